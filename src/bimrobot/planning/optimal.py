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
- precedences: ``depart[t] >= end[p]``; the floor gate (every task that closes a lower floor, its joints and
  its parts without connection nodes, before a transport)
  goes through one variable per floor, not one constraint per pair;
- per robot: a circuit over its possible tasks (an arc t -> u: ``depart[u] >= end[t]`` and
  ``start[u] >= depart[u] + travel(t -> u)``), arcs that contradict a precedence left out;
- redundant, for the bound: per robot a NoOverlap of its busy intervals [depart, end] (each at least
  its handling plus the shortest drive into it), and per group of tasks that the same robots can do a
  Cumulative of capacity the group's size;
- per floor, between the gate below and its own gate: each robot's work and its drives, counted once
  per point it works at (:class:`~bimrobot.planning.optimal_bounds._Visits`); for two robots that
  share work, the fastest split of it (subset sums); the two-stage bound
  (:func:`~bimrobot.planning.optimal_bounds._staged_bound`; where the problem is one floor from time 0,
  each robot from its own start, its first drive in included, in both stages); on the lowest floor, each robot's start no
  earlier than the lead-in of its first task (:func:`~bimrobot.planning.optimal_bounds._first_lead`);
  and, where floors cannot overlap, the
  bound of that floor solved alone (:func:`_floor_bounds`), whose schedules, one floor after the
  other, are a second hint next to the market's. A floor that repeats one below it (a repeated storey:
  the same problem to the tick, from the same places) takes that floor's solve (:func:`_solve_once`).

Where floors cannot overlap, the floors are then solved again two at a time from where the robots
stopped below, keeping the lower floor of each pair (:func:`_chain`): one after the other, a schedule of
the whole build, the third hint. Where every floor reaches its bound alone, that schedule reaches the sum
of the floors' bounds and is optimal without the whole model (``method`` ``floors chained``).

Where the whole model is too big (more than ``whole_tasks`` tasks), the build is solved floor by floor
(the floor gate makes floors follow each other): each floor starts when the one below is done, with
every robot where it stopped. The lower bound is then the sum of each floor's bound with its robots
free to start anywhere at once (valid because floors cannot overlap).

"Floor" here is a run of floors whose work may overlap, taken as one
(:func:`~bimrobot.planning.optimal_graph.merge_overlapping_floors`): runs follow each other by
construction, so every reasoning above that needs floors that cannot overlap holds between runs.

The tasks are built in :mod:`~bimrobot.planning.optimal_graph`, the model in
:mod:`~bimrobot.planning.optimal_model`, its bounds and cuts in :mod:`~bimrobot.planning.optimal_bounds`.

CP-SAT runs without its LP (``linearization_level`` 0, :data:`LINEARIZATION`): the bound is the constants
above, known before the search, and propagation alone closes what is left far sooner where they are tight.

