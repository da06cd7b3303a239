"""Whether a scenario can be simulated as described: the checks :func:`validate_scenario` runs, in order.

The file rules of :mod:`bimrobot.assembly.scenario_model` already hold every number to its range as the
file is read; these rules look at the scenario as a whole (a Scenario built in code gets the range checks
again). Each raises :class:`~bimrobot.core.errors.InputError` naming the file and the entry.
"""

from __future__ import annotations

import numpy as np

from bimrobot.assembly.compiled import compile_scenario, sample_layout
from bimrobot.assembly.scenario_model import (MAX_GRID_CELLS, Cell, Component, Scenario, Target, beam_supports,
                                             lifted_pose, run_cells)
from bimrobot.core.errors import InputError


def validate_scenario(sc: Scenario) -> None:
    """Raise InputError naming the entry when the scenario cannot be simulated as described.

    The checks run in this order and the first failure is reported: the numbers (for a Scenario built in
    code), the foundations and obstacles, the target slots, the components, the handling order, then the
    start poses of a fixed layout or the yard of a random one.
    """
    _check_numbers(sc)
    obstacle_cells = _check_foundations_and_obstacles(sc)
    _check_targets(sc, obstacle_cells)
    _check_components(sc)
    _validate_order(sc)
    if sc.layout == "fixed":
        _validate_fixed_layout(sc, obstacle_cells)
    else:
        if not sc.yard:
            raise InputError(f"{sc.source}: a random layout needs a yard (node1 sampling regions)")
        _check_random_layout_possible(sc)


def _inside(sc: Scenario, cell: Cell) -> bool:
    """Whether ``cell`` lies in the scenario's grid."""
    W, L, H = sc.grid
    return 0 <= cell[0] < W and 0 <= cell[1] < L and 0 <= cell[2] < H


def _check_numbers(sc: Scenario) -> None:
    """Grid size, layout, time limit and epsilon (a Scenario built in code, not read by parse_scenario)."""
    src = sc.source
    if min(sc.grid) < 2 or max(sc.grid) > MAX_GRID_CELLS:
        raise InputError(f"{src}: grid {list(sc.grid)} must be 2 to {MAX_GRID_CELLS} cells along every axis")
    if sc.layout not in ("fixed", "random"):
        raise InputError(f"{src}: layout: expected 'fixed' or 'random', got {sc.layout!r}")
    if sc.time_limit < 1:
        raise InputError(f"{src}: time_limit must be a positive number of steps, got {sc.time_limit}")
    if sc.reward.epsilon < 0:
        raise InputError(f"{src}: reward.epsilon must be >= 0, got {sc.reward.epsilon}")


def _check_foundations_and_obstacles(sc: Scenario) -> set[Cell]:
    """Foundations and obstacle boxes inside the grid, obstacles above the ground; returns the obstacle cells."""
    src = sc.source
    W, L, H = sc.grid
    for i, (x, y) in enumerate(sc.foundations):
        if not _inside(sc, (x, y, 0)):
            raise InputError(f"{src}: foundations[{i}] ({x}, {y}) lies outside the {W} x {L} grid")
    for i, box in enumerate(sc.obstacles):
        for cell in (box.x[0], box.y[0], box.z[0]), (box.x[1], box.y[1], box.z[1]):
            if not _inside(sc, cell):
                raise InputError(f"{src}: obstacles[{i}] reaches {cell}, outside the {W} x {L} x {H} grid")
        if box.z[0] < 1:
            raise InputError(f"{src}: obstacles[{i}] must start at z >= 1 (z = 0 is the ground)")
    # the union of the boxes on a grid first: overlapping boxes never list a cell twice
    occupied = np.zeros(sc.grid, bool)
    for box in sc.obstacles:
        occupied[box.x[0]:box.x[1] + 1, box.y[0]:box.y[1] + 1, box.z[0]:box.z[1] + 1] = True
    return set(map(tuple, np.argwhere(occupied).tolist()))


