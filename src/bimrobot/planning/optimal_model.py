"""The CP-SAT model of one problem (:mod:`bimrobot.planning.optimal`, whose docstring describes it):
its costs in ticks (0.01 s), its variables and constraints built step by step (:func:`_build`), and the
market's schedule given as the first solution (:func:`_add_hint`). Positions in the site frame (m)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from bimrobot.coordination.market import handling_time, incapability
from bimrobot.core.errors import InputError
from bimrobot.core.tasks import Task
from bimrobot.planning.optimal_bounds import _floor_loads, _Visits
from bimrobot.planning.optimal_graph import _closure, _Task, _ticks
from bimrobot.site.fleet import Fleet


@dataclass
class _Problem:
    """One CP-SAT problem: ``tasks`` (a whole build or one floor), the robots' start positions (site
    frame, m) and the time they are free from (s); ``free_start``: a robot's first task needs no drive
    (for a lower bound)."""

    tasks: list[_Task]
    fleet: Fleet
    homes: dict[str, np.ndarray]
    ready: dict[str, float]
    free_start: bool = False
    #: where each robot may stand at the start (site frame, m): its first drive is the shortest from any
    #: of them (for a lower bound); None: from ``homes``
    starts: dict[str, list] | None = None
    #: floor -> its least duration (ticks) known from a solve of that floor alone
    floor_least: dict[int, int] = field(default_factory=dict)
    #: robot -> where it should stop (site frame, m): among the shortest schedules, the one whose robots
    #: stop nearest to these (the drives to them, a second objective below the makespan)
    end_targets: dict[str, np.ndarray] | None = None
    #: ``time.perf_counter()`` past which building the model stops (:class:`OutOfTime`); None: no limit
    deadline: float | None = None


class OutOfTime(Exception):
    """The planner's time limit passed while a model was being built (large floors take minutes)."""


def _check(deadline: float | None) -> None:
    if deadline is not None and time.perf_counter() > deadline:
        raise OutOfTime


@dataclass
class _Costs:
    """A problem's numbers in ticks (0.01 s): who can do what, how long it takes, and the drives."""

    capable: dict  # task key -> the robots (specs) that can do it
    handling: dict  # (task key, robot) -> handling ticks
    ready: dict  # robot -> the tick it is free from
    speed: dict  # robot -> m/s
    mine: dict  # robot -> the tasks it can do
    first_drive: dict = field(default_factory=dict)  # (task key, robot) -> its drive as the robot's first task
    shortest_in: dict = field(default_factory=dict)  # (task key, robot) -> the least drive into the task
    horizon: int = 0  # no schedule needs longer (ticks)

    def drive(self, a, b, robot: str) -> int:
        """Ticks for ``robot`` to drive from ``a`` to ``b`` (site frame, m)."""
        return _ticks(float(np.hypot(*(np.asarray(b) - np.asarray(a)))) / self.speed[robot])


@dataclass
class _Vars:
    """The model's variables: per task its ``depart``, ``start`` and ``end`` (ticks), one gate per floor
    with joints, the robot literals, the circuit arcs and the busy interval sizes."""

    depart: dict
    start: dict
    end: dict
    gates: dict = field(default_factory=dict)  # floor -> >= every closer's end on floors <= floor
    closers_by_floor: dict = field(default_factory=dict)  # floor -> the keys of the tasks that close it
    assigned: dict = field(default_factory=dict)  # (task, robot) -> literal
    arcs: dict = field(default_factory=dict)  # (robot, task before or None for the depot, task after or None) -> literal
    sizes: dict = field(default_factory=dict)  # (task, robot or None for its group) -> (busy interval size, its least value)


def _costs(problem: _Problem) -> _Costs:
    """Capabilities, handling, release, first drives, shortest drives in and the horizon (ticks);
    InputError where no robot of the fleet can do a task."""
    tasks, fleet = problem.tasks, problem.fleet
    capable = {t.key: [r for r in fleet.robots if not incapability(r, t.request)] for t in tasks}
    for t in tasks:
        if not capable[t.key]:
            raise InputError(f"no robot of fleet {fleet.name} can do {t.key}")
    handling = {(t.key, r.name): _ticks(handling_time(r, t.request)) for t in tasks for r in capable[t.key]}
    c = _Costs(capable, handling, {name: _ticks(s) for name, s in problem.ready.items()},
               {r.name: r.speed_m_s for r in fleet.robots},
               {r.name: [t for t in tasks if (t.key, r.name) in handling] for r in fleet.robots})
    starts = problem.starts or {r: [xy] for r, xy in problem.homes.items()}
    c.first_drive = {(t.key, r): 0 if problem.free_start else min(c.drive(xy, t.request.start, r) for xy in starts[r])
                     for r, ts in c.mine.items() for t in ts}
    c.shortest_in = _shortest_in(c)
    c.horizon = _horizon(problem, c)
    return c