Determinism: ``workers=1`` with ``deterministic_limit`` (CP-SAT's deterministic time, not wall time)
and a fixed ``seed`` gives the same result on every machine; tests use that.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np

from bimrobot.site.fleet import Fleet
from bimrobot.site.site import Site
from bimrobot.coordination.market import handling_time, incapability
from bimrobot.coordination.simulation import ConstructionSimulation
from bimrobot.core.errors import InputError, require_extra
from bimrobot.sco.build import SmartModel
from bimrobot.core.tasks import Task
# the tasks (optimal_graph), the CP-SAT model (optimal_model) and its bounds live in siblings
from bimrobot.planning.optimal_graph import SCALE, _Task, merge_overlapping_floors, task_graph, within
from bimrobot.planning.optimal_model import OutOfTime, _build, _Problem
from bimrobot.planning.optimal_stop import allow_side_solves, solve_stoppably, stop_side_solves

#: Above this many tasks the build is solved floor by floor (:func:`solve_optimal`).
WHOLE_TASKS = 400
#: The share of the time limit spent on each floor alone, for its least duration (:func:`_floor_bounds`).
FLOOR_SHARE = 0.6
#: CP-SAT's ``linearization_level``: 0, no LP. The bound comes from the constants known before the search
#: (optimal_bounds), and propagation alone then proves a floor far sooner than with the LP (3x2x2's column
#: floor: 0.11 units against none within 30; docs/evidence/planning.md, "CP-SAT").
LINEARIZATION = 0
#: The share spent on the floors again, two at a time from where the robots stopped below (:func:`_chain`),
#: with the time the floors alone left unused.
CHAIN_SHARE = 0.2


@dataclass
class OptimalSchedule:
    """The best schedule CP-SAT found. ``makespan`` and ``lower_bound`` in seconds; ``status``
    ``OPTIMAL`` (proved: makespan == lower bound) or ``FEASIBLE``; ``method`` ``whole``, ``floors
    chained`` or ``by floor``;
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
    #: the makespan (s) of the floors chained, each solved from where the robots stopped below (None: not run)
    chained_s: float | None = None
    #: why the schedule is not CP-SAT's own ("" where it is): the time limit passed while models were built
    note: str = ""

    @property
    def gap(self) -> float:
        """(makespan - lower bound) / makespan: 0 when proved optimal."""
        return 0.0 if self.makespan <= 0 else max(0.0, (self.makespan - self.lower_bound) / self.makespan)


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


def _solve(problem: _Problem, hint: dict | list | None, time_limit_s: float, workers: int, seed: int,
           deterministic_limit: float | None, deadline: float | None = None, linearization: int = LINEARIZATION) -> _Solved:
    """``problem`` solved within ``time_limit_s`` (s) and before ``deadline`` (``time.perf_counter()``),
    building the model included; :class:`OutOfTime` where the deadline passes first. ``linearization``:
    CP-SAT's ``linearization_level`` (:data:`LINEARIZATION`)."""
    cp_model = require_extra("ortools.sat.python.cp_model", "optimize")
    model, (makespan, assigned, depart, start, end, capable, hinted, least, justify, weight) = _build(
        cp_model, dataclasses.replace(problem, deadline=deadline), hint)
    solver = cp_model.CpSolver()
    left = math.inf if deadline is None else deadline - time.perf_counter()
    if left <= 0:
        raise OutOfTime
    solver.parameters.max_time_in_seconds = min(time_limit_s, left)
    if deterministic_limit is not None:
        solver.parameters.max_deterministic_time = deterministic_limit
    solver.parameters.num_workers = workers
    solver.parameters.random_seed = seed
    solver.parameters.linearization_level = linearization
    status = solve_stoppably(solver, model)
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE) and hinted:  # stopped before reading the hint
        bound = solver.BestObjectiveBound()
        return _Solved(
            makespan=max(x[3] for x in hinted.values()) / SCALE,
            bound=max(least, bound // weight if math.isfinite(bound) else 0) / SCALE,
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
        bound=max(least, solver.BestObjectiveBound() // weight) / SCALE,
        status=solver.StatusName(status),
        assignment=robot,
        depart={k: x[0] / SCALE for k, x in timed.items()},
        start={k: x[1] / SCALE for k, x in timed.items()},
        end={k: x[2] / SCALE for k, x in timed.items()},
        deterministic_s=solver.response_proto.deterministic_time,
    )


def schedule_hint(smart: SmartModel, fleet: Fleet, site: Site | None, storey_elevations, tasks: list[_Task],
                  result=None) -> tuple[dict, float]:
    """The schedule of ``result`` (a ``SimulationResult`` of the same problem per joint: another
    planner's run), by default the least-cost market's run of the same tasks (``per_node=False``), as
    {task key: (robot, depart s, end s)} and its makespan (s). A joint's assembly is one row per node: it
    departs with the first and ends with the last."""
    from bimrobot.coordination.simulation import simulate

    if result is None:
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
    hint=True,
    whole_tasks: int = WHOLE_TASKS,
    linearization: int = LINEARIZATION,
) -> OptimalSchedule:
    """Minimum-makespan schedule of the build (CP-SAT; module docstring). Raises InputError above
    ``max_tasks`` tasks. ``time_limit_s``: wall-clock limit of the whole call (s), building the models
    included: where it passes first, the shortest complete schedule at hand (the market's, or the floors
    chained) is returned with the reason in ``note``;
    ``deterministic_limit``: CP-SAT's deterministic time limit per solve (reproducible; tests use it with
    ``workers=1``); ``hint``: start from the least-cost market's schedule (True), from
    a given ``SimulationResult`` of the same problem per joint, or from none (False); ``whole_tasks``: above this
    many tasks, solve floor by floor; ``linearization``: CP-SAT's ``linearization_level`` (0: no LP)."""
    started = time.perf_counter()
    sim = ConstructionSimulation(smart, fleet, site, storey_elevations=storey_elevations)
    tasks = merge_overlapping_floors(task_graph(smart, sim))
    if len(tasks) > max_tasks:
        raise InputError(f"the build has {len(tasks)} tasks; the CP-SAT comparison is limited to {max_tasks}")
    homes = {spec.name: np.array(sim.site.robot_start(i, fleet.home_on_site(spec, sim.offset))[:2], dtype=float)
             for i, spec in enumerate(fleet.robots)}
    start_from = None if hint is True else hint
    given, hinted = schedule_hint(smart, fleet, site, storey_elevations, tasks, start_from) if hint else (None, None)
    limits = dict(workers=workers, seed=seed, deterministic_limit=deterministic_limit, deadline=started + time_limit_s,
                  linearization=linearization)
    if len(tasks) > whole_tasks:
        return _by_floor(tasks, fleet, homes, given, hinted, time_limit_s, started, limits)
    least, work, rows, chained = {}, 0.0, [], None
    try:
        cache: dict = {}  # a repeated storey's problem is solved once (_solve_once)
        least, work, joined, rows, alone = _floor_bounds(tasks, fleet, homes, given, time_limit_s * FLOOR_SHARE, limits,
                                                         cache)
        if alone:  # the floors' schedules again, each from where the robots stopped below (CHAIN_SHARE)
            chain_s = started + time_limit_s * (FLOOR_SHARE + CHAIN_SHARE) - time.perf_counter()  # with what the floors left
            chained, more = _chain(alone, least, fleet, homes, max(1.0, chain_s), limits, cache, tasks)
            work += more
            if round(chained.makespan * SCALE) <= sum(least.values()):  # it reaches the floors' bounds: optimal
                return OptimalSchedule(chained.makespan, chained.makespan, "OPTIMAL", chained.assignment,
                                       chained.start, len(tasks), "floors chained", time.perf_counter() - started,
                                       hinted, rows, deterministic_s=work, chained_s=chained.makespan)
        hints = [h for h in (given, joined, chained and chained.hint) if h]
        solved = _solve(_Problem(tasks, fleet, homes, {r.name: 0.0 for r in fleet.robots}, floor_least=least),
                        hints or None, max(time_limit_s - (time.perf_counter() - started), 1.0), **limits)
    except OutOfTime:
        return _out_of_time(tasks, fleet, given, hinted, chained, sum(least.values()) / SCALE, "whole",
                            time_limit_s, started, rows, work)
    return OptimalSchedule(solved.makespan, solved.bound, solved.status, solved.assignment, solved.start,
                           len(tasks), "whole", time.perf_counter() - started, hinted, rows,
                           deterministic_s=solved.deterministic_s + work,
                           chained_s=chained.makespan if chained else None)


def _out_of_time(tasks, fleet, given, hinted, chained, bound_s, method, time_limit_s, started, rows, work) -> OptimalSchedule:
    """The time limit passed before CP-SAT had a schedule of the whole build: the shortest complete one
    at hand (the market's, ``given``: task -> (robot, depart s, end s); or ``chained``), with ``bound_s``
    (s) and the reason in ``note``. InputError where there is none (no hint asked for)."""
    reason = f"the time limit of {time_limit_s:g} s passed before CP-SAT had a schedule of the whole build"
    if chained is not None and (given is None or chained.makespan < hinted):
        assignment, start, makespan, note = chained.assignment, chained.start, chained.makespan, "the floors chained"
    elif given is not None:
        robots = {r.name: r for r in fleet.robots}
        assignment = {t.key: given[t.key][0] for t in tasks if t.key in given}
        start = {t.key: given[t.key][2] - handling_time(robots[given[t.key][0]], t.request) for t in tasks if t.key in given}
        makespan, note = hinted, "the market's schedule"
    else:
        raise InputError(f"{reason}, and none was given to start from")
    return OptimalSchedule(makespan, min(bound_s, makespan), "FEASIBLE", assignment, start, len(tasks), method,
                           time.perf_counter() - started, hinted, rows, work,
                           chained.makespan if chained else None, f"{reason}: {note}")


def _floor_bounds(tasks, fleet, homes, given, time_limit_s, limits, cache=None):
    """Each floor's least duration (ticks), where floors cannot overlap (every task of a floor after the
    floor gate below and before its own): the bound of that floor solved alone, from time 0, every robot
    standing where it may be when the floor opens (home, or the end of any of its tasks below; for each
    task the nearest of them). Valid because the floors follow each other: the whole makespan is the sum
    of the floors' durations, and no floor, whatever the robots did below, is shorter than its optimum
    from the best of those starts. Where every floor is proved optimal, the whole model's bound is their
    sum from the start, and a schedule that reaches it is proved optimal. ``time_limit_s`` (s) is shared
    by task count over the floors that differ: a floor that repeats one below (a repeated storey, the same
    problem to the tick) takes that floor's solve (``cache``, :func:`_solve_once`); time a floor leaves
    unused passes to the floors above. ``tasks`` come from
    :func:`~bimrobot.planning.optimal_graph.merge_overlapping_floors`, so floors cannot overlap. Returns
    {floor: ticks} ({} with one floor), the solves' deterministic time, their schedules one after the other
    (an order for a hint), one row per floor (tasks, best_s, bound_s, status) and each floor's (tasks,
    schedule) solved alone ([] with one floor)."""
    floors = sorted({t.floor for t in tasks})
    locals_ = {floor: within([t for t in tasks if t.floor == floor], gate_floor=None) for floor in floors}
    if len(floors) < 2:
        return {}, 0.0, None, [], []
    cache = {} if cache is None else cache
    problems, below = [], []
    for floor in floors:
        starts = {r.name: _unique([homes[r.name]] + [t.request.end for t in below if not incapability(r, t.request)])
                  for r in fleet.robots}
        problems.append(_Problem(locals_[floor], fleet, homes, {r.name: 0.0 for r in fleet.robots}, starts=starts))
        below += locals_[floor]
    hints = [_shifted(given, problem.tasks) for problem in problems]
    least, work, joined, clock, rows, alone, seen = {}, 0.0, {}, 0.0, [], [], set()
    if limits["workers"] > 1:
        work += _solve_apart(cache, problems, hints, time_limit_s, limits)
    keys = [_problem_key(problem) for problem in problems]
    deadline, left = time.perf_counter() + time_limit_s, sum(dict(zip(keys, (len(p.tasks) for p in problems))).values())
    for floor, problem, shifted, key in zip(floors, problems, hints, keys):
        local = problem.tasks
        repeated = key in seen
        seen.add(key)
        solved = _solve_once(cache, problem, shifted, max(1.0, (deadline - time.perf_counter()) * len(local) / max(1, left)),
                             **limits)
        left -= 0 if repeated else len(local)
        least[floor] = int(round(solved.bound * SCALE))
        rows.append({"floor": floor, "tasks": len(local), "best_s": solved.makespan, "bound_s": solved.bound,
                     "status": solved.status, "repeats": repeated})
        work += solved.deterministic_s
        joined.update({k: (robot, clock + solved.depart[k], clock + solved.end[k]) for k, robot in solved.assignment.items()})
        clock += solved.makespan
        alone.append((floor, local, solved))
    return least, work, joined, rows, alone


def _shifted(given, local: list[_Task]) -> dict | None:
    """The market's schedule (``given``: task -> (robot, depart s, end s)) of one floor's tasks, moved to
    begin at 0; None without it."""
    keys = {t.key for t in local}
    if not given or not keys <= given.keys():
        return None
    opening = min(given[k][1] for k in keys)
    return {k: (given[k][0], given[k][1] - opening, given[k][2] - opening) for k in sorted(keys)}


def _solve_apart(cache: dict, problems: list[_Problem], hints: list, time_limit_s: float, limits: dict) -> float:
    """The floors' problems that differ, solved alone at the same time, ``limits["workers"]`` at a time
    with one CP-SAT worker each, into ``cache`` (:func:`_solve_once`): a floor's proof comes sooner from
    one worker with a core to itself than from two that share it (2x2x3's floor 1: proved at 19.5 units,
    28 CPU s, with one; not with two in 124 CPU s). ``time_limit_s`` (s) is shared by task count. Returns
    the solves' deterministic time."""
    from concurrent.futures import ThreadPoolExecutor

    todo: dict = {}
    for problem, hint in zip(problems, hints):
        todo.setdefault(_problem_key(problem), (problem, hint))
    total, workers = sum(len(problem.tasks) for problem, _ in todo.values()), limits["workers"]
    one = dict(limits, workers=1)
    allow_side_solves()
    pool = ThreadPoolExecutor(workers)  # CP-SAT's solve runs without Python's lock: the threads run at once
    try:
        futures = {key: pool.submit(_solve, problem, hint, min(time_limit_s, max(1.0, time_limit_s * workers * len(
            problem.tasks) / total)), **one) for key, (problem, hint) in todo.items()}
        solved = {key: future.result() for key, future in futures.items()}
    except BaseException:  # a stop (Ctrl-C, SIGTERM): end the searches now, not at their time limits
        pool.shutdown(wait=False, cancel_futures=True)
        stop_side_solves()
        raise
    finally:
        pool.shutdown(wait=True)
    for key, (problem, _) in todo.items():
        cache[key] = ([t.key for t in problem.tasks], solved[key])
    return sum(s.deterministic_s for s in solved.values())


def _unique(points) -> list[np.ndarray]:
    """``points`` (site frame, m) without repeats, in a fixed order (a floor's starts, for its key)."""
    return [np.array(xy) for xy in sorted({tuple(float(c) for c in np.asarray(xy, dtype=float)[:2]) for xy in points})]


def _problem_key(problem: _Problem) -> tuple:
    """What a problem's model is built from, without its tasks' names: per task its activity, where it
    begins and ends (m), its handling per capable robot (s) and its predecessors by position; the robots'
    homes, starts, release times and targets; each floor's least duration. Two problems with the same key
    (a storey that repeats the one below it) build the same model, so one's solve stands for the other's."""
    index = {t.key: i for i, t in enumerate(problem.tasks)}
    ranks = {f: i for i, f in enumerate(sorted({t.floor for t in problem.tasks}))}

    def xy(point) -> tuple[float, ...]:
        return tuple(float(c) for c in np.asarray(point, dtype=float)[:2])

    tasks = tuple((str(t.activity), xy(t.request.start), xy(t.request.end), ranks[t.floor], t.gate_floor is None,
                   tuple((r.name, handling_time(r, t.request)) for r in problem.fleet.robots if not incapability(r, t.request)),
                   tuple(index[p] for p in t.predecessors if p in index)) for t in problem.tasks)
    robots = tuple((name, xy(problem.homes[name]), problem.ready.get(name, 0.0),
                    tuple(sorted(xy(p) for p in problem.starts[name])) if problem.starts else None,
                    xy(problem.end_targets[name]) if problem.end_targets and name in problem.end_targets else None)
                   for name in sorted(problem.homes))
    least = tuple(sorted((ranks[f], ticks) for f, ticks in problem.floor_least.items() if f in ranks))
    return tasks, robots, least, problem.free_start, problem.fleet.name


def _solve_once(cache: dict, problem: _Problem, hint, time_limit_s: float, **limits) -> _Solved:
    """:func:`_solve`, or, where a problem with the same key (:func:`_problem_key`) was solved before, that
    solve's schedule and bound under this problem's task names, without solving again (deterministic time
    0): the same model has the same optimum, and its schedule is one of this problem's."""
    key = _problem_key(problem)
    if key in cache:
        names, solved = cache[key]
        rename = dict(zip(names, (t.key for t in problem.tasks)))
        return dataclasses.replace(solved, deterministic_s=0.0, **{field: {rename[k]: v for k, v in getattr(solved, field).items()}
                                                                    for field in ("assignment", "depart", "start", "end")})
    solved = _solve(problem, hint, time_limit_s, **limits)
    cache[key] = ([t.key for t in problem.tasks], solved)
    return solved


@dataclass
class _Chained:
    """The floors' schedules one after the other, each from where the robots stopped below: ``makespan``
    (s), per task its robot and work start (s), and ``hint`` (task -> (robot, depart s, end s))."""

    makespan: float
    assignment: dict[str, str]
    start: dict[str, float]
    hint: dict[str, tuple[str, float, float]]


def _first_points(local: list[_Task], solved: _Solved) -> dict[str, np.ndarray]:
    """Robot -> where its first task of ``solved`` (a floor's schedule alone) begins (site frame, m)."""
    first: dict[str, _Task] = {}
    for t in sorted(local, key=lambda t: solved.depart[t.key]):
        first.setdefault(solved.assignment[t.key], t)
    return {robot: np.asarray(t.request.start, dtype=float) for robot, t in first.items()}


def _stops(local: list[_Task], solved: _Solved) -> dict[str, np.ndarray]:
    """Robot -> where it stops after ``local``'s tasks in ``solved`` (a schedule of them, or of more): the
    end point of its task of ``local`` that ends last (of equal ends, the later in the assignment's order); site frame, m."""
    ends = {t.key: t.request.end for t in local}
    stops = {}
    for key, robot in sorted(((k, r) for k, r in solved.assignment.items() if k in ends), key=lambda item: solved.end[item[0]]):
        stops[robot] = np.asarray(ends[key], dtype=float)
    return stops


def _chain(alone, least, fleet, homes, time_limit_s, limits, cache=None, tasks=None) -> tuple[_Chained, float]:
    """The floors again, two at a time from where every robot stopped below (home at first): floors i and
    i + 1 solved together (the floor gate between them, each floor's bound alone, ``least`` in ticks, as
    its least duration), and floor i's part kept, so a floor's schedule is chosen with what its robots'
    stops cost the floor above; the last pair keeps both. Each pair starts from floor i's schedule of the
    pair before (or alone) and floor i + 1's alone, and among its shortest schedules takes the one whose
    robots stop nearest to where they begin floor i + 2 alone. Floors cannot overlap, so one after the
    other this is a schedule of the whole build; where every floor reaches its bound alone, the sum of the
    floors' bounds is reached and the schedule is optimal. ``time_limit_s`` (s) is shared by task count; a
    pair whose problem repeats one solved before (``cache``, :func:`_solve_once`) takes that solve.
    ``tasks``: the whole build's tasks (the floor gate between a pair's floors). Returns the schedule and
    the solves' deterministic time."""
    where, clock, work = dict(homes), 0.0, 0.0
    chained = _Chained(0.0, {}, {}, {})
    cache = {} if cache is None else cache
    deadline = time.perf_counter() + time_limit_s
    left = sum(len(alone[i][1]) + len(alone[i + 1][1]) for i in range(len(alone) - 1))
    carried = None  # floor i's part of the pair before, from time 0 (task -> (robot, depart s, end s))
    for i in range(len(alone) - 1):
        (floor, local, solo), (upper, above, solo_above) = alone[i], alone[i + 1]
        pair = {t.key for t in local + above}
        window = within([t for t in (tasks or []) if t.key in pair]) or local + above
        hints = [_joined([part, _timed(solo_above)]) for part in (carried, _timed(solo)) if part]
        targets = _first_points(*alone[i + 2][1:]) if i + 2 < len(alone) else None
        solved = _solve_once(cache, _Problem(window, fleet, where, {r.name: 0.0 for r in fleet.robots},
                                             floor_least={floor: least[floor], upper: least[upper]},
                                             end_targets=targets), hints,
                             max(1.0, (deadline - time.perf_counter()) * len(window) / max(1, left)), **limits)
        left -= len(window)
        work += solved.deterministic_s
        for part in ([local, above] if i + 2 == len(alone) else [local]):
            keys = {t.key for t in part}
            ends = max(solved.end[k] for k in keys)
            opens = min(solved.depart[k] for k in keys)
            where.update(_stops(part, solved))
            for key in sorted(keys, key=lambda k: solved.end[k]):
                chained.assignment[key] = solved.assignment[key]
                chained.start[key] = clock + solved.start[key] - opens
                chained.hint[key] = (solved.assignment[key], clock + solved.depart[key] - opens, clock + solved.end[key] - opens)
            clock += ends - opens
        keys = {t.key for t in above}
        opens = min(solved.depart[k] for k in keys)
        carried = {k: (solved.assignment[k], solved.depart[k] - opens, solved.end[k] - opens) for k in keys}
    chained.makespan = clock
    return chained, work


def _timed(solved: _Solved) -> dict:
    """A floor's schedule as task -> (robot, depart s, end s)."""
    return {k: (robot, solved.depart[k], solved.end[k]) for k, robot in solved.assignment.items()}


def _joined(parts: list[dict]) -> dict:
    """Floors' schedules (task -> (robot, depart s, end s), each from 0) one after the other."""
    joined, clock = {}, 0.0
    for part in parts:
        joined.update({k: (robot, clock + depart, clock + end) for k, (robot, depart, end) in part.items()})
        clock += max(end for _, _, end in part.values())
    return joined


def _by_floor(tasks, fleet, homes, given, hinted, time_limit_s, started, limits) -> OptimalSchedule:
    """Floor after floor (module docstring): each floor's best schedule from where the robots stopped,
    and its bound with the robots free to start anywhere at once. Where the time limit passes before the
    last floor is solved, the market's schedule, with the bound of the floors solved."""
    floors = sorted({t.floor for t in tasks})
    ready = {r.name: 0.0 for r in fleet.robots}
    where = dict(homes)
    assignment, start, rows = {}, {}, []
    clock, bounds, work = 0.0, [], 0.0
    locals_ = {floor: within([t for t in tasks if t.floor == floor], gate_floor=None) for floor in floors}
    for floor in floors:
        local = locals_[floor]
        keys = {t.key for t in local}
        budget = max(1.0, (time_limit_s - (time.perf_counter() - started)) * len(local) / max(1, sum(
            1 for t in tasks if t.floor >= floor)))
        release = {name: max(ready[name], clock) for name in ready}
        shifted = None
        if given and keys <= given.keys():  # the market's schedule of this floor, moved to begin at the release
            offset = max(0.0, clock - min(given[k][1] for k in keys))
            shifted = {k: (given[k][0], given[k][1] + offset, given[k][2] + offset) for k in sorted(keys)}
        try:
            solved = _solve(_Problem(local, fleet, where, release), shifted, budget * 0.7, **limits)
            relaxed = _solve(_Problem(local, fleet, where, {r.name: 0.0 for r in fleet.robots}, free_start=True),
                             shifted, budget * 0.3, **limits)  # the hint, re-timed there, keeps it from failing
        except OutOfTime:
            return _out_of_time(tasks, fleet, given, hinted, None, sum(bounds), "by floor", time_limit_s, started, rows,
                                work)
        bounds.append(relaxed.bound)
        work += solved.deterministic_s + relaxed.deterministic_s
        for key, robot in solved.assignment.items():
            assignment[key] = robot
            start[key] = solved.start[key]
            ready[robot] = max(ready[robot], solved.end[key])
        where.update(_stops(local, solved))
        clock = solved.makespan
        rows.append({"floor": floor, "tasks": len(local), "end_s": solved.makespan, "status": solved.status,
                     "bound_s": relaxed.bound})
    bound = sum(bounds)
    return OptimalSchedule(clock, min(bound, clock), "FEASIBLE", assignment, start, len(tasks), "by floor",
                           time.perf_counter() - started, hinted, rows, work)
