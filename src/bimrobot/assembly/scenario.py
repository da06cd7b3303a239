"""Assembly scenarios: the voxel site, its components and targets, loaded from YAML and validated.

A scenario is pure data. The grid is a box of unit cells indexed ``(x, y, z)`` with z up; ``z = 0`` is
the ground (foundations live there) and components occupy cells with ``z >= 1``. A component is a
straight run of ``length`` cells between two end nodes (node1 -> node2).

:func:`load_scenario` reads and validates a YAML file; :func:`benchmark_scenario` returns one of the 16
benchmark settings ("E1S1" .. "E4S4") shipped in ``settings/``. :func:`compile_scenario` turns a scenario
into the lookup tables the environment, the batched simulator and the planner share.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from bimrobot.core.config import check_keys, parse_yaml, read_yaml_file
from bimrobot.core.errors import InputError
from bimrobot.core.schema import (At, Choice, Custom, Flag, Integer, Quantity, Rule, Text, Vector, keys_of, read_key, read_keys,
                             rule)

SETTINGS_DIR = Path(__file__).with_name("settings")
#: The benchmark settings ("E1S1" .. "E4S4"): the scenario files of ``settings/``, sorted. A file added
#: there is a setting (and, through :mod:`bimrobot.assembly`, a Gymnasium environment).
SETTINGS = sorted(path.stem for path in SETTINGS_DIR.glob("*.yaml"))
COMPONENT_LENGTHS = {"column": 4, "beam": 3}
MAX_LAYOUT_ATTEMPTS = 1000
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


# --------------------------------------------------------------------------------------------- loading


def benchmark_scenario(setting: str) -> Scenario:
    """One of the 16 benchmark settings, e.g. ``benchmark_scenario("E2S2")``."""
    if setting not in SETTINGS:
        raise InputError(f"unknown assembly setting '{setting}': expected one of {', '.join(SETTINGS)}")
    return _cached_benchmark(setting)


@functools.lru_cache(maxsize=None)
def setting_time_limit(setting: str) -> int:
    """The episode length of a benchmark setting, steps: its file's ``time_limit``, read without building
    the scenario (Gymnasium's TimeLimit gets it when :mod:`bimrobot.assembly` registers the settings).

    Only the file's top-level ``time_limit:`` line is parsed (the whole file, 16 times, added about 0.1 s
    to ``import bimrobot.assembly``); a file without one is read whole."""
    if setting not in SETTINGS:
        raise InputError(f"unknown assembly setting '{setting}': expected one of {', '.join(SETTINGS)}")
    path = SETTINGS_DIR / f"{setting}.yaml"
    text = path.read_text(encoding="utf-8")
    line = next((n for n, line in enumerate(text.splitlines()) if line.startswith("time_limit:")), None)
    data = parse_yaml(text if line is None else "\n" * line + text.splitlines()[line], str(path))  # same line number
    return read_key(data, "time_limit", Scenario, At(str(path), path=True), 100)


@functools.lru_cache(maxsize=None)
def _cached_benchmark(setting: str) -> Scenario:
    return load_scenario(SETTINGS_DIR / f"{setting}.yaml")


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file (see docs/assembly.md for the format)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: scenario file not found")
    data = _read_yaml(path)
    if not isinstance(data, dict):
        raise InputError(f"{path}: a scenario file must be a YAML mapping")
    data.setdefault("name", path.stem)
    return parse_scenario(data, source=str(path))


def _read_yaml(path: Path) -> Any:
    return read_yaml_file(path, "scenario file")


def parse_scenario(data: dict[str, Any], source: str = "<memory>") -> Scenario:
    """Build a :class:`Scenario` from a plain mapping (the YAML content) and validate it.

    Each key is read by the rule :class:`Scenario` declares for it (:mod:`bimrobot.core.schema`), the grid
    first: every number is checked against its range as it is read, and every coordinate against the
    grid, so nothing grid-sized is allocated before the whole file is known to fit (:data:`MAX_GRID_CELLS`
    per axis). Messages name the file, the line (when the mapping comes from
    :func:`bimrobot.core.config.parse_yaml`) and the key.
    """
    import copy

    data = copy.deepcopy(data)  # keeps parse_yaml's line numbers (LineDict survives deepcopy)
    at = At(source, path=True)
    _mapping(data, replace(at, key="the file"))
    check_keys(data, keys_of(Scenario), source)
    at = replace(at, context=read_key(data, "grid", Scenario, at, [15, 15, 9]))
    defaults = {"time_limit": 100, "interchangeable": False, "layout": "fixed", "name": "scenario", "description": ""}
    values = {key: read_key(data, key, Scenario, at, defaults.get(key))
              for key in ("reward", "time_limit", "targets", "components", "interchangeable", "foundations", "layout",
                          "obstacles", "yard", "construction_area", "name", "description")}
    if values["interchangeable"] is True:  # every type (and, through the cells, every beam axis) is one group
        groups = (tuple(t.id for t in values["targets"] if t.type == ttype) for ttype in COMPONENT_LENGTHS)
        values["interchangeable"] = tuple(group for group in groups if len(group) > 1)
    scenario = Scenario(grid=at.context, source=source, **values)
    validate_scenario(scenario)
    return scenario


# ------------------------------------------------------------------------------------------ validation


def validate_scenario(sc: Scenario) -> None:
    """Raise InputError naming the entry when the scenario cannot be simulated as described."""
    src = sc.source
    W, L, H = sc.grid

    def inside(cell: Cell) -> bool:
        return 0 <= cell[0] < W and 0 <= cell[1] < L and 0 <= cell[2] < H

    if min(sc.grid) < 2 or max(sc.grid) > MAX_GRID_CELLS:  # a Scenario built in code, not read by parse_scenario
        raise InputError(f"{src}: grid {list(sc.grid)} must be 2 to {MAX_GRID_CELLS} cells along every axis")
    if sc.layout not in ("fixed", "random"):
        raise InputError(f"{src}: layout: expected 'fixed' or 'random', got {sc.layout!r}")
    if sc.time_limit < 1:
        raise InputError(f"{src}: time_limit must be a positive number of steps, got {sc.time_limit}")
    if sc.reward.epsilon < 0:
        raise InputError(f"{src}: reward.epsilon must be >= 0, got {sc.reward.epsilon}")
    for i, (x, y) in enumerate(sc.foundations):
        if not inside((x, y, 0)):
            raise InputError(f"{src}: foundations[{i}] ({x}, {y}) lies outside the {W} x {L} grid")
    for i, box in enumerate(sc.obstacles):
        for cell in (box.x[0], box.y[0], box.z[0]), (box.x[1], box.y[1], box.z[1]):
            if not inside(cell):
                raise InputError(f"{src}: obstacles[{i}] reaches {cell}, outside the {W} x {L} x {H} grid")
        if box.z[0] < 1:
            raise InputError(f"{src}: obstacles[{i}] must start at z >= 1 (z = 0 is the ground)")
    # the union of the boxes on a grid first: overlapping boxes never list a cell twice
    occupied = np.zeros(sc.grid, bool)
    for box in sc.obstacles:
        occupied[box.x[0]:box.x[1] + 1, box.y[0]:box.y[1] + 1, box.z[0]:box.z[1] + 1] = True
    obstacle_cells = set(map(tuple, np.argwhere(occupied).tolist()))

    ids = [t.id for t in sc.targets]
    if len(set(ids)) != len(ids):
        raise InputError(f"{src}: targets: duplicate target id")
    target_owner: dict[Cell, str] = {}
    for t in sc.targets:
        for cell in t.cells:
            if not inside(cell) or cell[2] < 1:
                raise InputError(f"{src}: targets.{t.id}: cell {cell} is outside the grid (x < {W}, y < {L}, 1 <= z < {H})")
            if cell in target_owner:
                raise InputError(f"{src}: targets.{t.id} overlaps targets.{target_owner[cell]} at {cell}")
            if cell in obstacle_cells:
                raise InputError(f"{src}: targets.{t.id} overlaps an obstacle at {cell}")
            target_owner[cell] = t.id
        if t.type == "column" and (t.node1[0], t.node1[1]) not in sc.foundations:
            raise InputError(f"{src}: targets.{t.id}: column slot at ({t.node1[0]}, {t.node1[1]}) has no foundation")
        if t.type == "column" and t.axis != 2:
            raise InputError(f"{src}: targets.{t.id}: a column slot must be vertical")
        if t.type == "column" and min(c[2] for c in t.cells) != 1:
            raise InputError(f"{src}: targets.{t.id}: a column slot must stand on its foundation (bottom z = 1)")
        if t.type == "beam" and t.axis == 2:
            raise InputError(f"{src}: targets.{t.id}: a beam slot must be horizontal")
        if t.type == "beam":
            supports = beam_supports(sc, t)
            if any(s is None for s in supports):
                raise InputError(
                    f"{src}: targets.{t.id}: unsupported beam: it needs a column slot whose top cell is next to "
                    f"each of its ends at z = {t.node1[2]}"
                )

    comp_ids = [c.id for c in sc.components]
    if len(set(comp_ids)) != len(comp_ids):
        raise InputError(f"{src}: components: duplicate component id")
    if not sc.handled:
        raise InputError(f"{src}: components: at least one component must be handled (not prebuilt)")
    for group in sc.interchangeable:
        for tid in group:
            if tid not in ids:
                raise InputError(f"{src}: interchangeable: unknown target '{tid}'")
    used_targets: dict[str, str] = {}
    for c in sc.components:
        where = f"{src}: components.{c.id}"
        if c.target not in ids:
            raise InputError(f"{where}: unknown target '{c.target}'")
        t = sc.target(c.target)
        if t.type != c.type or t.length != c.length:
            raise InputError(f"{where}: a {c.type} of length {c.length} cannot fill targets.{t.id} ({t.type}, {t.length} cells)")
        if c.target in used_targets:
            raise InputError(f"{where}: target '{c.target}' is already the target of {used_targets[c.target]}")
        used_targets[c.target] = c.id
        if c.prebuilt:
            if c.type == "beam" and len(sc.group_of(c.target)) > 1:
                raise InputError(f"{where}: a prebuilt beam cannot stand on an interchangeable slot")
            continue
        if sc.layout == "fixed":
            if c.start is None:
                raise InputError(f"{where}: a fixed layout needs a start [[x, y, z], [x, y, z]]")
            if len(run_cells(*c.start)) != c.length:
                raise InputError(f"{where}: start spans {len(run_cells(*c.start))} cells, a {c.type} has {c.length}")
            for cell in run_cells(*c.start):
                if not inside(cell) or cell[2] < 1:
                    raise InputError(f"{where}: start cell {cell} is outside the grid (x < {W}, y < {L}, 1 <= z < {H})")
    _validate_order(sc)
    if sc.layout == "fixed":
        _validate_fixed_layout(sc, obstacle_cells)
    else:
        if not sc.yard:
            raise InputError(f"{src}: a random layout needs a yard (node1 sampling regions)")
        _check_random_layout_possible(sc)


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


def _validate_order(sc: Scenario) -> None:
    """Columns must come before the beams they rest on (or be prebuilt), per interchangeable group."""
    handled = list(sc.handled)
    for i, c in enumerate(handled):
        if c.type != "beam":
            continue
        for sup in beam_supports(sc, sc.target(c.target)):
            group = sc.group_of(sup)
            fillers = [
                x for x in sc.components
                if x.type == "column" and x.target in group and (x.prebuilt or handled.index(x) < i)
            ]
            needed = len(group) if len(group) > 1 else 1
            if len(group) == 1 and not fillers:
                raise InputError(
                    f"{sc.source}: components.{c.id}: its supporting column slot '{sup}' is filled by no component "
                    "handled before it (columns must come before the beams they support)"
                )
            if len(group) > 1 and len(fillers) < needed:
                raise InputError(
                    f"{sc.source}: components.{c.id}: the column slots of group {list(group)} are not all filled "
                    "before this beam is handled (columns must come before the beams they support)"
                )


def _validate_fixed_layout(sc: Scenario, obstacle_cells: set[Cell]) -> None:
    """Start poses must not overlap each other, obstacles, foundations or targets; pick-ups must succeed."""
    owner: dict[Cell, str] = {}
    for c in sc.handled:
        for cell in run_cells(*c.start):
            if cell in owner:
                raise InputError(f"{sc.source}: components.{c.id}: start overlaps components.{owner[cell]} at {cell}")
            if cell in obstacle_cells:
                raise InputError(f"{sc.source}: components.{c.id}: start overlaps an obstacle at {cell}")
            if (cell[0], cell[1]) in sc.foundations and cell[2] == 1:
                raise InputError(f"{sc.source}: components.{c.id}: start lies on a foundation at {cell}")
            owner[cell] = c.id
    starts = {c.id: run_cells(*c.start) for c in sc.handled}
    placed_cells = {cell for c in sc.prebuilt for cell in sc.target(c.target).cells}
    for c in sc.handled:
        # cells still occupied when c is picked up: later components' start poses, obstacles, prebuilt
        waiting = {cell for other in sc.handled[sc.handled.index(c) + 1:] for cell in starts[other.id]}
        blocked = obstacle_cells | waiting | placed_cells
        if lifted_pose(sc, c, c.start, blocked) is None:
            raise InputError(
                f"{sc.source}: components.{c.id}: the crane cannot lift it free of other objects below z = {sc.grid[2] - 1}"
            )


def _check_random_layout_possible(sc: Scenario) -> None:
    rng = np.random.default_rng(0)
    sample_layout(compile_scenario(sc), rng)  # raises InputError after MAX_LAYOUT_ATTEMPTS failures


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


# ------------------------------------------------------------------------------------------ compiled


@dataclass
class CompiledScenario:
    """Flat lookup tables of a scenario, shared by the env, the batched simulator and the planner.

    Cells are flattened as ``index = (x * L + y) * H + z``. Components are indexed in handling order
    (``comp``), targets in scenario order (``target``).
    """

    scenario: Scenario
    W: int
    L: int
    H: int
    n_comp: int
    n_target: int
    comp_type: list[str]
    comp_len: list[int]
    comp_axis: list[int]  # axis after pick-up (columns z, beams their target's axis)
    comp_arrival: list[dict[int, int]]  # per comp: flat min corner -> target index it may fill there
    target_cells: list[list[int]]  # flat cell indices per target
    target_supports: list[tuple[int, ...]]  # target indices that must be filled first (beams)
    target_top: np.ndarray  # (n_target, W, L) int8, top z of each target over (x, y), 0 elsewhere
    target_fp: np.ndarray  # (n_target, W, L) bool footprint
    static_blocked: np.ndarray  # (W*L*H,) uint8: ground and obstacles
    obstacle_top: np.ndarray  # (W, L) int8
    prebuilt_slots: list[list[int]]  # per prebuilt component: the target indices it may stand on
    n_total: int  # components standing at the end (handled + prebuilt)
    fixed_starts: list[tuple[Cell, Cell]] | None
    yard_x: list[int] = field(default_factory=list)  # node1 x values of random layouts
    yard_y: dict[int, tuple[int, int]] = field(default_factory=dict)  # x -> (y lo, y hi)
    foundation_xy: set = field(default_factory=set)

    def flat(self, x: int, y: int, z: int) -> int:
        return (x * self.L + y) * self.H + z

    def unflat(self, index: int) -> Cell:
        xy, z = divmod(index, self.H)
        x, y = divmod(xy, self.L)
        return x, y, z

    def stride(self, axis: int) -> int:
        return (self.L * self.H, self.H, 1)[axis]


@functools.lru_cache(maxsize=64)
def _compile_cached(sc: Scenario) -> CompiledScenario:
    return _compile(sc)


def compile_scenario(sc: Scenario) -> CompiledScenario:
    """Lookup tables for ``sc`` (cached per scenario object)."""
    return _compile_cached(sc)


def _compile(sc: Scenario) -> CompiledScenario:
    W, L, H = sc.grid
    tindex = {t.id: i for i, t in enumerate(sc.targets)}

    def flat(cell: Cell) -> int:
        return (cell[0] * L + cell[1]) * H + cell[2]

    handled = sc.handled
    comp_axis = [2 if c.type == "column" else sc.target(c.target).axis for c in handled]
    comp_arrival = []
    for c, axis in zip(handled, comp_axis):
        table = {}
        for tid in sc.group_of(c.target):
            t = sc.target(tid)
            if t.length == c.length and t.type == c.type and t.axis == axis:
                table[flat(t.cells[0])] = tindex[tid]
        comp_arrival.append(table)
    target_top = np.zeros((len(sc.targets), W, L), np.int8)
    target_fp = np.zeros((len(sc.targets), W, L), bool)
    for i, t in enumerate(sc.targets):
        for x, y, z in t.cells:
            target_top[i, x, y] = max(target_top[i, x, y], z)
            target_fp[i, x, y] = True
    supports = []
    for t in sc.targets:
        supports.append(tuple(tindex[s] for s in beam_supports(sc, t)) if t.type == "beam" else ())
    blocked = np.zeros((W, L, H), np.uint8)
    blocked[:, :, 0] = 1
    obstacle_top = np.zeros((W, L), np.int8)
    for box in sc.obstacles:
        blocked[box.x[0]:box.x[1] + 1, box.y[0]:box.y[1] + 1, box.z[0]:box.z[1] + 1] = 1
        region = obstacle_top[box.x[0]:box.x[1] + 1, box.y[0]:box.y[1] + 1]
        np.maximum(region, box.z[1], out=region)
    yard_y: dict[int, tuple[int, int]] = {}
    for box in sc.yard:
        for x in range(box.x[0], box.x[1] + 1):
            yard_y.setdefault(x, box.y)
    return CompiledScenario(
        scenario=sc,
        W=W, L=L, H=H,
        n_comp=len(handled),
        n_target=len(sc.targets),
        comp_type=[c.type for c in handled],
        comp_len=[c.length for c in handled],
        comp_axis=comp_axis,
        comp_arrival=comp_arrival,
        target_cells=[[flat(c) for c in t.cells] for t in sc.targets],
        target_supports=supports,
        target_top=target_top,
        target_fp=target_fp,
        static_blocked=blocked.reshape(-1),
        obstacle_top=obstacle_top,
        prebuilt_slots=[[tindex[t] for t in sc.group_of(c.target)] for c in sc.prebuilt],
        n_total=len(sc.components),
        fixed_starts=[c.start for c in handled] if sc.layout == "fixed" else None,
        yard_x=sorted(yard_y),
        yard_y=yard_y,
        foundation_xy=set(sc.foundations),
    )


# ------------------------------------------------------------------------------------------ resets


def sample_prebuilt_slots(cs: CompiledScenario, rng: np.random.Generator) -> list[int]:
    """Target index each prebuilt component stands on: uniform over its group (one draw each)."""
    slots = []
    taken: set[int] = set()
    for options in cs.prebuilt_slots:
        free = [t for t in options if t not in taken]
        if len(options) > 1:
            slot = free[int(rng.random() * len(free))]
        else:
            slot = options[0]
        taken.add(slot)
        slots.append(slot)
    return slots


def _fits_somewhere(cs: CompiledScenario, length: int, occupied: bytearray) -> bool:
    cells = _lying_candidates(cs, length)[0]
    if not len(cells):
        return False
    return not np.frombuffer(bytes(occupied), np.uint8)[cells].any(axis=1).all()


def _lying_candidates(cs: CompiledScenario, length: int):
    """Every lying pose of a run of ``length`` at z = 1 with node1 in the yard, clear of obstacles and
    foundations: its (x, y) cell indices (K, length) and its (axis, node1, node2). Cached."""
    cache = cs.__dict__.setdefault("_lying_candidates", {})
    if length not in cache:
        cells, poses = [], []
        for x in cs.yard_x:
            ylo, yhi = cs.yard_y[x]
            for y in range(ylo, yhi + 1):
                for axis in (0, 1):
                    run = [(x - k, y) if axis == 0 else (x, y - k) for k in range(length)]
                    if all(
                        0 <= cx < cs.W and 0 <= cy < cs.L
                        and not cs.static_blocked[(cx * cs.L + cy) * cs.H + 1]
                        and (cx, cy) not in cs.foundation_xy
                        for cx, cy in run
                    ):
                        cells.append([cx * cs.L + cy for cx, cy in run])
                        poses.append((axis, (x, y, 1), (run[-1][0], run[-1][1], 1)))
        cache[length] = (np.array(cells, np.int64).reshape(-1, length), poses)
    return cache[length]


def _lying_table(cs: CompiledScenario, length: int) -> list:
    """Index ``(axis * W + x) * L + y`` of node1 -> the (x, y) cell indices of the lying run, or None when
    it leaves the grid or touches an obstacle or a foundation (cached on the compiled scenario)."""
    cache = cs.__dict__.setdefault("_lying_table", {})
    if length not in cache:
        table: list = [None] * (2 * cs.W * cs.L)
        cells, poses = _lying_candidates(cs, length)
        for run, (axis, node1, _) in zip(cells.tolist(), poses):
            table[(axis * cs.W + node1[0]) * cs.L + node1[1]] = tuple(run)
        cache[length] = table
    return cache[length]


def sample_layout(cs: CompiledScenario, rng: np.random.Generator) -> list[tuple[Cell, Cell]]:
    """A random initial layout: every handled component flat at z = 1 in the yard, along x or y.

    For each component in handling order: the axis is x or y (1/2 each), node1's x uniform over the yard's
    x values and its y uniform over the range of the yard region that holds that x; node2 = node1 -
    (length - 1) along the axis. A draw that overlaps another component, an obstacle or a foundation is
    redrawn; a component that fits nowhere (checked exactly after every 32 failed draws) redraws the whole
    layout, at most MAX_LAYOUT_ATTEMPTS times, then InputError. The uniforms come from
    ``rng.random(192)`` blocks, three per draw (axis, x, y).
    """
    xs = cs.yard_x
    n_x = len(xs)
    L = cs.L
    axis_offset = cs.W * cs.L  # index offset of axis y in the run tables
    y_ranges = [(cs.yard_y[x][0], cs.yard_y[x][1] - cs.yard_y[x][0] + 1) for x in xs]
    tables = [_lying_table(cs, n) for n in cs.comp_len]
    for _ in range(MAX_LAYOUT_ATTEMPTS):
        occupied = bytearray(cs.W * cs.L)
        layout: list[tuple[Cell, Cell]] = []
        uniforms: list[float] = []
        used = 0
        for ci, table in enumerate(tables):
            failures = 0
            while True:
                if used == len(uniforms):
                    uniforms, used = rng.random(192).tolist(), 0
                axis_u, x_u, y_u = uniforms[used], uniforms[used + 1], uniforms[used + 2]
                used += 3
                xi = int(x_u * n_x)
                ylo, ny = y_ranges[xi]
                cells = table[(axis_offset if axis_u >= 0.5 else 0) + xs[xi] * L + ylo + int(y_u * ny)]
                if cells is not None:
                    for c in cells:
                        if occupied[c]:
                            break
                    else:
                        for c in cells:
                            occupied[c] = 1
                        first, last = cells[0], cells[-1]
                        layout.append(((first // L, first % L, 1), (last // L, last % L, 1)))
                        break
                failures += 1
                if failures % 32 == 0 and not _fits_somewhere(cs, cs.comp_len[ci], occupied):
                    break
            if len(layout) <= ci:
                break  # this component fits nowhere: redraw the whole layout
        else:
            return layout
    raise InputError(
        f"{cs.scenario.source}: impossible random layout: the yard cannot hold all {cs.n_comp} components "
        f"without overlaps in {MAX_LAYOUT_ATTEMPTS} attempts"
    )
