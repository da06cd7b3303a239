"""A compiled scenario: the flat lookup tables the environment, the batched simulator and the planner
share (:func:`compile_scenario`), and the draws of a reset from them (prebuilt slots, random layouts).

Cells are flattened as ``index = (x * L + y) * H + z`` (x, y, z in cells, z up).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from bimrobot.assembly.scenario_model import Cell, Scenario, beam_supports
from bimrobot.core.errors import InputError

MAX_LAYOUT_ATTEMPTS = 1000


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
