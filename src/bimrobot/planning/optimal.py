"""An optimal schedule with OR-Tools CP-SAT, to measure how far the market is from the best possible.

Same problem as the simulation: the same tasks (transport, position, assemble), handling times, robot
speeds, capabilities, start positions and precedences (supporters positioned before a component is
brought in, floor by floor, position after transport, assemble after all members are positioned), and
a robot leaves for a task only once the task is published (its predecessors are done). Travel between
two tasks of one robot is sequence-dependent, modelled with one circuit per robot. The market's schedule
is a feasible solution of this model, so the optimum is never worse than the market; it is given to the
solver as its first solution (a hint), so the best found is never worse either.

The model (times in seconds, solved in units of 0.01 s):
- per task t: ``depart`` (its robot leaves), ``start`` (work begins), ``end``; one robot literal per
  capable robot; ``end = start + handling`` on the chosen robot;
- precedences: ``depart[t] >= end[p]``; the floor gate (every joint of a lower floor before a transport)
  goes through one variable per floor, not one constraint per pair;
- per robot: a circuit over its possible tasks (an arc t -> u: ``depart[u] >= end[t]`` and
  ``start[u] >= depart[u] + travel(t -> u)``), arcs that contradict a precedence left out;
- redundant, for the bound: per robot a NoOverlap of its busy intervals [depart, end] (each at least
  its handling plus the shortest drive into it), and per group of tasks that the same robots can do a
  Cumulative of capacity the group's size;
- per floor, between the gate below and its own gate: each robot's work and its drives, counted once
  per point it works at (:class:`_Visits`); for two robots that share work, the fastest split of it
  (subset sums); the two-stage bound (:func:`_staged_bound`); and, where floors cannot overlap, the
  bound of that floor solved alone (:func:`_floor_bounds`), whose schedules, one floor after the other,
  are a second hint next to the market's.

Where the whole model is too big (more than ``whole_tasks`` tasks), the build is solved floor by floor
(the floor gate makes floors follow each other): each floor starts when the one below is done, with
every robot where it stopped. The lower bound is then the sum of each floor's bound with its robots
free to start anywhere at once (valid because floors cannot overlap), or the largest of them where a
floor has work that no joint of that floor waits for or that the floor gate does not hold.

Determinism: ``workers=1`` with ``deterministic_limit`` (CP-SAT's deterministic time, not wall time)
and a fixed ``seed`` gives the same result on every machine; tests use that.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from bimrobot.site.fleet import Fleet, Site
from bimrobot.coordination.market import handling_time, incapability
from bimrobot.coordination.simulation import ConstructionSimulation
from bimrobot.core.errors import InputError, require_extra
from bimrobot.sco.build import SmartModel
from bimrobot.core.tasks import Task

SCALE = 100  # solver time unit: 0.01 s
#: Above this many tasks the build is solved floor by floor (:func:`solve_optimal`).
WHOLE_TASKS = 400
#: The share of the time limit spent on each floor alone, for its least duration (:func:`_floor_bounds`).
FLOOR_SHARE = 0.3


@dataclass
class _Task:
    key: str
    activity: Task
    request: object
    predecessors: list[str]
    #: the floor gate: every joint on a floor below this one comes first (None: no gate); those joints
    #: are also listed in ``predecessors``
    gate_floor: int | None = None
    floor: int = 0


@dataclass
class OptimalSchedule:
    """The best schedule CP-SAT found. ``makespan`` and ``lower_bound`` in seconds; ``status``
    ``OPTIMAL`` (proved: makespan == lower bound) or ``FEASIBLE``; ``method`` ``whole`` or ``by floor``;
    ``solve_s``: wall time of the solves (s); ``hinted_s``: the makespan of the market's schedule
    given as the first solution (None without one)."""

    makespan: float
    lower_bound: float
    status: str
    assignment: dict[str, str]  # task key -> robot
    start: dict[str, float]  # task key -> work start (s)
    tasks: int
    method: str = "whole"
    solve_s: float = 0.0
    hinted_s: float | None = None
    floors: list[dict] = field(default_factory=list)
    #: CP-SAT's deterministic time of all solves (its own work units, comparable across machines and loads)
    deterministic_s: float = 0.0

    @property
    def gap(self) -> float:
        """(makespan - lower bound) / makespan: 0 when proved optimal."""
        return 0.0 if self.makespan <= 0 else max(0.0, (self.makespan - self.lower_bound) / self.makespan)


def task_graph(smart: SmartModel, sim: ConstructionSimulation) -> list[_Task]:
    """The build's tasks with their precedences, as the simulation publishes them."""
    tasks: list[_Task] = []
    components = smart.components
    joints_by_floor: dict[int, list[str]] = {}
    for joint in smart.joints.values():  # a joint of prebuilt parts only is no task: it gates nothing
        if any(not components[g].prebuilt for g in joint.component_ids):
            joints_by_floor.setdefault(joint.floor, []).append(f"assemble:{joint.id}")
    for component in components.values():
        if component.prebuilt:
            continue
        # a prebuilt supporter made later stands once its own robot-built supporters do
        preds = [f"position:{s}" for s in smart.robot_supporters(component.id)]
        gate = [key for floor, keys in joints_by_floor.items() if floor < component.floor for key in keys]
        tasks.append(_Task(f"transport:{component.id}", Task.TRANSPORT, sim.request_for(Task.TRANSPORT, component),
                           preds + gate, component.floor if gate else None, component.floor))
        tasks.append(_Task(f"position:{component.id}", Task.POSITION, sim.request_for(Task.POSITION, component),
                           [f"transport:{component.id}"], None, component.floor))
    for joint in smart.joints.values():
        members = [components[g] for g in joint.component_ids]
        preds = [f"position:{m.id}" for m in members if not m.prebuilt]
        preds += [f"position:{s}" for m in members if m.prebuilt for s in smart.robot_supporters(m.id)]
        preds = list(dict.fromkeys(preds))
        if not preds:
            continue  # foundations only: nothing for robots to wait for, but still assembled
        tasks.append(_Task(f"assemble:{joint.id}", Task.ASSEMBLE, sim.request_for(Task.ASSEMBLE, members[0], joint),
                           preds, None, joint.floor))
    return tasks


