"""A scenario as data: the voxel site's parts, the :class:`Scenario`, and how each key of its file is read.

A scenario is pure data. The grid is a box of unit cells indexed ``(x, y, z)`` with z up; ``z = 0`` is
the ground (foundations live there) and components occupy cells with ``z >= 1``. A component is a
straight run of ``length`` cells between two end nodes (node1 -> node2).

Besides the data: the geometry every later step asks of it, :func:`run_cells` (the cells of a run),
:func:`beam_supports` (the column slots a beam rests on) and :func:`lifted_pose` (where the crane lifts a
component to). Loading is :mod:`bimrobot.assembly.scenario`, checking :mod:`bimrobot.assembly.scenario_rules`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from bimrobot.core.config import check_keys
from bimrobot.core.schema import (At, Choice, Custom, Flag, Integer, Quantity, Rule, Text, Vector, keys_of, read_key, read_keys,
                             rule)

COMPONENT_LENGTHS = {"column": 4, "beam": 3}
#: Largest grid a scenario may ask for, cells per axis: the benchmark's is 15 x 15 x 9; observations are
#: int8 (z <= 127) and the batched simulator keeps W x L x H bytes per environment.
MAX_GRID_CELLS = 64
#: Most entries in one list of a scenario (targets, components, obstacles, ...): channel 5 of the
#: observation counts standing components in an int8.
MAX_ENTRIES = 100
#: A component spans at most 4 cells (the batched simulator reads a move's cells as one uint32).
MAX_COMPONENT_LENGTH = 4
#: Longest episode a scenario may ask for, steps (the benchmark's longest is 600).
MAX_TIME_LIMIT = 100_000
#: Largest magnitude of a reward constant (the benchmark's are -1 and 10).
MAX_REWARD = 1e6

Cell = tuple[int, int, int]


#: A box's cells along one axis: [lo, hi], inclusive.
_SPAN = Vector(Integer(), "[lo, hi]")


@dataclass(frozen=True)
class Reward:
    """Reward constants (thesis eq. 6.1-6.2): step cost ``r0 / c`` (doubled after ``epsilon`` steps on a
    component), ``+k`` for a placement with k components standing, ``+k + completion_bonus`` for the last."""

    # r0 < 0: the planner's optimality rests on every step costing something
    r0: float = field(default=-1.0, metadata=rule(Quantity(-MAX_REWARD, 0.0, high_open=True)))
    epsilon: int = field(default=15, metadata=rule(Integer(0, MAX_TIME_LIMIT)))
    completion_bonus: float = field(default=10.0, metadata=rule(Quantity(0.0, MAX_REWARD)))


@dataclass(frozen=True)
class Box:
    """An inclusive box of cells: x in x[0]..x[1], y in y[0]..y[1], z in z[0]..z[1]."""

    x: tuple[int, int] = field(metadata=rule(_SPAN))
    y: tuple[int, int] = field(metadata=rule(_SPAN))
    z: tuple[int, int] = field(default=(0, 0), metadata=rule(_SPAN))

    def cells(self) -> list[Cell]:
        return [
            (x, y, z)
            for x in range(self.x[0], self.x[1] + 1)
            for y in range(self.y[0], self.y[1] + 1)
            for z in range(self.z[0], self.z[1] + 1)
        ]


@dataclass(frozen=True)
class Target:
    """A slot of the structure: the exact cells a component must occupy to be placed."""

    id: str
    type: str
    node1: Cell
    node2: Cell

    @property
    def cells(self) -> list[Cell]:
        return run_cells(self.node1, self.node2)

    @property
    def axis(self) -> int:
        return run_axis(self.node1, self.node2)

    @property
    def length(self) -> int:
        return len(self.cells)


@dataclass(frozen=True)
class Component:
    """A prefabricated column or beam. ``start`` is its lying pose (node1, node2) for fixed layouts
    (None for random layouts and prebuilt components); ``target`` is the id of its own slot."""

    id: str
    type: str
    length: int
    target: str
    start: tuple[Cell, Cell] | None = None
    prebuilt: bool = False


# ------------------------------------------------------------------------------------- file rules
# How each key of a scenario file is read (bimrobot.core.schema); coordinates are checked against the grid
# (``At.context``, read first) as they are read, so a number like 10**6 in a cell never reaches a
# ``range()`` or an array shape.


def _mapping(value: Any, at: At) -> dict:
    if not isinstance(value, dict):
        raise at.fail(f"expected a mapping (key: value lines), got {value!r}")
    return value


def _entries(value: Any, at: At, kind: type = list) -> Any:
    """``value``, a list (or a ``kind``) of at most :data:`MAX_ENTRIES` entries."""
    if not isinstance(value, kind):
        raise at.fail(f"expected a list, got {value!r}")
    if len(value) > MAX_ENTRIES:
        raise at.fail(f"{len(value)} entries; a scenario holds at most {MAX_ENTRIES}")
    return value


def _item(value: Any, at: At, key: str) -> At:
    """The place of a list item: the item's own line when it is a mapping, else the list's."""
    line = getattr(value, "line", None)
    return replace(at, key=key, line=f" line {line}" if line else at.line)


_DIMS, _CELL, _PAIR = (Vector(Integer(), shape, (n,)) for shape, n in (("[W, L, H] cells", 3), ("[x, y, z]", 3), ("[x, y]", 2)))


@dataclass(frozen=True)
class _Grid(Rule):
    """[W, L, H]: 2 to :data:`MAX_GRID_CELLS` cells along every axis."""

    def read(self, value: Any, at: At) -> Cell:
        dims = _DIMS.read(value, at)
        if min(dims) < 2 or max(dims) > MAX_GRID_CELLS:
            raise at.fail(f"{list(dims)} must be 2 to {MAX_GRID_CELLS} cells along every axis (the benchmark's grid is "
                          "15 x 15 x 9; larger grids exceed what the batched simulator and the planner are sized for)")
        return dims


def _cell(value: Any, at: At) -> Cell:
    cell = _CELL.read(value, at)
    W, L, H = at.context
    if not all(0 <= c < n for c, n in zip(cell, at.context)):
        raise at.fail(f"cell {cell} is outside the grid (0 <= x < {W}, 0 <= y < {L}, 0 <= z < {H})")
    return cell


@dataclass(frozen=True)
class _Run(Rule):
    """A straight run of cells [node1, node2] along x, y or z."""

    def read(self, value: Any, at: At) -> tuple[Cell, Cell]:
        if not isinstance(value, list) or len(value) != 2:
            raise at.fail(f"expected [[x, y, z], [x, y, z]] (node1, node2), got {value!r}")
        node1, node2 = _cell(value[0], at), _cell(value[1], at)
        if sum(a != b for a, b in zip(node1, node2)) > 1:
            raise at.fail(f"{list(node1)} -> {list(node2)} is not a straight run along x, y or z")
        return node1, node2


@dataclass(frozen=True)
class _ComponentType(Rule):
    """column or beam (:data:`COMPONENT_LENGTHS`); messages name the entry."""

    def read(self, value: Any, at: At) -> str:
        if not isinstance(value, str) or value not in COMPONENT_LENGTHS:
            raise replace(at, key="").fail(
                f"unknown component type {value!r} (expected one of {', '.join(COMPONENT_LENGTHS)})")
        return value


@dataclass(frozen=True)
class _Box(Rule):
    """A box {x: [lo, hi], y: [lo, hi], z: [lo, hi]} inside the grid (an axis left out: [0, 0])."""

    def read(self, value: Any, at: At) -> Box:
        if not isinstance(value, dict):
            raise at.fail(f"expected a box {{x: [lo, hi], y: [lo, hi], z: [lo, hi]}}, got {value!r}")
        entry = at.entry()
        check_keys(value, keys_of(Box), at.source, entry.where)
        spans = {}
        for axis, size in zip(keys_of(Box), at.context):
            axis_at = entry.of(value, axis)
            lo, hi = spans[axis] = _SPAN.read(value.get(axis, [0, 0]), axis_at)
            if lo > hi:
                raise replace(axis_at, key="").fail(f"{axis} range {[lo, hi]} is empty")
            if lo < 0 or hi >= size:
                raise replace(axis_at, key="").fail(f"{axis} range {[lo, hi]} leaves the grid (0 <= {axis} < {size})")
        return Box(**spans)


def _boxes(value: Any, at: At) -> tuple[Box, ...]:
    items = _entries(value or [], at)
    return tuple(_Box().read(b, _item(b, at, f"{at.key}[{i}]")) for i, b in enumerate(items))


def _foundations(value: Any, at: At) -> tuple[tuple[int, int], ...]:
    W, L, _ = at.context
    pairs = []
    for i, item in enumerate(_entries(value or [], at)):
        x, y = _PAIR.read(item, replace(at, key=f"foundations[{i}]"))
        if not (0 <= x < W and 0 <= y < L):
            raise replace(at, key=f"foundations[{i}]").fail(f"({x}, {y}) lies outside the {W} x {L} grid")
        pairs.append((x, y))
    return tuple(pairs)


@dataclass(frozen=True)
class TargetEntry:
    """The keys of a target entry (docs/assembly.md): ``targets: {id: {type, cells}}``."""

    type: str = field(metadata=rule(_ComponentType()))
    cells: tuple[Cell, Cell] = field(metadata=rule(_Run()))


@dataclass(frozen=True)
class ComponentEntry:
    """The keys of a component entry (docs/assembly.md); ``id`` and ``target`` default to ``#i`` and the id."""

    id: str = field(metadata=rule(Text()))
    type: str = field(metadata=rule(_ComponentType()))
    length: int = field(metadata=rule(Integer(1, MAX_COMPONENT_LENGTH)))
    start: tuple[Cell, Cell] | None = field(metadata=rule(_Run()))
    target: str = field(metadata=rule(Text()))
    prebuilt: bool = field(metadata=rule(Flag()))