def _shortest_in(c: _Costs) -> dict:
    """(task, robot) -> the least drive into the task (ticks): its first drive, or from the end of
    another of the robot's tasks."""
    shortest_in = {}
    for r, ts in c.mine.items():
        ends = np.array([t.request.end for t in ts], dtype=float).reshape(-1, 2)
        for i, t in enumerate(ts):
            gaps = np.hypot(*(ends - np.asarray(t.request.start, dtype=float)).T)
            gaps[i] = np.inf
            nearest = float(gaps.min()) if len(ts) > 1 else np.inf
            shortest_in[t.key, r] = min(c.first_drive[t.key, r], _ticks(nearest / c.speed[r]) if np.isfinite(nearest) else 1 << 40)
    return shortest_in


def _horizon(problem: _Problem, c: _Costs) -> int:
    """Ticks no schedule needs to exceed: the latest release plus, per task, its longest handling, drive
    from the farthest home and 400 m more."""
    horizon = max(c.ready.values(), default=0)
    for t in problem.tasks:
        horizon += max(c.handling[t.key, r.name] + max(c.drive(h, t.request.start, r.name) for h in problem.homes.values()) +
                       _ticks(400.0 / r.speed_m_s) for r in c.capable[t.key])
    return horizon


def _variables(model, tasks: list[_Task], horizon: int) -> _Vars:
    """Each task's depart, start and end, and one gate per floor with work that closes it (after each
    such task of that floor, :func:`~bimrobot.planning.optimal_graph.floor_closers`, and the gate below)."""
    v = _Vars({t.key: model.NewIntVar(0, horizon, f"depart[{t.key}]") for t in tasks},
              {t.key: model.NewIntVar(0, horizon, f"start[{t.key}]") for t in tasks},
              {t.key: model.NewIntVar(0, horizon, f"end[{t.key}]") for t in tasks})
    for t in tasks:
        if t.closes:
            v.closers_by_floor.setdefault(t.floor, []).append(t.key)
    for floor in sorted(v.closers_by_floor):
        v.gates[floor] = model.NewIntVar(0, horizon, f"gate[{floor}]")  # >= every closer's end on floors <= floor
        for key in v.closers_by_floor[floor]:
            model.Add(v.gates[floor] >= v.end[key])
        below = [f for f in v.gates if f < floor]
        if below:
            model.Add(v.gates[floor] >= v.gates[max(below)])
    return v


def _assignment(model, tasks: list[_Task], c: _Costs, v: _Vars) -> None:
    """One robot per task (its handling there, its release) and the precedences: a task departs after
    its predecessors end, or after the gate below where the floor gate holds it."""
    keys = {t.key for t in tasks}
    for t in tasks:
        literals = []
        for r in c.capable[t.key]:
            lit = model.NewBoolVar(f"x[{t.key},{r.name}]")
            v.assigned[t.key, r.name] = lit
            literals.append(lit)
            model.Add(v.end[t.key] == v.start[t.key] + c.handling[t.key, r.name]).OnlyEnforceIf(lit)
            model.Add(v.depart[t.key] >= c.ready[r.name]).OnlyEnforceIf(lit)
        model.AddExactlyOne(literals)
        model.Add(v.depart[t.key] <= v.start[t.key])
        gated = set()
        if t.gate_floor is not None:
            below = [f for f in v.gates if f < t.gate_floor]
            if below:
                model.Add(v.depart[t.key] >= v.gates[max(below)])
                gated = {k for f in v.gates if f < t.gate_floor for k in v.closers_by_floor[f]}
        for p in t.predecessors:
            if p in keys and p not in gated:
                model.Add(v.depart[t.key] >= v.end[p])