def _ticks(seconds: float) -> int:
    return int(math.ceil(seconds * SCALE - 1e-9))


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


@dataclass
class _Solved:
    makespan: float
    bound: float
    status: str
    assignment: dict[str, str]
    depart: dict[str, float]
    start: dict[str, float]
    end: dict[str, float]
    deterministic_s: float = 0.0


def _closure(tasks: list[_Task]) -> dict[str, int]:
    """Each task's ancestors (within ``tasks``) as a bit set over ``tasks``' order (Python ints)."""
    index = {t.key: i for i, t in enumerate(tasks)}
    preds = {t.key: [p for p in t.predecessors if p in index] for t in tasks}
    waiting = {key: len(ps) for key, ps in preds.items()}
    children: dict[str, list[str]] = {}
    for key, ps in preds.items():
        for p in ps:
            children.setdefault(p, []).append(key)
    ready = [key for key, n in waiting.items() if n == 0]
    ancestors: dict[str, int] = {}
    while ready:  # Kahn's order: every task after its predecessors
        key = ready.pop()
        bits = 0
        for p in preds[key]:
            bits |= (1 << index[p]) | ancestors[p]
        ancestors[key] = bits
        for child in children.get(key, ()):
            waiting[child] -= 1
            if waiting[child] == 0:
                ready.append(child)
    if len(ancestors) < len(tasks):
        raise InputError("the task graph has a cycle: no schedule can satisfy its precedences")
    return ancestors