def _targets(value: Any, at: At) -> tuple[Target, ...]:
    targets_data = _entries(_mapping(value or {}, at), at, dict)
    targets = []
    for tid, tdata in targets_data.items():
        entry = at.entry().of(targets_data, tid).entry()
        tdata = _mapping(tdata, entry)
        check_keys(tdata, keys_of(TargetEntry), at.source, entry.where)
        ttype = read_key(tdata, "type", TargetEntry, entry)
        targets.append(Target(str(tid), ttype, *read_key(tdata, "cells", TargetEntry, entry)))
    return tuple(targets)


def _components(value: Any, at: At) -> tuple[Component, ...]:
    components = []
    for i, cdata in enumerate(_entries(value or [], at)):
        cdata = _mapping(cdata, replace(at, key=f"components[{i}]"))
        cid = str(cdata.get("id", f"#{i}"))
        entry = replace(_item(cdata, at, ""), where=f"components.{cid}")
        check_keys(cdata, keys_of(ComponentEntry), at.source, entry.where)
        ctype = read_key(cdata, "type", ComponentEntry, entry)
        length = read_key(cdata, "length", ComponentEntry, entry, COMPONENT_LENGTHS[ctype])
        start = read_key(cdata, "start", ComponentEntry, entry) if cdata.get("start") is not None else None
        prebuilt = read_key(cdata, "prebuilt", ComponentEntry, entry, False)
        components.append(Component(cid, ctype, length, str(cdata.get("target", cid)), start, prebuilt))
    return tuple(components)


