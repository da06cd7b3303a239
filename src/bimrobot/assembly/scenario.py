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
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bimrobot.config import check_keys, line_of, read_yaml_file
from bimrobot.errors import InputError

SETTINGS_DIR = Path(__file__).with_name("settings")
SETTINGS = [f"E{e}S{s}" for e in range(1, 5) for s in range(1, 5)]
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

#: The keys of a target entry and of a component entry (docs/assembly.md).
TARGET_KEYS = ("type", "cells")
COMPONENT_KEYS = ("id", "type", "length", "start", "target", "prebuilt")

Cell = tuple[int, int, int]


@dataclass(frozen=True)
class Reward:
    """Reward constants (thesis eq. 6.1-6.2): step cost ``r0 / c`` (doubled after ``epsilon`` steps on a
    component), ``+k`` for a placement with k components standing, ``+k + completion_bonus`` for the last."""

    r0: float = -1.0
    epsilon: int = 15
    completion_bonus: float = 10.0


@dataclass(frozen=True)
class Box:
    """An inclusive box of cells: x in x[0]..x[1], y in y[0]..y[1], z in z[0]..z[1]."""

    x: tuple[int, int]
    y: tuple[int, int]
    z: tuple[int, int] = (0, 0)

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


@dataclass(frozen=True)
class Scenario:
    """One assembly setting: site, components in handling order, targets, dynamics constants."""

    name: str
    grid: tuple[int, int, int]
    time_limit: int
    components: tuple[Component, ...]
    targets: tuple[Target, ...]
    foundations: tuple[tuple[int, int], ...] = ()
    obstacles: tuple[Box, ...] = ()
    layout: str = "fixed"  # "fixed" or "random"
    yard: tuple[Box, ...] = ()  # node1 sampling regions of random layouts (z ignored)
    construction_area: Box | None = None
    interchangeable: tuple[tuple[str, ...], ...] = ()  # groups of target ids
    reward: Reward = field(default_factory=Reward)
    description: str = ""
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

    Every number is checked against its range as it is read, and every coordinate against the grid, so
    nothing grid-sized is allocated before the whole file is known to fit (:data:`MAX_GRID_CELLS` per axis).
    Messages name the file, the line (when the mapping comes from :func:`bimrobot.config.parse_yaml`) and
    the key.
    """
    import copy

    data = copy.deepcopy(data)  # keeps parse_yaml's line numbers (LineDict survives deepcopy)
    p = _Parser(source)
    p.mapping(data, "the file", "")
    known = {
        "name", "description", "grid", "time_limit", "reward", "foundations", "obstacles", "layout", "yard",
        "construction_area", "targets", "components", "interchangeable",
    }
    check_keys(data, known, source)
    p.read_grid(data.get("grid", [15, 15, 9]), line_of(data, "grid"))
    reward_data = p.mapping(data.get("reward") or {}, "reward", line_of(data, "reward"))
    check_keys(reward_data, ("r0", "epsilon", "completion_bonus"), source, "reward")

    def reward_line(key: str) -> str:
        return line_of(reward_data, key) or line_of(data, "reward")

    # r0 < 0: the planner's optimality rests on every step costing something
    reward = Reward(
        r0=p.real(reward_data.get("r0", -1.0), "reward.r0", reward_line("r0"), low=-MAX_REWARD, high=0.0, high_open=True),
        epsilon=p.integer(reward_data.get("epsilon", 15), "reward.epsilon", reward_line("epsilon"), 0, MAX_TIME_LIMIT),
        completion_bonus=p.real(
            reward_data.get("completion_bonus", 10.0), "reward.completion_bonus", reward_line("completion_bonus"),
            low=0.0, high=MAX_REWARD,
        ),
    )
    time_limit = p.integer(data.get("time_limit", 100), "time_limit", line_of(data, "time_limit"), 1, MAX_TIME_LIMIT)
    targets_data = p.mapping(data.get("targets") or {}, "targets", line_of(data, "targets"))
    p.count(targets_data, "targets", line_of(data, "targets"))
    targets = []
    for tid, tdata in targets_data.items():
        where = f"targets.{tid}"
        line = line_of(targets_data, tid)
        tdata = p.mapping(tdata, where, line)
        check_keys(tdata, TARGET_KEYS, source, where)
        ttype = p.component_type(tdata.get("type"), where, line_of(tdata, "type") or line)
        node1, node2 = p.run(tdata.get("cells"), f"{where}.cells", line_of(tdata, "cells") or line)
        targets.append(Target(str(tid), ttype, node1, node2))
    components_data = p.sequence(data.get("components") or [], "components", line_of(data, "components"))
    p.count(components_data, "components", line_of(data, "components"))
    components = []
    for i, cdata in enumerate(components_data):
        cdata = p.mapping(cdata, f"components[{i}]", line_of(data, "components"))
        cid = str(cdata.get("id", f"#{i}"))
        where = f"components.{cid}"
        line = f" line {cdata.line}" if getattr(cdata, "line", None) else line_of(data, "components")
        check_keys(cdata, COMPONENT_KEYS, source, where)
        ctype = p.component_type(cdata.get("type"), where, line_of(cdata, "type") or line)
        length = p.integer(
            cdata.get("length", COMPONENT_LENGTHS[ctype]), f"{where}.length", line_of(cdata, "length") or line,
            1, MAX_COMPONENT_LENGTH,
        )
        start_line = line_of(cdata, "start") or line
        start = p.run(cdata["start"], f"{where}.start", start_line) if cdata.get("start") is not None else None
        target = str(cdata.get("target", cid))
        prebuilt = cdata.get("prebuilt", False)
        if not isinstance(prebuilt, bool):
            raise p.fail(f"{where}.prebuilt", f"expected true or false, got {prebuilt!r}", line_of(cdata, "prebuilt") or line)
        components.append(Component(cid, ctype, length, target, start, prebuilt))
    interchangeable = data.get("interchangeable", False)
    interchangeable_line = line_of(data, "interchangeable")
    if interchangeable is True:  # every type (and, through the cells, every beam axis) is one group
        groups = []
        for ttype in COMPONENT_LENGTHS:
            group = tuple(t.id for t in targets if t.type == ttype)
            if len(group) > 1:
                groups.append(group)
        interchangeable = groups
    elif interchangeable is False or interchangeable is None:
        interchangeable = []
    elif not isinstance(interchangeable, list) or not all(isinstance(g, list) for g in interchangeable):
        raise p.fail("interchangeable", f"expected true, false or a list of target-id lists, got {interchangeable!r}",
                     interchangeable_line)

    def boxes(key: str) -> tuple[Box, ...]:
        items = p.sequence(data.get(key) or [], key, line_of(data, key))
        p.count(items, key, line_of(data, key))
        return tuple(p.box(b, f"{key}[{i}]", _item_line(b, line_of(data, key))) for i, b in enumerate(items))

    foundations_data = p.sequence(data.get("foundations") or [], "foundations", line_of(data, "foundations"))
    p.count(foundations_data, "foundations", line_of(data, "foundations"))
    layout = data.get("layout", "fixed")
    if layout not in ("fixed", "random"):
        raise p.fail("layout", f"expected 'fixed' or 'random', got {layout!r}", line_of(data, "layout"))
    scenario = Scenario(
        name=str(data.get("name", "scenario")),
        grid=p.grid,
        time_limit=time_limit,
        components=tuple(components),
        targets=tuple(targets),
        foundations=tuple(
            p.pair(f, f"foundations[{i}]", line_of(data, "foundations")) for i, f in enumerate(foundations_data)
        ),
        obstacles=boxes("obstacles"),
        layout=layout,
        yard=boxes("yard"),
        construction_area=(
            p.box(data["construction_area"], "construction_area", line_of(data, "construction_area"))
            if data.get("construction_area") else None
        ),
        interchangeable=tuple(tuple(str(t) for t in g) for g in interchangeable),
        reward=reward,
        description=str(data.get("description", "")),
        source=source,
    )
    validate_scenario(scenario)
    return scenario


def _item_line(item: Any, fallback: str) -> str:
    """`` line N`` of a mapping item of a YAML list (its own line), else ``fallback``."""
    line = getattr(item, "line", None)
    return f" line {line}" if line else fallback


class _Parser:
    """Small typed readers that raise InputError naming the file, the line and the offending key.

    Every coordinate is checked against the grid (read first) as it is read, so a number like 10**6
    in a cell never reaches a ``range()`` or an array shape.
    """

    def __init__(self, source: str):
        self.source = source
        self.grid: Cell = (0, 0, 0)

    def fail(self, where: str, what: str, line: str = "") -> InputError:
        return InputError(f"{self.source}{line}: {where}: {what}")

    def mapping(self, value: Any, where: str, line: str) -> dict:
        if not isinstance(value, dict):
            raise self.fail(where, f"expected a mapping (key: value lines), got {value!r}", line)
        return value

    def sequence(self, value: Any, where: str, line: str) -> list:
        if not isinstance(value, list):
            raise self.fail(where, f"expected a list, got {value!r}", line)
        return value

    def count(self, items: Any, where: str, line: str) -> None:
        if len(items) > MAX_ENTRIES:
            raise self.fail(where, f"{len(items)} entries; a scenario holds at most {MAX_ENTRIES}", line)

    def integer(self, value: Any, where: str, line: str = "", low: int | None = None, high: int | None = None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(where, f"expected an integer, got {value!r}", line)
        if (low is not None and value < low) or (high is not None and value > high):
            raise self.fail(where, f"must be an integer from {low} to {high}, got {value}", line)
        return value

    def real(self, value: Any, where: str, line: str, low: float, high: float, high_open: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(where, f"expected a number, got {value!r}", line)
        if not math.isfinite(value) or value < low or value > high or (high_open and value == high):
            upper = f"< {high:g}" if high_open else f"<= {high:g}"
            shown = f"{value:g}" if isinstance(value, float) or abs(value) < 10**15 else "a huge number"
            raise self.fail(where, f"must be a finite number >= {low:g} and {upper}, got {shown}", line)
        return float(value)

    def read_grid(self, value: Any, line: str) -> None:
        if not isinstance(value, list) or len(value) != 3:
            raise self.fail("grid", f"expected [W, L, H] cells, got {value!r}", line)
        dims = [self.integer(v, "grid", line) for v in value]
        if min(dims) < 2 or max(dims) > MAX_GRID_CELLS:
            raise self.fail(
                "grid",
                f"{dims} must be 2 to {MAX_GRID_CELLS} cells along every axis (the benchmark's grid is 15 x 15 x 9; "
                "larger grids exceed what the batched simulator and the planner are sized for)",
                line,
            )
        self.grid = tuple(dims)  # type: ignore[assignment]

    def cell(self, value: Any, where: str, line: str) -> Cell:
        if not isinstance(value, list) or len(value) != 3:
            raise self.fail(where, f"expected [x, y, z], got {value!r}", line)
        cell = tuple(self.integer(v, where, line) for v in value)
        W, L, H = self.grid
        if not all(0 <= c < n for c, n in zip(cell, self.grid)):
            raise self.fail(where, f"cell {cell} is outside the grid (0 <= x < {W}, 0 <= y < {L}, 0 <= z < {H})", line)
        return cell  # type: ignore[return-value]

    def pair(self, value: Any, where: str, line: str) -> tuple[int, int]:
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(where, f"expected [x, y], got {value!r}", line)
        x, y = (self.integer(v, where, line) for v in value)
        W, L, _ = self.grid
        if not (0 <= x < W and 0 <= y < L):
            raise self.fail(where, f"({x}, {y}) lies outside the {W} x {L} grid", line)
        return x, y

    def run(self, value: Any, where: str, line: str) -> tuple[Cell, Cell]:
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(where, f"expected [[x, y, z], [x, y, z]] (node1, node2), got {value!r}", line)
        node1, node2 = self.cell(value[0], where, line), self.cell(value[1], where, line)
        if sum(a != b for a, b in zip(node1, node2)) > 1:
            raise self.fail(where, f"{list(node1)} -> {list(node2)} is not a straight run along x, y or z", line)
        return node1, node2

    def component_type(self, value: Any, where: str, line: str) -> str:
        if not isinstance(value, str) or value not in COMPONENT_LENGTHS:
            raise self.fail(where, f"unknown component type {value!r} (expected one of {', '.join(COMPONENT_LENGTHS)})", line)
        return value

    def box(self, value: Any, where: str, line: str) -> Box:
        if not isinstance(value, dict):
            raise self.fail(where, f"expected a box {{x: [lo, hi], y: [lo, hi], z: [lo, hi]}}, got {value!r}", line)
        check_keys(value, ("x", "y", "z"), self.source, where)
        ranges = {}
        for axis, size in zip(("x", "y", "z"), self.grid):
            rng = value.get(axis, [0, 0])
            axis_line = line_of(value, axis) or line
            if not isinstance(rng, list) or len(rng) != 2:
                raise self.fail(f"{where}.{axis}", f"expected [lo, hi], got {rng!r}", axis_line)
            lo, hi = (self.integer(v, f"{where}.{axis}", axis_line) for v in rng)
            if lo > hi:
                raise self.fail(where, f"{axis} range {[lo, hi]} is empty", axis_line)
            if lo < 0 or hi >= size:
                raise self.fail(where, f"{axis} range {[lo, hi]} leaves the grid (0 <= {axis} < {size})", axis_line)
            ranges[axis] = (lo, hi)
        return Box(ranges["x"], ranges["y"], ranges["z"])


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
