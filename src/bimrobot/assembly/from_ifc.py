"""A storey of an IFC model as a custom assembly scenario (``bimrobot assembly from-ifc``).

The storey's columns (``IfcColumn``) and beams (``IfcBeam``, and ``IfcMember`` when horizontal) are read
through :func:`bimrobot.bim.load_model` (model frame, metres, z up) and snapped to a voxel grid shaped like
the benchmark's: a bay of the grid is :data:`BAY_CELLS` cells and the storey's most common column is
:data:`COLUMN_CELLS` cells tall. A cell is therefore ``grid / 4`` metres along x and y (``grid``: the metres
given, or, of the most common column spacings along each axis, the pair that keeps the most beams) and a
quarter of that column height along z; voxels are boxes, not cubes. A column whose axis lies more than :data:`ON_GRID` of a cell from a grid line
is dropped as off-grid; a beam is kept when it rests on the tops of two kept columns of one grid line,
one bay apart, its cells the run between their top cells. Everything dropped is listed with the reason.

The scenario is the benchmark's in every other respect: a foundation under each column slot, the
components lying flat in a yard in front of the structure (rows along x at z = 1, columns first, in
handling order), each to its own slot unless ``interchangeable``. It is validated by
:func:`bimrobot.assembly.scenario.parse_scenario`, like any scenario file.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from bimrobot.assembly.scenario import MAX_COMPONENT_LENGTH, MAX_ENTRIES, MAX_GRID_CELLS, Scenario, parse_scenario
from bimrobot.core.errors import InputError

#: Cells per bay of the grid (the benchmark's columns stand 4 cells apart: x 5, 9, 13).
BAY_CELLS = 4
#: Cells of the storey's most common column (the benchmark's columns are 4 cells tall).
COLUMN_CELLS = 4
#: How far a column's axis may lie from a grid line, as a fraction of a cell.
ON_GRID = 0.25
#: Largest angle (degrees) between a beam's axis and the horizontal, and between its plan and x or y.
AXIS_TOLERANCE_DEG = 5.0
#: Coordinates closer than this (metres) are one grid line when the spacing is measured.
SAME_LINE_M = 0.05
#: Shortest column (metres) a frame stands on: shorter IfcColumns are cleats, stubs or pedestals
#: (ifcUnit.ifc exports its 0.25 m angle cleats as IfcColumn).
MIN_COLUMN_M = 1.0
#: Steps the time limit allows per component (the benchmark's Env4: 600 for 13).
STEPS_PER_COMPONENT = 50
BEAM_CLASSES = ("IfcBeam", "IfcMember")


@dataclass(frozen=True)
class Dropped:
    """An element of the storey that is not in the scenario, and why (one phrase)."""

    global_id: str
    ifc_class: str
    name: str
    reason: str


@dataclass(frozen=True)
class _Column:
    global_id: str
    name: str
    x: float  # axis, model frame, metres
    y: float
    base: float  # bottom and top z, metres
    top: float
    i: int = 0  # grid cell (relative to the grid origin)
    j: int = 0
    cells: int = 0  # height in cells


@dataclass
class FrameScenario:
    """What :func:`frame_scenario` made of one storey.

    ``data``: the scenario mapping (the YAML's content); ``scenario``: it, validated. ``cell``: the size
    of a cell along x, y and z (metres); ``origin``: the model-frame point (metres) where the corner of
    cell (0, 0, 1) lies. ``elements``: component id -> (GlobalId, IFC class, name). ``dropped``: what was
    left out. ``spacing``: the grid (metres) along x and y and whether it was measured (auto)."""

    model: str
    storey: str
    spacing: tuple[float, float]
    auto: bool
    cell: tuple[float, float, float]
    origin: tuple[float, float, float]
    data: dict
    scenario: Scenario
    elements: dict[str, tuple[str, str, str]]
    dropped: list[Dropped] = field(default_factory=list)
    read: Counter = field(default_factory=Counter)


# ----------------------------------------------------------------------------------------- options


def parse_grid(text: str) -> tuple[float, float] | None:
    """``--grid``: ``auto`` (None), ``METRES`` (both axes) or ``XxY`` metres; InputError otherwise."""
    if text.strip().lower() == "auto":
        return None
    parts = text.lower().split("x")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) not in (1, 2) or not all(math.isfinite(v) and 0.1 <= v <= 1000.0 for v in values):
        raise InputError(f"--grid must be 'auto', a spacing in metres (0.1 to 1000) or two as XxY (e.g. 6x7.2), got {text!r}")
    return (values[0], values[-1])


def _model_name(model) -> str:
    """The model's file name (a model built in memory: its project name)."""
    return Path(model.source).name if model.source else model.project_name


def find_storey(model, spec: str):
    """The storey named ``spec`` (exactly, then ignoring case) or with index ``spec`` (from 0, the model's
    order); InputError listing the storeys otherwise."""
    storeys = list(model.storeys)
    listing = "; ".join(f"{i} '{s.name}' ({s.elevation:g} m)" for i, s in enumerate(storeys)) or "none"
    for match in (lambda s: s.name == spec, lambda s: s.name.casefold() == spec.casefold()):
        found = [s for s in storeys if match(s)]
        if len(found) == 1:
            return found[0]
        if len(found) > 1:
            raise InputError(f"--storey '{spec}': {len(found)} storeys of {_model_name(model)} have that name; "
                             f"give its index instead (storeys: {listing})")
    if spec.strip().isdigit() and int(spec) < len(storeys):
        return storeys[int(spec)]
    raise InputError(f"--storey '{spec}': no such storey in {_model_name(model)} (storeys: {listing})")


# ------------------------------------------------------------------------------------------ reading


def _dropped(element, reason: str) -> Dropped:
    return Dropped(element.global_id, element.ifc_class, element.name, reason)


def _mode(values, step: float) -> float:
    """The most common of ``values`` rounded to ``step`` (ties: the smallest)."""
    counts = Counter(round(v / step) for v in values)
    best = max(counts.values())
    return min(k for k, n in counts.items() if n == best) * step


def _columns(model, storey, dropped: list[Dropped]) -> list[_Column]:
    """The storey's vertical IfcColumns as axes (the centre of their plan bounds, bottom and top z)."""
    columns = []
    for element in model.by_class("IfcColumn"):
        if element.storey_id != storey.global_id:
            continue
        low, high = element.world_bounds
        size = high - low
        if size[2] < MIN_COLUMN_M:
            dropped.append(_dropped(element, f"too short: {size[2]:.2f} m high, under {MIN_COLUMN_M:g} m (a cleat, a stub "
                                             "or a pedestal)"))
            continue
        if max(size[0], size[1]) > 0.5 * size[2]:
            dropped.append(_dropped(element, f"not vertical: {size[0]:.2f} x {size[1]:.2f} m in plan, {size[2]:.2f} m high"))
            continue
        centre = (low + high) / 2
        columns.append(_Column(element.global_id, element.name, float(centre[0]), float(centre[1]),
                               float(low[2]), float(high[2])))
    return columns


def _beam_axis(element, cell: float) -> tuple[int, np.ndarray, np.ndarray, float] | str:
    """(plan axis 0 x / 1 y, start, end, bottom) of a beam's axis (metres; z: the beam's top; bottom: the
    z of its underside), or why it is no beam; ``cell``: the height of a cell (metres): a piece shorter
    than half of it is no beam."""
    low, high = element.world_bounds
    if max(high - low) < cell / 2:
        return f"too short: {max(high - low):.2f} m long, under half a cell's height of {cell:.2f} m (a cleat, a plate or a stub)"
    vertices = np.unique(element.world_vertices.round(6), axis=0)
    centre = vertices.mean(axis=0)
    direction = np.linalg.svd(vertices - centre, full_matrices=False)[2][0]
    tolerance = math.sin(math.radians(AXIS_TOLERANCE_DEG))
    if abs(direction[2]) > tolerance:
        return f"inclined: {math.degrees(math.asin(min(1.0, abs(direction[2])))):.0f} degrees (a brace or a rafter)"
    axis = int(abs(direction[1]) > abs(direction[0]))
    if abs(direction[1 - axis]) > tolerance:
        return "diagonal in plan"
    middle = (low + high) / 2
    start, end = middle.copy(), middle.copy()
    start[axis], end[axis] = low[axis], high[axis]
    start[2] = end[2] = high[2]
    return axis, start, end, float(low[2])


def _offset(values: list[float], cell: float) -> float:
    """The grid origin along one axis (metres): the one that puts the most ``values`` on grid lines."""
    def on(offset: float) -> int:
        return sum(abs((v - offset) / cell - round((v - offset) / cell)) <= ON_GRID for v in values)

    return max(values, key=on)  # ties: the first column's


# ------------------------------------------------------------------------------------- the scenario


def frame_scenario(model, storey, grid: tuple[float, float] | None = None, interchangeable: bool = False,
                   name: str | None = None, source: str = "<from-ifc>") -> FrameScenario:
    """The scenario of ``storey``'s steel (or precast) frame; ``grid``: metres along x and y, or None to
    measure it (:func:`_best_grid`). Raises InputError for a storey without columns or beams, or one that
    the env's limits cannot hold at this grid."""
    model_name = _model_name(model)
    dropped: list[Dropped] = []
    read = Counter()
    columns = _columns(model, storey, dropped)
    read["IfcColumn"] = len(columns) + len(dropped)
    if columns:
        vertical, columns = _vertical_cell(columns, dropped)
    if not columns:
        raise _no_columns(model, storey, dropped)
    beams = _beam_axes(model, storey, vertical, read)
    dropped += [_dropped(element, axis) for element, axis in beams if isinstance(axis, str)]
    beams = [(element, axis) for element, axis in beams if not isinstance(axis, str)]
    spacing = _best_grid(columns, beams, vertical) if grid is None else (float(grid[0]), float(grid[1]))
    fit = _Fit(columns, beams, spacing)
    dropped += fit.dropped
    where = f"storey '{storey.name}' of {model_name}"
    if not fit.columns:
        raise InputError(f"{where}: none of its {read['IfcColumn']} columns is on the grid ({spacing[0]:g} x "
                         f"{spacing[1]:g} m; {_kinds(dropped)}); try another --grid")
    if not fit.beams:
        found = sum(read[c] for c in BEAM_CLASSES)
        raise InputError(f"{where}: none of its {found} beams rests on the tops of two of its {len(fit.columns)} columns "
                         f"on the grid ({spacing[0]:g} x {spacing[1]:g} m{'; ' + _kinds(dropped, BEAM_CLASSES) if found else ''}"
                         "), so there is no frame to assemble")
    base = _mode([c.base for c in fit.columns], SAME_LINE_M)
    cell = (*fit.cell, vertical)
    data, elements, origin = _layout(fit.columns, fit.beams, (*fit.offset, base), cell, interchangeable,
                                     name or f"{Path(model_name).stem}-{storey.name}", where)
    return FrameScenario(model_name, storey.name, spacing, grid is None, cell, origin, data,
                         parse_scenario(data, source=source), elements, dropped, read)


def _no_columns(model, storey, dropped: list[Dropped]) -> InputError:
    """The refusal of a storey without a column to build on: why its own were dropped, or which storeys
    have IfcColumns."""
    where = f"storey '{storey.name}' of {_model_name(model)}"
    if dropped:
        return InputError(f"{where}: none of its {len(dropped)} columns (IfcColumn) is a vertical column of "
                          f"{MIN_COLUMN_M:g} m or more on the storey's base ({_kinds(dropped)}), so there is no frame "
                          "to assemble")
    with_columns = Counter(model.storey(e.storey_id).name for e in model.by_class("IfcColumn") if e.storey_id)
    hint = ", ".join(f"'{s}' ({n})" for s, n in with_columns.items()) or "none"
    return InputError(f"{where} has no vertical columns (IfcColumn) to build a frame from; storeys with IfcColumns: {hint}")


def _vertical_cell(columns: list[_Column], dropped: list[Dropped]) -> tuple[float, list[_Column]]:
    """The z size of a cell (a quarter of the most common column height) and the columns that stand on
    the storey's base and are 1 to 4 cells tall, with their height in cells."""
    height = _mode([c.top - c.base for c in columns], SAME_LINE_M)
    height = height if height > 0 else max(c.top - c.base for c in columns)
    cell = height / COLUMN_CELLS
    base = _mode([c.base for c in columns], SAME_LINE_M)
    kept = []
    for c in columns:
        cells = round((c.top - c.base) / cell)
        if abs(c.base - base) > cell / 2:
            reason = f"off the storey's base: it stands at z = {c.base:.2f} m, the columns at z = {base:.2f} m"
        elif cells < 1:
            reason = f"too short: {c.top - c.base:.2f} m high, under half a cell of {cell:.2f} m (a stub or a cleat)"
        elif cells > MAX_COMPONENT_LENGTH:
            reason = (f"too tall: {c.top - c.base:.2f} m high, {cells} cells of {cell:.2f} m, and components are at "
                      f"most {MAX_COMPONENT_LENGTH} cells long")
        else:
            kept.append(replace(c, cells=cells))
            continue
        dropped.append(Dropped(c.global_id, "IfcColumn", c.name, reason))
    return cell, kept


#: Most spacings tried per axis by ``--grid auto`` (the most common ones).
GRID_CANDIDATES = 6


def _best_grid(columns: list[_Column], beams: list, vertical: float) -> tuple[float, float]:
    """``--grid auto``: among the most common spacings between neighbouring column lines along x and
    along y, the pair that keeps the most beams, then columns, within the env's grid (ties: the more
    common spacing). An axis with one column line takes the other's spacing; a single column, four cells
    of the column's height."""
    xs, ys = _spacings([c.x for c in columns]), _spacings([c.y for c in columns])
    xs, ys = xs or ys, ys or xs
    if not xs:
        return vertical * BAY_CELLS, vertical * BAY_CELLS
    best, best_score = (xs[0], ys[0]), None
    for rank_x, sx in enumerate(xs[:GRID_CANDIDATES]):
        for rank_y, sy in enumerate(ys[:GRID_CANDIDATES]):
            fit = _Fit(columns, beams, (sx, sy))
            score = (fit.fits, len(fit.beams), len(fit.columns), -(rank_x + rank_y))
            if best_score is None or score > best_score:
                best, best_score = (sx, sy), score
    return best


def _spacings(values: list[float]) -> list[float]:
    """Distances (metres, to the cm) between neighbouring grid lines among ``values``, most common first
    (ties: the larger)."""
    lines: list[float] = []
    for v in sorted(values):
        if not lines or v - lines[-1] > SAME_LINE_M:
            lines.append(v)
    counts = Counter(round(b - a, 2) for a, b in zip(lines, lines[1:]))
    return [gap for gap, _ in sorted(counts.items(), key=lambda item: (-item[1], -item[0]))]


class _Fit:
    """The columns and beams that one grid spacing (metres along x and y) keeps, and what it drops.

    ``cell``: the cell size in plan (metres); ``offset``: the grid origin (metres) that puts the most
    columns on grid lines; ``fits``: whether the kept frame's site fits the env's grid limits."""

    def __init__(self, columns: list[_Column], beams: list, spacing: tuple[float, float]):
        self.cell = (spacing[0] / BAY_CELLS, spacing[1] / BAY_CELLS)
        self.offset = (_offset([c.x for c in columns], self.cell[0]), _offset([c.y for c in columns], self.cell[1]))
        self.dropped: list[Dropped] = []
        self.columns = _snap_columns(columns, self.offset, self.cell, self.dropped)
        self.beams = _match_beams(beams, self.columns, self.offset, self.cell, self.dropped)
        self.fits = bool(self.columns) and _site_size(self.columns, self.beams) is not None


def _snap_columns(columns, offset, cell, dropped) -> list[_Column]:
    """Columns on grid lines, with their cell (i, j); the others dropped (off-grid, or a cell taken)."""
    kept, taken = [], {}
    for c in columns:
        ij, off = [], []
        for value, o, size in zip((c.x, c.y), offset, cell):
            k = round((value - o) / size)
            ij.append(k)
            off.append(value - (o + k * size))
        worst = int(abs(off[1]) > abs(off[0]))
        if abs(off[worst]) > ON_GRID * cell[worst]:
            reason = (f"off-grid: {abs(off[worst]):.2f} m from the nearest grid line along {'xy'[worst]} "
                      f"(more than {ON_GRID:g} of a {cell[worst]:.2f} m cell)")
        elif tuple(ij) in taken:
            reason = f"same cell: as column '{taken[tuple(ij)]}'"
        else:
            taken[tuple(ij)] = c.name
            kept.append(replace(c, i=ij[0], j=ij[1]))
            continue
        dropped.append(Dropped(c.global_id, "IfcColumn", c.name, reason))
    return kept


def _storeys_above(model, storey) -> set[str]:
    """The storey and the next one up (beams often belong to the storey at their top)."""
    ordered = sorted(model.storeys, key=lambda s: s.elevation)
    index = next(i for i, s in enumerate(ordered) if s.global_id == storey.global_id)
    return {s.global_id for s in ordered[index:index + 2]}


def _beam_axes(model, storey, vertical: float, read: Counter) -> list[tuple[object, object]]:
    """(element, its axis (:func:`_beam_axis`) or why it is no beam) of the IfcBeams and IfcMembers of the
    storey and of the next one up (beams often belong to the storey at their top)."""
    storeys = _storeys_above(model, storey)
    out = []
    for element in model.by_class(*BEAM_CLASSES):
        if element.storey_id in storeys:
            read[element.ifc_class] += 1
            out.append((element, _beam_axis(element, vertical)))
    return out


def _match_beams(beams, columns, offset, cell, dropped) -> list[tuple[object, int, _Column, _Column]]:
    """(element, plan axis, column at the start, column at the end) of every beam resting on two
    columns one bay apart, at their tops; the others dropped with the reason."""
    kept, seen = [], {}
    for element, (axis, start, end, bottom) in beams:
        reason, ends = _supports(axis, start, end, bottom, columns, offset, cell)
        if reason is None:
            key = (axis, ends[0].i, ends[0].j)
            if key in seen:
                reason = f"same cells: as beam '{seen[key]}'"
            else:
                seen[key] = element.name
                kept.append((element, axis, ends[0], ends[1]))
                continue
        dropped.append(_dropped(element, reason))
    return kept


def _supports(axis, start, end, bottom, columns, offset, cell):
    """(None, (column a, column b)) when the beam from ``start`` to ``end`` rests on the tops of two
    columns of one grid line one bay apart; (reason, None) otherwise."""
    across = 1 - axis
    k = round((start[across] - offset[across]) / cell[across])
    off = start[across] - (offset[across] + k * cell[across])
    if abs(off) > ON_GRID * cell[across]:
        return f"off-grid: {abs(off):.2f} m from the nearest grid line along {'xy'[across]}", None
    line = [c for c in columns if (c.j if axis == 0 else c.i) == k]
    position = (lambda c: c.x) if axis == 0 else (lambda c: c.y)
    ends = []
    for point in (start[axis], end[axis]):
        near = min(line, key=lambda c: abs(position(c) - point), default=None)
        if near is None or abs(position(near) - point) > cell[axis] + 1e-9:
            return f"not at a column: its end at {'xy'[axis]} = {point:.2f} m has no column of the storey on its grid line", None
        ends.append(near)
    a, b = sorted(ends, key=lambda c: c.i if axis == 0 else c.j)
    first, last = (a.i, b.i) if axis == 0 else (a.j, b.j)
    length = last - first - 1
    if length < 1:
        return "no bay: its ends are at one column or at columns in neighbouring cells", None
    inside = [c for c in line if first < (c.i if axis == 0 else c.j) < last]
    if inside:
        return f"over several bays: it runs over column '{inside[0].name}'", None
    if length > MAX_COMPONENT_LENGTH:
        return f"too long: {length} cells between its columns, and components are at most {MAX_COMPONENT_LENGTH}", None
    top = start[2]
    for c in (a, b):  # flush with the top, or resting on it: within half a cell of the beam's depth
        half = (c.top - c.base) / c.cells / 2
        if not bottom - half <= c.top <= top + half:
            return (f"not at the column tops: it spans z = {bottom:.2f} .. {top:.2f} m, column '{c.name}' ends at "
                    f"{c.top:.2f} m"), None
    if a.cells != b.cells:
        return f"columns of different heights: '{a.name}' {a.cells} cells, '{b.name}' {b.cells}", None
    return None, (a, b)


# -------------------------------------------------------------------------------------------- layout


def _layout(columns, beams, origin_m, cell, interchangeable, name, where):
    """The scenario mapping: targets (the structure), foundations, and a yard in front of the structure
    (rows along x at z = 1, y below the structure) where the components lie in handling order."""
    n = len(columns) + len(beams)
    if n > MAX_ENTRIES:
        raise InputError(f"{where} has {len(columns)} columns and {len(beams)} beams on the "
                         f"grid, {n} components; a scenario holds at most {MAX_ENTRIES} (try a storey or model part with fewer)")
    i0, j0, width, depth = _extent(columns)
    column_ids = {c.global_id: f"col{k}" for k, c in enumerate(sorted(columns, key=lambda c: (c.j, c.i)), start=1)}
    layout = _site_size(columns, beams)
    if layout is None:
        raise InputError(
            f"{where} spans {width} x {depth} cells at this grid (a bay is {BAY_CELLS} cells) "
            f"and its {n} components need a yard beside it: more than the env's {MAX_GRID_CELLS} cells per axis; "
            "try a larger --grid")
    W, L, yard_rows, starts = layout
    dx, dy = 1 - i0, yard_rows + 2 - j0  # cell of grid point (i, j): (i + dx, j + dy)
    H = 2 * max(c.cells for c in columns) + 1
    targets, components, elements = {}, [], {}
    for c in sorted(columns, key=lambda c: (c.j, c.i)):
        cid = column_ids[c.global_id]
        targets[cid] = {"type": "column", "cells": [[c.i + dx, c.j + dy, 1], [c.i + dx, c.j + dy, c.cells]]}
        elements[cid] = (c.global_id, "IfcColumn", c.name)
    ordered = sorted(beams, key=lambda b: (b[1], b[2].j, b[2].i))
    for k, (element, axis, a, b) in enumerate(ordered, start=1):
        bid = f"beam{k}"
        step = (1, 0) if axis == 0 else (0, 1)
        first = [a.i + dx + step[0], a.j + dy + step[1], a.cells]
        last = [b.i + dx - step[0], b.j + dy - step[1], a.cells]
        targets[bid] = {"type": "beam", "cells": [first, last]}
        elements[bid] = (element.global_id, element.ifc_class, element.name)
    for cid, start in zip(targets, starts):
        kind = targets[cid]["type"]
        cells = targets[cid]["cells"]
        length = max(abs(p - q) for p, q in zip(*cells)) + 1
        components.append({"id": cid, "type": kind, "length": length, "target": cid, "start": start})
    data = {
        "name": name,
        "description": f"{where}: {len(columns)} columns and {len(beams)} beams "
                       "(bimrobot assembly from-ifc)",
        "grid": [W, L, H],
        "time_limit": STEPS_PER_COMPONENT * n,
        "layout": "fixed",
        "interchangeable": bool(interchangeable),
        "construction_area": {"x": [dx + i0 - 1, min(W - 1, dx + i0 + width)], "y": [dy + j0 - 1, min(L - 1, dy + j0 + depth)]},
        "foundations": [[t["cells"][0][0], t["cells"][0][1]] for t in targets.values() if t["type"] == "column"],
        "targets": targets,
        "components": components,
    }
    cx, cy, cz = cell
    ox, oy, oz = origin_m
    # cell (x, y, z) holds the grid point (x - dx, y - dy): its centre at ox + (x - dx) cx; z = 1 starts at the base
    origin = (ox - (dx + 0.5) * cx, oy - (dy + 0.5) * cy, oz)
    return data, elements, origin


def _extent(columns: list[_Column]) -> tuple[int, int, int, int]:
    """(lowest i, lowest j, width, depth) of the columns' cells."""
    i0, j0 = min(c.i for c in columns), min(c.j for c in columns)
    return i0, j0, max(c.i for c in columns) - i0 + 1, max(c.j for c in columns) - j0 + 1


def _site_size(columns, beams):
    """:func:`_yard` of this frame, or None when it has more components than a scenario holds."""
    if len(columns) + len(beams) > MAX_ENTRIES:
        return None
    _, _, width, depth = _extent(columns)
    lengths = [c.cells for c in columns] + [_beam_cells(a, b, axis) for _, axis, a, b in beams]
    return _yard(lengths, width, depth)


def _beam_cells(a: _Column, b: _Column, axis: int) -> int:
    return (b.i - a.i - 1) if axis == 0 else (b.j - a.j - 1)


def _yard(lengths: list[int], width: int, depth: int):
    """(W, L, rows, start poses) of a grid holding the structure (``width`` x ``depth`` cells, a margin
    of one cell all round) and, in front of it, yard rows along x where the components (``lengths``, in
    handling order) lie end to end at z = 1; the narrowest W (at least the structure's) that keeps L
    within the env's limit, or None."""
    for W in range(max(width + 2, max(lengths) + 2), MAX_GRID_CELLS + 1):
        starts, row, x = [], 1, 1
        for n in lengths:
            if x + n > W - 1:
                row, x = row + 1, 1
            starts.append([[x + n - 1, row, 1], [x, row, 1]])
            x += n
        L = row + 1 + depth + 1 + 1  # margin row 0, yard rows 1..row, a free row, the structure, a margin
        if L <= MAX_GRID_CELLS:
            return W, L, row, starts
    return None


# -------------------------------------------------------------------------------------------- output


def scenario_yaml(result: FrameScenario, signature_line: str) -> str:
    """The scenario file: a header (what it came from, the grid, each component's element, what was
    dropped) and the mapping, in the format :func:`~bimrobot.assembly.scenario.load_scenario` reads."""
    import yaml

    cx, cy, cz = result.cell
    lines = [
        f"# {signature_line}",
        f"# Storey '{result.storey}' of {result.model} as a custom assembly scenario (docs/assembly.md).",
        f"# Grid {result.spacing[0]:g} x {result.spacing[1]:g} m ({'auto: the column spacings that keep the most beams' if result.auto else 'given'}); "
        f"a cell is {cx:.3f} x {cy:.3f} x {cz:.3f} m (x, y, z);",
        f"# the corner of cell (0, 0, 1) lies at ({result.origin[0]:.3f}, {result.origin[1]:.3f}, {result.origin[2]:.3f}) m "
        "in the model frame (z up).",
        "# Components and the IFC elements they stand for:",
    ]
    lines += [f"#   {cid}: {gid} {cls} '{name}'" for cid, (gid, cls, name) in result.elements.items()]
    if result.dropped:
        lines.append(f"# Dropped ({len(result.dropped)}):")
        lines += [f"#   {d.global_id} {d.ifc_class} '{d.name}': {d.reason}" for d in result.dropped]
    body = yaml.dump(_flow_runs(result.data), Dumper=_yaml_dumper(), sort_keys=False, default_flow_style=False, width=120,
                     allow_unicode=True)
    return "\n".join(lines) + "\n" + body


class _Flow(list):
    """A list written on one line (``[[1, 2, 1], [1, 2, 4]]``), as the benchmark's setting files do."""


class _FlowMap(dict):
    """A mapping written on one line (a component entry)."""


def _flow_runs(value, key: str = ""):
    """``value`` with every list of numbers or of number lists marked :class:`_Flow`, and the component
    entries :class:`_FlowMap`."""
    if isinstance(value, dict):
        return {k: _flow_runs(v, k) for k, v in value.items()}
    if key == "components":
        return [_FlowMap({k: _flow_runs(v) for k, v in entry.items()}) for entry in value]
    if isinstance(value, list):
        if all(isinstance(v, (int, float)) or (isinstance(v, list) and all(isinstance(w, (int, float)) for w in v))
               for v in value):
            return _Flow(value)
        return [_flow_runs(v) for v in value]
    return value


def _yaml_dumper():
    import yaml

    class Dumper(yaml.SafeDumper):
        pass

    Dumper.add_representer(_Flow, lambda dumper, data: dumper.represent_sequence(
        "tag:yaml.org,2002:seq", data, flow_style=True))
    Dumper.add_representer(_FlowMap, lambda dumper, data: dumper.represent_mapping(
        "tag:yaml.org,2002:map", data.items(), flow_style=True))
    return Dumper


def _kinds(dropped: list[Dropped], classes=None) -> str:
    """``3 inclined, 2 off-grid``: how many were dropped for each kind of reason."""
    counts = Counter(_kind(d.reason) for d in dropped if classes is None or d.ifc_class in classes)
    return ", ".join(f"{n} {kind}" for kind, n in counts.items()) or "none dropped"


def _kind(reason: str) -> str:
    return reason.split(":")[0].split(" (")[0]


def dropped_summary(dropped: list[Dropped], shown: int = 3) -> list[str]:
    """One line per reason kind: how many elements, and the first few names."""
    groups: dict[str, list[Dropped]] = {}
    for d in dropped:
        groups.setdefault(_kind(d.reason), []).append(d)
    out = []
    for kind, items in groups.items():
        names = ", ".join(f"{d.ifc_class} '{d.name}'" for d in items[:shown]) + (", ..." if len(items) > shown else "")
        out.append(f"{len(items)} {kind}: {names} ({items[0].reason})")
    return out