def _groups(value: Any, at: At) -> Any:
    """``interchangeable``: true (every type's slots one group), false (none) or lists of target ids."""
    if value is True:
        return True
    if value is False or value is None:
        return ()
    if not isinstance(value, list) or not all(isinstance(g, list) for g in value):
        raise at.fail(f"expected true, false or a list of target-id lists, got {value!r}")
    return tuple(tuple(str(t) for t in g) for g in value)


def _reward(value: Any, at: At) -> Reward:
    return Reward(**read_keys(_mapping(value or {}, at), Reward, at.entry()))


def _area(value: Any, at: At) -> Box | None:
    return _Box().read(value, at) if value else None


@dataclass(frozen=True)
class Scenario:
    """One assembly setting: site, components in handling order, targets, dynamics constants."""

    name: str = field(metadata=rule(Text()))
    grid: tuple[int, int, int] = field(metadata=rule(_Grid()))
    time_limit: int = field(metadata=rule(Integer(1, MAX_TIME_LIMIT)))
    components: tuple[Component, ...] = field(metadata=rule(Custom(_components)))
    targets: tuple[Target, ...] = field(metadata=rule(Custom(_targets)))
    foundations: tuple[tuple[int, int], ...] = field(default=(), metadata=rule(Custom(_foundations)))
    obstacles: tuple[Box, ...] = field(default=(), metadata=rule(Custom(_boxes)))
    layout: str = field(default="fixed", metadata=rule(Choice(("fixed", "random"), "'fixed' or 'random'")))
    #: node1 sampling regions of random layouts (z ignored)
    yard: tuple[Box, ...] = field(default=(), metadata=rule(Custom(_boxes)))
    construction_area: Box | None = field(default=None, metadata=rule(Custom(_area)))
    #: groups of target ids
    interchangeable: tuple[tuple[str, ...], ...] = field(default=(), metadata=rule(Custom(_groups)))
    reward: Reward = field(default_factory=Reward, metadata=rule(Custom(_reward)))
    description: str = field(default="", metadata=rule(Text()))
    source: str = "<memory>"

    @property
    def handled(self) -> tuple[Component, ...]:
        """Components the agent moves, in handling order."""
        return tuple(c for c in self.components if not c.prebuilt)

    @property
    def prebuilt(self) -> tuple[Component, ...]:
        return tuple(c for c in self.components if c.prebuilt)

    def target(self, target_id: str) -> Target:
        return next(t for t in self.targets if t.id == target_id)

    def group_of(self, target_id: str) -> tuple[str, ...]:
        """Target ids a component whose own target is ``target_id`` may fill."""
        for group in self.interchangeable:
            if target_id in group:
                return group
        return (target_id,)

    @property
    def is_stochastic(self) -> bool:
        """True when resets differ between seeds (random layout, or a prebuilt column on a random slot)."""
        return self.layout == "random" or any(len(self.group_of(c.target)) > 1 for c in self.prebuilt)