def _build(cp_model, problem: _Problem, hint: dict | None):
    """The CP-SAT model of ``problem`` (module docstring); returns (model, variables)."""
    tasks, fleet = problem.tasks, problem.fleet
    keys = {t.key for t in tasks}
    capable = {t.key: [r for r in fleet.robots if not incapability(r, t.request)] for t in tasks}
    for t in tasks:
        if not capable[t.key]:
            raise InputError(f"no robot of fleet {fleet.name} can do {t.key}")
    speed = {r.name: r.speed_m_s for r in fleet.robots}
    handling = {(t.key, r.name): _ticks(handling_time(r, t.request)) for t in tasks for r in capable[t.key]}
    ready = {name: _ticks(s) for name, s in problem.ready.items()}

    def drive(a, b, robot: str) -> int:
        return _ticks(float(np.hypot(*(np.asarray(b) - np.asarray(a)))) / speed[robot])

    mine = {r.name: [t for t in tasks if (t.key, r.name) in handling] for r in fleet.robots}
    starts = problem.starts or {r: [xy] for r, xy in problem.homes.items()}
    first_drive = {(t.key, r): 0 if problem.free_start else min(drive(xy, t.request.start, r) for xy in starts[r])
                   for r, ts in mine.items() for t in ts}
    shortest_in = {}
    for r, ts in mine.items():
        ends = np.array([t.request.end for t in ts], dtype=float).reshape(-1, 2)
        for i, t in enumerate(ts):
            gaps = np.hypot(*(ends - np.asarray(t.request.start, dtype=float)).T)
            gaps[i] = np.inf
            nearest = float(gaps.min()) if len(ts) > 1 else np.inf
            shortest_in[t.key, r] = min(first_drive[t.key, r], _ticks(nearest / speed[r]) if np.isfinite(nearest) else 1 << 40)

    horizon = max(ready.values(), default=0)
    for t in tasks:
        horizon += max(handling[t.key, r.name] + max(drive(h, t.request.start, r.name) for h in problem.homes.values()) +
                       _ticks(400.0 / r.speed_m_s) for r in capable[t.key])
    model = cp_model.CpModel()
    depart = {t.key: model.NewIntVar(0, horizon, f"depart[{t.key}]") for t in tasks}
    start = {t.key: model.NewIntVar(0, horizon, f"start[{t.key}]") for t in tasks}
    end = {t.key: model.NewIntVar(0, horizon, f"end[{t.key}]") for t in tasks}
    gates = {}
    joints_by_floor: dict[int, list[str]] = {}
    for t in tasks:
        if t.activity == Task.ASSEMBLE:
            joints_by_floor.setdefault(t.floor, []).append(t.key)
    for floor in sorted(joints_by_floor):
        gates[floor] = model.NewIntVar(0, horizon, f"gate[{floor}]")  # >= every joint's end on floors <= floor
        for key in joints_by_floor[floor]:
            model.Add(gates[floor] >= end[key])
        below = [f for f in gates if f < floor]
        if below:
            model.Add(gates[floor] >= gates[max(below)])
    assigned = {}
    for t in tasks:
        literals = []
        for r in capable[t.key]:
            lit = model.NewBoolVar(f"x[{t.key},{r.name}]")
            assigned[t.key, r.name] = lit
            literals.append(lit)
            model.Add(end[t.key] == start[t.key] + handling[t.key, r.name]).OnlyEnforceIf(lit)
            model.Add(depart[t.key] >= ready[r.name]).OnlyEnforceIf(lit)
        model.AddExactlyOne(literals)
        model.Add(depart[t.key] <= start[t.key])
        gated = set()
        if t.gate_floor is not None:
            below = [f for f in gates if f < t.gate_floor]
            if below:
                model.Add(depart[t.key] >= gates[max(below)])
                gated = {k for f in gates if f < t.gate_floor for k in joints_by_floor[f]}
        for p in t.predecessors:
            if p in keys and p not in gated:
                model.Add(depart[t.key] >= end[p])
    ancestors = _closure(tasks)
    order = {t.key: i for i, t in enumerate(tasks)}
    arcs_of = {}  # (robot, task before or None for the depot, task after or None) -> arc literal
    sizes = {}  # (task, robot or None for its group) -> (busy interval size, its least value)
    for r in fleet.robots:
        ts = mine[r.name]
        if not ts:
            continue
        busy = []
        arcs = []
        node = {t.key: i + 1 for i, t in enumerate(ts)}
        arcs.append((0, 0, model.NewBoolVar(f"idle[{r.name}]")))
        arcs_of[r.name, None, None] = arcs[-1][2]
        for t in ts:
            lit = assigned[t.key, r.name]
            arcs.append((node[t.key], node[t.key], lit.Not()))
            first = model.NewBoolVar(f"first[{r.name},{t.key}]")
            arcs_of[r.name, None, t.key] = first
            arcs.append((0, node[t.key], first))
            model.Add(start[t.key] >= depart[t.key] + first_drive[t.key, r.name]).OnlyEnforceIf(first)
            arcs.append((node[t.key], 0, model.NewBoolVar(f"last[{r.name},{t.key}]")))
            arcs_of[r.name, t.key, None] = arcs[-1][2]
            size = model.NewIntVar(handling[t.key, r.name] + min(shortest_in[t.key, r.name], horizon), horizon, f"busy[{t.key},{r.name}]")
            sizes[t.key, r.name] = (size, handling[t.key, r.name] + min(shortest_in[t.key, r.name], horizon))
            busy.append(model.NewOptionalIntervalVar(depart[t.key], size, end[t.key], lit, f"busy[{t.key},{r.name}]"))
            for u in ts:
                if u.key == t.key or (ancestors[t.key] >> order[u.key]) & 1:
                    continue  # u must finish before t starts: t is never followed by u
                follow = model.NewBoolVar(f"next[{r.name},{t.key},{u.key}]")
                arcs.append((node[t.key], node[u.key], follow))
                arcs_of[r.name, t.key, u.key] = follow
                model.Add(depart[u.key] >= end[t.key]).OnlyEnforceIf(follow)
                model.Add(start[u.key] >= depart[u.key] + drive(t.request.end, u.request.start, r.name)).OnlyEnforceIf(follow)
        model.AddCircuit(arcs)
        model.AddNoOverlap(busy)
    groups: dict[tuple[str, ...], list[_Task]] = {}
    for t in tasks:
        groups.setdefault(tuple(r.name for r in capable[t.key]), []).append(t)
    for robots, ts in groups.items():
        if len(robots) < 2 or len(ts) < 2:
            continue  # one robot: its NoOverlap says it
        intervals = []
        for t in ts:
            least = min(handling[t.key, r] + min(shortest_in[t.key, r], horizon) for r in robots)
            size = model.NewIntVar(least, horizon, f"group[{t.key}]")
            sizes[t.key, None] = (size, least)
            intervals.append(model.NewIntervalVar(depart[t.key], size, end[t.key], f"group[{t.key}]"))
        model.AddCumulative(intervals, [1] * len(intervals), len(robots))
    busy_min = {(t.key, r): handling[t.key, r] + min(shortest_in[t.key, r], horizon) for t in tasks for r in
                (x.name for x in capable[t.key])}
    travel = _Visits(model, assigned, handling, busy_min, drive)
    known_bound = _floor_loads(model, tasks, gates, ancestors, capable, busy_min, assigned, travel, problem.floor_least)
    makespan = model.NewIntVar(0, horizon, "makespan")
    model.AddMaxEquality(makespan, list(end.values()))
    for gate in gates.values():  # a gate is never later than the last end: lets the floor loads bound the makespan
        model.Add(makespan >= gate)
    model.Minimize(makespan)
    if hint:
        variables = dict(assigned=assigned, depart=depart, start=start, end=end, arcs=arcs_of, sizes=sizes,
                         gates=gates, makespan=makespan, visited=travel.visited)
        hinted = _add_hint(model, hint, problem, handling, drive, first_drive, ready, variables)
    else:
        hinted = None

    def justify(found: dict) -> dict:
        """The solver's schedule (task -> (robot, depart, end) ticks), every task as early as its
        order allows: CP-SAT's solutions may wait where nothing makes them (ticks)."""
        return _retime(tasks, fleet, found, handling, drive, first_drive, ready)[0]

    return model, (makespan, assigned, depart, start, end, capable, hinted, known_bound, justify)