def _circuit(model, name: str, c: _Costs, v: _Vars, ancestors: dict, order: dict, deadline=None) -> None:
    """Robot ``name``'s circuit over the tasks it can do (a depot node 0; an arc t -> u: u departs after
    t ends and starts after the drive), arcs that contradict a precedence left out, and the NoOverlap of
    its busy intervals [depart, end] (each at least its handling plus the shortest drive into it)."""
    ts, horizon = c.mine[name], c.horizon
    busy = []
    arcs = []
    node = {t.key: i + 1 for i, t in enumerate(ts)}
    arcs.append((0, 0, model.NewBoolVar(f"idle[{name}]")))
    v.arcs[name, None, None] = arcs[-1][2]
    for t in ts:
        _check(deadline)  # each task adds an arc to every other: the quadratic part of the build
        lit = v.assigned[t.key, name]
        arcs.append((node[t.key], node[t.key], lit.Not()))
        first = model.NewBoolVar(f"first[{name},{t.key}]")
        v.arcs[name, None, t.key] = first
        arcs.append((0, node[t.key], first))
        model.Add(v.start[t.key] >= v.depart[t.key] + c.first_drive[t.key, name]).OnlyEnforceIf(first)
        arcs.append((node[t.key], 0, model.NewBoolVar(f"last[{name},{t.key}]")))
        v.arcs[name, t.key, None] = arcs[-1][2]
        least = c.handling[t.key, name] + min(c.shortest_in[t.key, name], horizon)
        size = model.NewIntVar(least, horizon, f"busy[{t.key},{name}]")
        v.sizes[t.key, name] = (size, least)
        busy.append(model.NewOptionalIntervalVar(v.depart[t.key], size, v.end[t.key], lit, f"busy[{t.key},{name}]"))
        for u in ts:
            if u.key == t.key or (ancestors[t.key] >> order[u.key]) & 1:
                continue  # u must finish before t starts: t is never followed by u
            follow = model.NewBoolVar(f"next[{name},{t.key},{u.key}]")
            arcs.append((node[t.key], node[u.key], follow))
            v.arcs[name, t.key, u.key] = follow
            model.Add(v.depart[u.key] >= v.end[t.key]).OnlyEnforceIf(follow)
            model.Add(v.start[u.key] >= v.depart[u.key] + c.drive(t.request.end, u.request.start, name)).OnlyEnforceIf(follow)
    model.AddCircuit(arcs)
    model.AddNoOverlap(busy)


def _group_capacity(model, tasks: list[_Task], c: _Costs, v: _Vars) -> None:
    """Redundant: per group of two or more tasks that the same two or more robots can do, a Cumulative
    of capacity the group's size over their busy intervals."""
    groups: dict[tuple[str, ...], list[_Task]] = {}
    for t in tasks:
        groups.setdefault(tuple(r.name for r in c.capable[t.key]), []).append(t)
    for robots, ts in groups.items():
        if len(robots) < 2 or len(ts) < 2:
            continue  # one robot: its NoOverlap says it
        intervals = []
        for t in ts:
            least = min(c.handling[t.key, r] + min(c.shortest_in[t.key, r], c.horizon) for r in robots)
            size = model.NewIntVar(least, c.horizon, f"group[{t.key}]")
            v.sizes[t.key, None] = (size, least)
            intervals.append(model.NewIntervalVar(v.depart[t.key], size, v.end[t.key], f"group[{t.key}]"))
        model.AddCumulative(intervals, [1] * len(intervals), len(robots))


def _makespan(model, v: _Vars, horizon: int):
    """The objective: the last end, never before a floor gate (so the floor loads bound it)."""
    makespan = model.NewIntVar(0, horizon, "makespan")
    model.AddMaxEquality(makespan, list(v.end.values()))
    for gate in v.gates.values():  # a gate is never later than the last end: lets the floor loads bound the makespan
        model.Add(makespan >= gate)
    model.Minimize(makespan)
    return makespan


def _stop_near(model, problem: _Problem, c: _Costs, v: _Vars, makespan) -> int:
    """With ``end_targets``: minimize the makespan first, then the drives (ticks) from where each robot
    stops to its target, as makespan x weight + drives; returns the weight (1 without targets)."""
    if not problem.end_targets:
        return 1
    drives, weight = [], 1
    for name, target in sorted(problem.end_targets.items()):
        options = [(v.arcs[name, t.key, None], c.drive(t.request.end, target, name)) for t in c.mine[name]
                   if (name, t.key, None) in v.arcs]
        if (name, None, None) in v.arcs:  # it does nothing: it stays where it stands
            options.append((v.arcs[name, None, None], c.drive(problem.homes[name], target, name)))
        drives += [lit * ticks for lit, ticks in options]
        weight += max((ticks for _, ticks in options), default=0)
    model.Minimize(makespan * weight + sum(drives))
    return weight