def _check_targets(sc: Scenario, obstacle_cells: set[Cell]) -> None:
    """Unique target ids; every slot inside the grid above the ground, clear of other slots and obstacles."""
    ids = [t.id for t in sc.targets]
    if len(set(ids)) != len(ids):
        raise InputError(f"{sc.source}: targets: duplicate target id")
    target_owner: dict[Cell, str] = {}
    for t in sc.targets:
        _check_target_cells(sc, t, target_owner, obstacle_cells)
        _check_slot_shape(sc, t)


def _check_target_cells(sc: Scenario, t: Target, target_owner: dict[Cell, str], obstacle_cells: set[Cell]) -> None:
    """The cells of slot ``t`` inside the grid at z >= 1, owned by no earlier slot (recorded in ``target_owner``)."""
    src = sc.source
    W, L, H = sc.grid
    for cell in t.cells:
        if not _inside(sc, cell) or cell[2] < 1:
            raise InputError(f"{src}: targets.{t.id}: cell {cell} is outside the grid (x < {W}, y < {L}, 1 <= z < {H})")
        if cell in target_owner:
            raise InputError(f"{src}: targets.{t.id} overlaps targets.{target_owner[cell]} at {cell}")
        if cell in obstacle_cells:
            raise InputError(f"{src}: targets.{t.id} overlaps an obstacle at {cell}")
        target_owner[cell] = t.id


def _check_slot_shape(sc: Scenario, t: Target) -> None:
    """A column slot stands vertical on a foundation; a beam slot is horizontal with a column slot at each end."""
    src = sc.source
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


def _check_components(sc: Scenario) -> None:
    """Unique component ids, at least one handled, known targets (each filled by one component of its type
    and length), and a start pose for every handled component of a fixed layout."""
    src = sc.source
    comp_ids = [c.id for c in sc.components]
    if len(set(comp_ids)) != len(comp_ids):
        raise InputError(f"{src}: components: duplicate component id")
    if not sc.handled:
        raise InputError(f"{src}: components: at least one component must be handled (not prebuilt)")
    ids = [t.id for t in sc.targets]
    for group in sc.interchangeable:
        for tid in group:
            if tid not in ids:
                raise InputError(f"{src}: interchangeable: unknown target '{tid}'")
    used_targets: dict[str, str] = {}
    for c in sc.components:
        _check_component_target(sc, c, ids, used_targets)
        if c.prebuilt:
            if c.type == "beam" and len(sc.group_of(c.target)) > 1:
                raise InputError(f"{src}: components.{c.id}: a prebuilt beam cannot stand on an interchangeable slot")
        elif sc.layout == "fixed":
            _check_start(sc, c)


def _check_component_target(sc: Scenario, c: Component, ids: list[str], used_targets: dict[str, str]) -> None:
    """Component ``c`` fills a known slot of its type and length that no earlier component fills."""
    where = f"{sc.source}: components.{c.id}"
    if c.target not in ids:
        raise InputError(f"{where}: unknown target '{c.target}'")
    t = sc.target(c.target)
    if t.type != c.type or t.length != c.length:
        raise InputError(f"{where}: a {c.type} of length {c.length} cannot fill targets.{t.id} ({t.type}, {t.length} cells)")
    if c.target in used_targets:
        raise InputError(f"{where}: target '{c.target}' is already the target of {used_targets[c.target]}")
    used_targets[c.target] = c.id


def _check_start(sc: Scenario, c: Component) -> None:
    """A handled component of a fixed layout has a start pose of its length, inside the grid at z >= 1."""
    where = f"{sc.source}: components.{c.id}"
    W, L, H = sc.grid
    if c.start is None:
        raise InputError(f"{where}: a fixed layout needs a start [[x, y, z], [x, y, z]]")
    if len(run_cells(*c.start)) != c.length:
        raise InputError(f"{where}: start spans {len(run_cells(*c.start))} cells, a {c.type} has {c.length}")
    for cell in run_cells(*c.start):
        if not _inside(sc, cell) or cell[2] < 1:
            raise InputError(f"{where}: start cell {cell} is outside the grid (x < {W}, y < {L}, 1 <= z < {H})")


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