def _floor_loads(model, tasks, gates, ancestors, capable, busy_min, assigned, travel, floor_least) -> int:
    """Redundant, for the bound: on each floor f, the work of floor f that a robot does fits between the
    gate below (or time 0) plus the shortest lead-in before any of it can start, and the floor's own gate
    (every joint of floors <= f done) less the shortest run-out after it. With the robot literals this
    is linear, so the relaxation balances each floor's work over the robots that can do it. Returns the
    sum over floors of each floor's least duration known before solving (ticks): a lower bound of the
    makespan, since each gate follows the one below."""
    least = 0
    for floor, gate in gates.items():
        known = 0
        below = [f for f in gates if f < floor]
        opening = gates[max(below)] if below else 0
        mine = sorted((t for t in tasks if t.floor == floor), key=lambda t: bin(ancestors[t.key]).count("1"))
        keys = {t.key for t in mine}
        gated = {t.key for t in mine if not below or (t.gate_floor == floor)}
        head: dict[str, int] = {}
        for t in mine:  # ancestors first (fewer ancestors first is a topological order within the floor)
            preds = [p for p in t.predecessors if p in keys]
            if not below or t.key in gated or any(p in gated for p in preds):
                gated.add(t.key)
                head[t.key] = max((head[p] + min(busy_min[p, r.name] for r in capable[p]) for p in preds if p in head), default=0)
        tail = {t.key: 0 for t in mine if t.key in head and t.activity == Task.ASSEMBLE}  # it ends by the gate
        successors: dict[str, list[str]] = {}
        for t in mine:
            for p in t.predecessors:
                if p in keys:
                    successors.setdefault(p, []).append(t.key)
        for t in sorted(mine, key=lambda t: -bin(ancestors[t.key]).count("1")):  # successors first
            after = [u for u in successors.get(t.key, ()) if u in tail]
            if t.key in head and t.key not in tail and after:
                tail[t.key] = max(min(busy_min[u, r.name] for r in capable[u]) + tail[u] for u in after)
        counted = [t for t in mine if t.key in head and t.key in tail]
        robots = {r.name for t in counted for r in capable[t.key]}
        for name in robots:
            work = [t for t in counted if (t.key, name) in assigned]
            lead = min(head[t.key] for t in work) + min(tail[t.key] for t in work)
            model.Add(sum(assigned[t.key, name] * busy_min[t.key, name] for t in work) <= gate - opening - lead)
            if len(counted) == len(mine):  # the window holds all of the floor's work: count its drives
                model.Add(travel.load(name, work) <= gate - opening - lead)
        pairs: dict[tuple[str, ...], list[_Task]] = {}
        for t in counted:
            pairs.setdefault(tuple(r.name for r in capable[t.key]), []).append(t)
        for pair, work in pairs.items():
            if len(pair) == 2 and len(work) > 1:
                lead = min(head[t.key] for t in work) + min(tail[t.key] for t in work)
                known = max(known, lead + _two_robot_bound(work, pair, busy_min))
                if len(counted) == len(mine):
                    known = max(known, lead + travel.two_robot_bound(work, pair))
        known = max(known, _staged_bound(pairs, head, tail, busy_min), floor_least.get(floor, 0))
        if known:
            model.Add(gate - opening >= known)
        least += known
    return least


def _fastest(costs: dict[str, list[int]], count: int) -> int:
    """The least time (ticks) one or two robots need for ``count`` of their tasks, whichever: each robot
    takes the cheapest of its own ``costs`` (sorted ascending), for every split of the count."""
    lists = list(costs.values())
    if len(lists) == 1:
        return sum(lists[0][:count]) if count <= len(lists[0]) else 1 << 40
    a, b = lists
    best = 1 << 40
    for on_a in range(max(0, count - len(b)), min(count, len(a)) + 1):
        best = min(best, max(sum(a[:on_a]), sum(b[:count - on_a])))
    return best