def _build(cp_model, problem: _Problem, hint: dict | None):
    """The CP-SAT model of ``problem`` (module docstring); returns (model, variables). Raises
    :class:`OutOfTime` where ``problem.deadline`` passes while it is built."""
    tasks, fleet = problem.tasks, problem.fleet
    _check(problem.deadline)
    c = _costs(problem)
    model = cp_model.CpModel()
    v = _variables(model, tasks, c.horizon)
    _assignment(model, tasks, c, v)
    ancestors = _closure(tasks)
    order = {t.key: i for i, t in enumerate(tasks)}
    for r in fleet.robots:
        if c.mine[r.name]:
            _circuit(model, r.name, c, v, ancestors, order, problem.deadline)
    _check(problem.deadline)
    _group_capacity(model, tasks, c, v)
    busy_min = {(t.key, r): c.handling[t.key, r] + min(c.shortest_in[t.key, r], c.horizon) for t in tasks for r in
                (x.name for x in c.capable[t.key])}
    travel = _Visits(model, v.assigned, c.handling, busy_min, c.drive)
    first = {(name, key): lit for (name, before, key), lit in v.arcs.items() if before is None and key is not None}
    arrival = {(t.key, r): c.first_drive[t.key, r] - min(c.shortest_in[t.key, r], c.first_drive[t.key, r])
               for t in tasks for r in (x.name for x in c.capable[t.key])} if not any(c.ready.values()) else None
    known_bound = _floor_loads(model, tasks, v.gates, ancestors, c.capable, busy_min, v.assigned, travel,
                               problem.floor_least, first, arrival)
    _check(problem.deadline)
    makespan = _makespan(model, v, c.horizon)
    weight = _stop_near(model, problem, c, v, makespan)
    if hint:
        variables = dict(assigned=v.assigned, depart=v.depart, start=v.start, end=v.end, arcs=v.arcs, sizes=v.sizes,
                         gates=v.gates, makespan=makespan, visited=travel.visited)
        hinted = _add_hint(model, hint, problem, c.handling, c.drive, c.first_drive, c.ready, variables)
    else:
        hinted = None

    def justify(found: dict) -> dict:
        """The solver's schedule (task -> (robot, depart, end) ticks), every task as early as its
        order allows: CP-SAT's solutions may wait where nothing makes them (ticks)."""
        return _retime(tasks, fleet, found, c.handling, c.drive, c.first_drive, c.ready)[0]

    return model, (makespan, v.assigned, v.depart, v.start, v.end, c.capable, hinted, known_bound, justify, weight)


def _retime(tasks: list[_Task], fleet: Fleet, hint: dict, handling, drive, first_drive, ready):
    """A schedule's tasks (``hint``: task key -> (robot, depart, end), any unit) in its order per robot,
    each as early as its predecessors, its robot and the drive allow: (times: task -> (depart, start,
    end) in ticks, arcs, each robot's last task)."""
    keys = {t.key for t in tasks}
    ends = {t.key: t.request.end for t in tasks}
    times: dict[str, tuple[int, int, int]] = {}
    last: dict[str, str | None] = {r.name: None for r in fleet.robots}
    free = dict(ready)
    true_arcs = set()
    for t in sorted(tasks, key=lambda t: (hint[t.key][1], hint[t.key][2])):
        robot, before = hint[t.key][0], last[hint[t.key][0]]
        leave = max([free[robot]] + [times[p][2] for p in t.predecessors if p in keys])
        way = first_drive[t.key, robot] if before is None else drive(ends[before], t.request.start, robot)
        times[t.key] = (leave, leave + way, leave + way + handling[t.key, robot])
        true_arcs.add((robot, before, t.key))
        last[robot], free[robot] = t.key, times[t.key][2]
    return times, true_arcs, last


def _part_ranks(tasks: list[_Task], can: dict, handling: dict) -> dict[str, int]:
    """Positioning task -> its rank in the list schedule (:func:`_list_schedule`), the parts in
    :func:`~bimrobot.planning.rules.completing_order` (a joint's parts: its assembly's positioning
    predecessors; a part's time: its shortest positioning, ticks)."""
    from bimrobot.planning.rules import completing_order

    parts = {t.key: (t.floor, min(handling[t.key, r] for r in can[t.key])) for t in tasks if t.activity == Task.POSITION}
    joints = [list(t.predecessors) for t in tasks if t.activity == Task.ASSEMBLE]
    return {part: rank for rank, part in enumerate(completing_order(parts, joints))}