def run_axis(node1: Cell, node2: Cell) -> int:
    """Axis (0 x, 1 y, 2 z) along which two end nodes differ; a one-cell run counts as z."""
    diff = [i for i in range(3) if node1[i] != node2[i]]
    return diff[0] if diff else 2


def run_cells(node1: Cell, node2: Cell) -> list[Cell]:
    """The cells of the straight run from node1 to node2 (inclusive), in increasing order."""
    axis = run_axis(node1, node2)
    lo, hi = sorted((node1[axis], node2[axis]))
    cells = []
    for v in range(lo, hi + 1):
        cell = list(node1)
        cell[axis] = v
        cells.append(tuple(cell))
    return cells


# --------------------------------------------------------------------------------- slots and pick-ups


def beam_supports(sc: Scenario, target: Target) -> tuple[str | None, str | None]:
    """Ids of the column slots whose top cells touch the two ends of a beam slot (None when missing)."""
    cells = target.cells
    axis = target.axis
    result = []
    for end, step in ((cells[0], -1), (cells[-1], +1)):
        probe = list(end)
        probe[axis] += step
        probe = tuple(probe)
        found = None
        for t in sc.targets:
            if t.type == "column" and max(t.cells, key=lambda c: c[2]) == probe:
                found = t.id
        result.append(found)
    return result[0], result[1]


def lifted_pose(sc: Scenario, comp: Component, start: tuple[Cell, Cell], blocked: set[Cell]) -> tuple[Cell, int] | None:
    """Pick-up pose (min corner, axis) of a component lying at ``start``, lifted free of ``blocked`` cells.

    A column stands up on its node1 (x, y) with its bottom one cell above its lowest start cell; a beam
    rises to its target's height and turns about its centre onto its target's axis. Poses leaving the
    grid in x or y are shifted inward by the fewest cells; then the crane lifts the component one cell at
    a time until it is free. Returns None when it is not free below the top of the grid.
    """
    W, L, H = sc.grid
    node1, node2 = start
    n = comp.length
    if comp.type == "column":
        axis = 2
        corner = [node1[0], node1[1], min(node1[2], node2[2]) + 1]
    else:
        target = sc.target(comp.target)
        axis = target.axis
        cells = run_cells(node1, node2)
        centre = cells[(len(cells) - 1) // 2]
        corner = [centre[0], centre[1], target.node1[2]]
        corner[axis] -= (n - 1) // 2
    size = [W, L]
    for a in (0, 1):
        extent = n if a == axis else 1
        corner[a] = min(max(corner[a], 0), size[a] - extent)
    top = H - (n if axis == 2 else 1)
    for z in range(corner[2], top + 1):
        base = (corner[0], corner[1], z)
        cells = [tuple(base[i] + (k if i == axis else 0) for i in range(3)) for k in range(n)]
        if not any(cell in blocked for cell in cells):
            return base, axis
    return None