def _staged_bound(groups: dict[tuple[str, ...], list[_Task]], head, tail, busy_min) -> int:
    """A floor's least duration (ticks) from its two stages, e.g. positioning then assembly: every task
    of a later group J waits for some task of an earlier group P (one or two robots each). Before the k-th
    P task can end (E_k: the earliest, over splits of k between P's robots, from P's earliest start), at
    most the k-1 P tasks with the most J successors are done, so the rest of J, at least n - released
    tasks, starts after E_k and needs J's robots for at least their fastest split; then the run-out."""
    best = 0
    for later_robots, later in groups.items():
        if len(later_robots) > 2 or len(later) < 2:
            continue
        for earlier_robots, earlier in groups.items():
            if earlier_robots == later_robots or len(earlier_robots) > 2:
                continue
            keys = {t.key for t in earlier}
            feeds = {t.key: 0 for t in earlier}
            if not all(any(p in keys for p in t.predecessors) for t in later):
                continue
            for t in later:
                for p in t.predecessors:
                    if p in keys:
                        feeds[p] += 1
            released = sorted(feeds.values(), reverse=True)
            first = min(head[t.key] for t in earlier)
            run_out = min(tail[t.key] for t in later)
            cost_p = {r: sorted(busy_min[t.key, r] for t in earlier) for r in earlier_robots}
            cost_j = {r: sorted(busy_min[t.key, r] for t in later) for r in later_robots}
            for k in range(1, len(earlier) + 1):
                left = len(later) - sum(released[:k - 1])
                if left <= 0:
                    break
                best = max(best, first + _fastest(cost_p, k) + _fastest(cost_j, left) + run_out)
    return best