def _list_schedule(tasks: list[_Task], can: dict, handling, drive, first_drive, ready) -> dict:
    """A schedule built one task at a time (a serial list schedule; task -> (robot, depart, end) ticks):
    of the tasks whose predecessors are placed, a joint first, otherwise the transport or positioning of
    the part ranked first (:func:`_part_ranks`), each on the capable robot that ends it first, leaving
    once its predecessors are done. Where the positioning cranes are the bottleneck, it keeps them on
    parts whose joints can then be made, where the market leaves the joints of the last parts to the end
    (ROOT-staal's floor 2: 11,629 s from the robots' homes, the market's order 13,761 s, its bound alone
    11,255 s). ``can``: task key -> the names of the robots that can do it."""
    import heapq

    keys = {t.key: t for t in tasks}
    ranks = _part_ranks(tasks, can, handling)
    waiting = {t.key: sum(1 for p in t.predecessors if p in keys) for t in tasks}
    after: dict[str, list[str]] = {}
    for t in tasks:
        for p in t.predecessors:
            if p in keys:
                after.setdefault(p, []).append(t.key)

    def priority(key: str) -> tuple:
        kind, _, part = key.partition(":")
        return (1, ranks.get(f"position:{part}", len(ranks)), kind != "transport", key) if kind != "assemble" else (0, key)

    eligible = [(priority(key), key) for key, count in waiting.items() if count == 0]
    heapq.heapify(eligible)
    free, at, schedule = dict(ready), {name: None for name in ready}, {}
    while eligible:
        _, key = heapq.heappop(eligible)
        t = keys[key]
        done = max((schedule[p][2] for p in t.predecessors if p in keys), default=0)
        options = []
        for name in can[key]:
            leave = max(free[name], done)
            way = first_drive[key, name] if at[name] is None else drive(at[name], t.request.start, name)
            options.append((leave + way + handling[key, name], name, leave))
        end, name, leave = min(options)
        schedule[key] = (name, leave, end)
        free[name], at[name] = end, t.request.end
        for u in after.get(key, ()):
            waiting[u] -= 1
            if waiting[u] == 0:
                heapq.heappush(eligible, (priority(u), u))
    return schedule


def _add_hint(model, hints, problem: _Problem, handling, drive, first_drive, ready, v: dict) -> dict | None:
    """The market's assignment and order (``hints``: task key -> (robot, depart s, end s), or a list of
    such schedules, with the problem's own list schedule, :func:`_list_schedule`; the shortest once
    re-timed is taken) as CP-SAT's first solution, every variable
    given: the tasks are re-timed in the model's own units (0.01 s, rounded up), in the schedule's order,
    each as early as its predecessors, its robot and the drive allow, so that the hint is feasible as it
    stands and the best found is never longer than the market's schedule."""
    tasks = problem.tasks
    keys = {t.key for t in tasks}

    def retime(hint: dict):
        if any(t.key not in hint or (t.key, hint[t.key][0]) not in v["assigned"] for t in tasks):
            return None  # a partial hint would only mislead the search
        return _retime(tasks, problem.fleet, hint, handling, drive, first_drive, ready)

    can: dict[str, list[str]] = {}
    for key, name in v["assigned"]:
        can.setdefault(key, []).append(name)
    listed = _list_schedule(tasks, can, handling, drive, first_drive, ready)
    given = [hint for hint in (hints if isinstance(hints, list) else [hints]) if hint]
    candidates = [(hint, retime(hint)) for hint in given + [listed]]
    candidates = [(hint, timed) for hint, timed in candidates if timed]
    if not candidates:
        return None
    hint, (times, true_arcs, last) = min(candidates, key=lambda c: max((x[2] for x in c[1][0].values()), default=0))
    for robot, key in last.items():
        true_arcs.add((robot, key, None))  # (robot, None, None): the robot does nothing
    for (key, name), lit in v["assigned"].items():
        model.AddHint(lit, hint[key][0] == name)
    for arc, lit in v["arcs"].items():
        model.AddHint(lit, arc in true_arcs)
    for (robot, _, keys), lit in v["visited"].items():
        model.AddHint(lit, any(hint[key][0] == robot for key in keys))
    for key, (leave, begin, finish) in times.items():
        model.AddHint(v["depart"][key], leave)
        model.AddHint(v["start"][key], begin)
        model.AddHint(v["end"][key], finish)
    for (key, name), (size, least) in v["sizes"].items():  # an absent interval (another robot's): its least size
        model.AddHint(size, times[key][2] - times[key][0] if name in (None, hint[key][0]) else least)
    for floor, gate in v["gates"].items():
        model.AddHint(gate, max((times[t.key][2] for t in tasks if t.closes and t.floor <= floor), default=0))
    longest = max((x[2] for x in times.values()), default=0)
    model.AddHint(v["makespan"], longest)
    model.Add(v["makespan"] <= longest)  # the hint is a schedule: the optimum is no longer
    return {key: (hint[key][0], *values) for key, values in times.items()}