class _Visits:
    """A robot's drives, for the bound: tasks that begin and end at one point (positioning, assembly)
    share that point with others, so each one's shortest drive in is 0; but a robot that does work at n
    points drives into each of them at least once. ``load(robot, work)`` is the robot's handling of
    ``work`` plus, per point it visits, the shortest drive into that point from the end of any other of
    ``work``'s tasks, less the largest such drive (the first point may be where the robot already stands).
    Ticks (0.01 s)."""

    def __init__(self, model, assigned, handling, busy_min, drive):
        self.model, self.assigned, self.handling, self.busy_min, self.drive = model, assigned, handling, busy_min, drive
        self.visited = {}  # (robot, point) -> literal: the robot does some work there

    @staticmethod
    def _point(xy) -> tuple[int, int]:
        return tuple(int(round(float(c) * 100)) for c in np.asarray(xy, dtype=float)[:2])

    def two_robot_bound(self, work: list[_Task], pair: tuple[str, str]) -> int:
        """The least time (ticks) two robots need for ``work`` that only they can do, with their drives:
        min over splits of the larger load, a split choosing per point how many of its tasks each robot
        takes (the cheapest of them, for a bound), each robot paying the shortest drive into every point
        it works at, less its largest such drive (subset sums in ticks, or in coarser units rounded down
        where the floor is large)."""
        points, moving = self._points(work)
        if moving:
            return 0
        cost = {r: {here: sorted(self.handling[t.key, r] for t in ts) for here, ts in points.items()} for r in pair}
        near = {r: {here: self._nearest(r, here, ts, work) for here, ts in points.items()} for r in pair}
        a, b = pair
        terms = sum(len(ts) + 1 for ts in points.values())
        ticks = sum(sum(c) + near[a][here] for here, c in cost[a].items()) + 1
        unit = max(1, math.ceil(ticks * terms / 4e7))  # coarser than a tick on large floors; sums round down
        size = ticks // unit + 1
        never = np.iinfo(np.int64).max // 4
        best_b = np.full(size, never, dtype=np.int64)  # units on a -> least units on b
        best_b[0] = 0
        for here, ts in points.items():
            merged = np.full(size, never, dtype=np.int64)
            for on_a in range(len(ts) + 1):
                on_b = len(ts) - on_a
                add_a = (sum(cost[a][here][:on_a]) + (near[a][here] if on_a else 0)) // unit
                add_b = (sum(cost[b][here][:on_b]) + (near[b][here] if on_b else 0)) // unit
                shifted = np.full(size, never, dtype=np.int64)
                shifted[add_a:] = best_b[:size - add_a] if add_a else best_b
                merged = np.minimum(merged, shifted + add_b)
            best_b = merged
        slack_a, slack_b = -(-max(near[a].values()) // unit), -(-max(near[b].values()) // unit)
        loads = np.maximum(np.arange(size) - slack_a, best_b - slack_b)
        return max(0, int(loads.min()) * unit)

    def _nearest(self, name: str, here, ts: list[_Task], work: list[_Task]) -> int:
        return min((self.drive(u.request.end, ts[0].request.start, name) for u in work
                    if self._point(u.request.end) != here), default=0)

    def _points(self, work: list[_Task]):
        points: dict[tuple[int, int], list[_Task]] = {}
        moving = []  # tasks that end elsewhere than they begin: their own shortest drive in stands
        for t in work:
            here = self._point(t.request.start)
            (points.setdefault(here, []) if here == self._point(t.request.end) else moving).append(t)
        return points, moving

    def load(self, name: str, work: list[_Task]):
        points: dict[tuple[int, int], list[_Task]] = {}
        moving = []  # tasks that end elsewhere than they begin: their own shortest drive in stands
        for t in work:
            here = self._point(t.request.start)
            (points.setdefault(here, []) if here == self._point(t.request.end) else moving).append(t)
        nearest = {}
        for here, ts in points.items():
            gaps = [self.drive(u.request.end, ts[0].request.start, name) for u in work if self._point(u.request.end) != here]
            nearest[here] = min(gaps, default=0)
        terms = [self.assigned[t.key, name] * self.handling[t.key, name] for ts in points.values() for t in ts]
        for here, ts in points.items():
            key = (name, here, tuple(sorted(t.key for t in ts)))
            if key not in self.visited:
                self.visited[key] = lit = self.model.NewBoolVar(f"visits[{name},{here}]")
                for t in ts:
                    self.model.AddImplication(self.assigned[t.key, name], lit)
            terms.append(self.visited[key] * nearest[here])
        return sum(terms) - max(nearest.values(), default=0) + sum(
            self.assigned[t.key, name] * self.busy_min[t.key, name] for t in moving)


def _two_robot_bound(work: list[_Task], pair: tuple[str, str], busy_min) -> int:
    """The least time (ticks) two robots need for ``work`` that only they can do, each task on one of
    them with its least busy time there: min over splits of the larger load (subset sums, in whole
    seconds rounded down, so never above the true least). The relaxation splits tasks in fractions;
    this cut keeps each task whole."""
    a, b = pair
    cost_a = [busy_min[t.key, a] // SCALE for t in work]
    cost_b = [busy_min[t.key, b] // SCALE for t in work]
    size = sum(cost_a) + 1
    if size * len(work) > 5e7:
        return 0  # too large to enumerate; the linear loads still hold
    best_b = np.full(size, np.iinfo(np.int64).max // 4, dtype=np.int64)  # load on a -> least load on b
    best_b[0] = 0
    for ca, cb in zip(cost_a, cost_b):
        on_b = best_b + cb
        on_a = np.full(size, np.iinfo(np.int64).max // 4, dtype=np.int64)
        on_a[ca:] = best_b[:size - ca] if ca else best_b
        best_b = np.minimum(on_a, on_b)
    loads = np.maximum(np.arange(size), best_b)
    return int(loads.min()) * SCALE


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


def _add_hint(model, hints, problem: _Problem, handling, drive, first_drive, ready, v: dict) -> dict | None:
    """The market's assignment and order (``hints``: task key -> (robot, depart s, end s), or a list of
    such schedules, the shortest once re-timed is taken) as CP-SAT's first solution, every variable
    given: the tasks are re-timed in the model's own units (0.01 s, rounded up), in the schedule's order,
    each as early as its predecessors, its robot and the drive allow, so that the hint is feasible as it
    stands and the best found is never longer than the market's schedule."""
    tasks = problem.tasks
    keys = {t.key for t in tasks}
    ends = {t.key: t.request.end for t in tasks}

    def retime(hint: dict):
        if any(t.key not in hint or (t.key, hint[t.key][0]) not in v["assigned"] for t in tasks):
            return None  # a partial hint would only mislead the search
        return _retime(tasks, problem.fleet, hint, handling, drive, first_drive, ready)

    candidates = [(hint, retime(hint)) for hint in (hints if isinstance(hints, list) else [hints]) if hint]
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
        model.AddHint(gate, max((times[t.key][2] for t in tasks if t.activity == Task.ASSEMBLE and t.floor <= floor), default=0))
    longest = max((x[2] for x in times.values()), default=0)
    model.AddHint(v["makespan"], longest)
    model.Add(v["makespan"] <= longest)  # the hint is a schedule: the optimum is no longer
    return {key: (hint[key][0], *values) for key, values in times.items()}


def _solve(problem: _Problem, hint: dict | list | None, time_limit_s: float, workers: int, seed: int,
           deterministic_limit: float | None) -> _Solved:
    cp_model = require_extra("ortools.sat.python.cp_model", "optimize")
    model, (makespan, assigned, depart, start, end, capable, hinted, least, justify) = _build(cp_model, problem, hint)
    solver = cp_model.CpSolver()
    solver.parameters.max_time_in_seconds = time_limit_s
    if deterministic_limit is not None:
        solver.parameters.max_deterministic_time = deterministic_limit
    solver.parameters.num_workers = workers
    solver.parameters.random_seed = seed
    status = solver.Solve(model)
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE) and hinted:  # stopped before reading the hint
        bound = solver.BestObjectiveBound()
        return _Solved(
            makespan=max(x[3] for x in hinted.values()) / SCALE,
            bound=max(least, bound if math.isfinite(bound) else 0) / SCALE,
            status="FEASIBLE",
            assignment={k: x[0] for k, x in hinted.items()},
            depart={k: x[1] / SCALE for k, x in hinted.items()},
            start={k: x[2] / SCALE for k, x in hinted.items()},
            end={k: x[3] / SCALE for k, x in hinted.items()},
            deterministic_s=solver.response_proto.deterministic_time,
        )
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        raise InputError(f"CP-SAT found no schedule within {time_limit_s} s (status {solver.StatusName(status)})")
    tasks = problem.tasks
    robot = {t.key: next(r.name for r in capable[t.key] if solver.Value(assigned[t.key, r.name])) for t in tasks}
    timed = justify({t.key: (robot[t.key], solver.Value(depart[t.key]), solver.Value(end[t.key])) for t in tasks})
    return _Solved(
        makespan=max(x[2] for x in timed.values()) / SCALE,
        bound=max(least, solver.BestObjectiveBound()) / SCALE,
        status=solver.StatusName(status),
        assignment=robot,
        depart={k: x[0] / SCALE for k, x in timed.items()},
        start={k: x[1] / SCALE for k, x in timed.items()},
        end={k: x[2] / SCALE for k, x in timed.items()},
        deterministic_s=solver.response_proto.deterministic_time,
    )


def market_hint(smart: SmartModel, fleet: Fleet, site: Site | None, storey_elevations, tasks: list[_Task]) -> tuple[dict, float]:
    """The least-cost market's schedule of the same tasks (``per_node=False``) as {task key: (robot,
    depart s, end s)} and its makespan (s). A joint's assembly is one row per node: it departs with the
    first and ends with the last."""
    from bimrobot.coordination.simulation import simulate

    result = simulate(smart, fleet, site, "least-cost", 0, (), storey_elevations, per_node=False)
    keys = {t.key for t in tasks}
    hint: dict[str, tuple[str, float, float]] = {}
    for row in result.activities:
        if row.activity == Task.ASSEMBLE:  # "Assemble <node id>": one row per connection node of the joint
            node = row.node_id or row.name.split(" ", 1)[1]
            key = f"assemble:{smart.nodes[node].joint_id}" if node in smart.nodes else None
        else:
            key = f"{row.activity}:{row.global_id}"
        if key not in keys:
            continue
        if key in hint:
            robot, left, done = hint[key]
            hint[key] = (robot, min(left, row.start), max(done, row.finish))
        else:
            hint[key] = (row.robot, row.start, row.finish)
    return hint, result.makespan


def solve_optimal(
    smart: SmartModel,
    fleet: Fleet,
    site: Site | None = None,
    storey_elevations: list[float] | None = None,
    time_limit_s: float = 60.0,
    workers: int = 2,
    max_tasks: int = 20_000,
    deterministic_limit: float | None = None,
    seed: int = 0,
    hint: bool = True,
    whole_tasks: int = WHOLE_TASKS,
) -> OptimalSchedule:
    """Minimum-makespan schedule of the build (CP-SAT; module docstring). Raises InputError above
    ``max_tasks`` tasks. ``time_limit_s``: wall-clock limit of all solves together (s);
    ``deterministic_limit``: CP-SAT's deterministic time limit per solve (reproducible; tests use it with
    ``workers=1``); ``hint``: start from the least-cost market's schedule; ``whole_tasks``: above this
    many tasks, solve floor by floor."""
    sim = ConstructionSimulation(smart, fleet, site, storey_elevations=storey_elevations)
    tasks = task_graph(smart, sim)
    if len(tasks) > max_tasks:
        raise InputError(f"the build has {len(tasks)} tasks; the CP-SAT comparison is limited to {max_tasks}")
    homes = {spec.name: np.array(sim.site.robot_start(i, fleet.home_on_site(spec, sim.offset))[:2], dtype=float)
             for i, spec in enumerate(fleet.robots)}
    started = time.perf_counter()
    given, hinted = market_hint(smart, fleet, site, storey_elevations, tasks) if hint else (None, None)
    limits = dict(workers=workers, seed=seed, deterministic_limit=deterministic_limit)
    if len(tasks) <= whole_tasks:
        least, work, joined = _floor_bounds(tasks, fleet, homes, given, time_limit_s * FLOOR_SHARE, limits)
        solved = _solve(_Problem(tasks, fleet, homes, {r.name: 0.0 for r in fleet.robots}, floor_least=least),
                        [given, joined] if given else None,
                        max(time_limit_s - (time.perf_counter() - started), 1.0), **limits)
        return OptimalSchedule(solved.makespan, solved.bound, solved.status, solved.assignment, solved.start,
                               len(tasks), "whole", time.perf_counter() - started, hinted,
                               deterministic_s=solved.deterministic_s + work)
    return _by_floor(tasks, fleet, homes, given, hinted, time_limit_s, started, limits)


def _floor_bounds(tasks, fleet, homes, given, time_limit_s, limits) -> tuple[dict[int, int], float]:
    """Each floor's least duration (ticks), where floors cannot overlap (every task of a floor after the
    floor gate below and before its own): the bound of that floor solved alone, from time 0, every robot
    standing where it may be when the floor opens (home, or the end of any of its tasks below; for each
    task the nearest of them). Returns {floor: ticks} ({} where floors may overlap or with one floor)
    the solves' deterministic time and their schedules one after the other (an order for a hint)."""
    floors = sorted({t.floor for t in tasks})
    locals_ = {}
    for floor in floors:
        mine = [t for t in tasks if t.floor == floor]
        keys = {t.key for t in mine}
        locals_[floor] = [_Task(t.key, t.activity, t.request, [p for p in t.predecessors if p in keys], None, t.floor)
                          for t in mine]
        if not (_all_feed_a_joint(locals_[floor]) and (floor == floors[0] or _all_after_the_gate(mine))):
            return {}, 0.0, None
    if len(floors) < 2:
        return {}, 0.0, None
    least, work, below, joined, clock = {}, 0.0, [], {}, 0.0
    for floor in floors:
        local = locals_[floor]
        keys = {t.key for t in local}
        starts = {r.name: [homes[r.name]] + [np.asarray(t.request.end, dtype=float) for t in below
                                             if not incapability(r, t.request)] for r in fleet.robots}
        shifted = None
        if given and keys <= given.keys():  # the market's schedule of this floor, moved to begin at 0
            opening = min(given[k][1] for k in keys)
            shifted = {k: (given[k][0], given[k][1] - opening, given[k][2] - opening) for k in keys}
        solved = _solve(_Problem(local, fleet, homes, {r.name: 0.0 for r in fleet.robots}, starts=starts), shifted,
                        max(1.0, time_limit_s * len(local) / len(tasks)), **limits)
        least[floor] = int(round(solved.bound * SCALE))
        work += solved.deterministic_s
        below += local
        joined.update({k: (robot, clock + solved.depart[k], clock + solved.end[k]) for k, robot in solved.assignment.items()})
        clock += solved.makespan
    return least, work, joined


def _by_floor(tasks, fleet, homes, given, hinted, time_limit_s, started, limits) -> OptimalSchedule:
    """Floor after floor (module docstring): each floor's best schedule from where the robots stopped,
    and its bound with the robots free to start anywhere at once."""
    floors = sorted({t.floor for t in tasks})
    ready = {r.name: 0.0 for r in fleet.robots}
    where = dict(homes)
    assignment, start, rows = {}, {}, []
    clock, bounds, disjoint, work = 0.0, [], True, 0.0
    for floor in floors:
        mine = [t for t in tasks if t.floor == floor]
        keys = {t.key for t in mine}
        local = [_Task(t.key, t.activity, t.request, [p for p in t.predecessors if p in keys], None, t.floor) for t in mine]
        disjoint &= _all_feed_a_joint(local) and (floor == floors[0] or _all_after_the_gate(mine))
        budget = max(1.0, (time_limit_s - (time.perf_counter() - started)) * len(mine) / max(1, sum(
            1 for t in tasks if t.floor >= floor)))
        release = {name: max(ready[name], clock) for name in ready}
        shifted = None
        if given and keys <= given.keys():  # the market's schedule of this floor, moved to begin at the release
            offset = max(0.0, clock - min(given[k][1] for k in keys))
            shifted = {k: (given[k][0], given[k][1] + offset, given[k][2] + offset) for k in keys}
        solved = _solve(_Problem(local, fleet, where, release), shifted, budget * 0.7, **limits)
        relaxed = _solve(_Problem(local, fleet, where, {r.name: 0.0 for r in fleet.robots}, free_start=True),
                         shifted, budget * 0.3, **limits)  # the hint, re-timed there, keeps it from failing
        bounds.append(relaxed.bound)
        work += solved.deterministic_s + relaxed.deterministic_s
        for key, robot in solved.assignment.items():
            assignment[key] = robot
            start[key] = solved.start[key]
            if solved.end[key] >= ready[robot]:
                ready[robot] = solved.end[key]
                where[robot] = np.asarray(next(t for t in local if t.key == key).request.end, dtype=float)
        clock = solved.makespan
        rows.append({"floor": floor, "tasks": len(mine), "end_s": solved.makespan, "status": solved.status,
                     "bound_s": relaxed.bound})
    bound = sum(bounds) if disjoint else max(bounds)
    return OptimalSchedule(clock, min(bound, clock), "FEASIBLE", assignment, start, len(tasks), "by floor",
                           time.perf_counter() - started, hinted, rows, work)


def _all_after_the_gate(tasks: list[_Task]) -> bool:
    """Whether every task of a floor waits, through the floor's own precedences, for a transport held
    by the floor gate (then nothing of this floor can start before the floors below are done)."""
    keys = {t.key for t in tasks}
    gated = {t.key for t in tasks if t.gate_floor is not None}
    changed = True
    while changed:
        changed = False
        for t in tasks:
            if t.key not in gated and any(p in gated for p in t.predecessors if p in keys):
                gated.add(t.key)
                changed = True
    return len(gated) == len(tasks)


def _all_feed_a_joint(tasks: list[_Task]) -> bool:
    """Whether every task of a floor is a joint or comes before one of the floor's joints (then nothing
    of this floor can run on after its gate, and floors follow each other without overlap)."""
    feeds = {p for t in tasks if t.activity == Task.ASSEMBLE for p in t.predecessors}
    changed = True
    while changed:
        changed = False
        for t in tasks:
            if t.key in feeds:
                for p in t.predecessors:
                    if p not in feeds:
                        feeds.add(p)
                        changed = True
    return all(t.activity == Task.ASSEMBLE or t.key in feeds for t in tasks)
