"""Planners behind one interface (issue 38): every planner is a dispatcher of the one event simulation.

A planner turns a problem (model + fleet + site, as ``simulate`` reads it: a
:class:`~bimrobot.planning.dispatch.DispatchProblem`) into a :class:`~bimrobot.coordination.market.Dispatcher`.
:class:`~bimrobot.coordination.simulation.ConstructionSimulation` then executes the plan: it asks the
dispatcher at each allocation round, so every planner's makespan comes from the same time model (travel,
handling, release, floor gate, idle robots driving back to the yard).

Names (:func:`planner_for`):

- ``market`` (least-cost) and ``market:quickest-finish``: the thesis' market (``market.MarketDispatcher``).
- ``rule:most-successors``, ``rule:longest-path``, ``rule:shortest-handling``: priority rules. At each
  round the ready tasks are taken in the rule's order (most tasks after it, directly or not; longest
  remaining path of shortest handling times, the critical path; shortest handling time); each goes to the
  capable idle robot that finishes it soonest (travel + handling; ties: robot name).
- ``rule:nearest``: the (ready task, idle robot) pair with the shortest drive first, again and again.
- ``rule:completes-joints``: joints first, then the parts in one fixed order, each next the one that
  completes the most joints with those before it (:func:`bimrobot.planning.rules.completing_order`).
- ``portfolio``: every planner above played on the problem in the event simulation, the shortest schedule
  kept (the first in :data:`PORTFOLIO`'s order on a tie). Cheap planners, several runs: the price is one
  simulation per member.
- ``cp-sat``: :func:`bimrobot.planning.optimal.solve_optimal`'s schedule, started from the shortest of
  the portfolio's schedules, replayed: each task goes to the robot CP-SAT chose, and each robot takes
  its tasks in CP-SAT's start order, each as soon as it is published and the robot is free (per joint
  only: CP-SAT's tasks are per joint).
- ``rollout``: the portfolio's best schedule improved by rollouts (the learned planner's search,
  :mod:`bimrobot.planning.learned_search`, on the advisers' first choices only: no policy).
- ``learned`` and ``PATH.zip``: a learned policy with decision-time search,
  :class:`bimrobot.planning.learned.LearnedPlanner` (imported only when asked for): the policy proposes,
  rollouts decide, never longer than the portfolio. ``learned:greedy``: the shipped policy alone,
  guarded by the market (``LearnedPlanner(path, search=0)``). The contract: ``LearnedPlanner(path)``
  (``path`` None for the policy shipped with the package) is a ``Dispatcher``, or has
  ``dispatcher(problem) -> Dispatcher``.

All planners are deterministic. Times in seconds, positions (x, y) in metres in the site frame.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from bimrobot.coordination.market import (
    Award, Dispatcher, MarketDispatcher, incapability, make_evaluator, propose,
)
from bimrobot.core.errors import InputError
from bimrobot.planning.rules import PORTFOLIO, RULES, RuleDispatcher, _request_key

#: the names :func:`planner_for` knows, in the order the CLI lists them (``PATH.zip`` besides)
PLANNERS = ("market", "market:quickest-finish", *(f"rule:{r}" for r in RULES), "portfolio", "rollout", "cp-sat", "learned",
            "learned:greedy")
DEFAULT = "market"
#: CP-SAT's limits when it plans for the CLI: wall seconds, deterministic seconds, one worker (reproducible)
CPSAT_TIME_LIMIT_S = 60.0
CPSAT_DETERMINISTIC_S = 20.0


@dataclass
class PlanStats:
    """What planning cost: ``decisions`` (awards made), ``decide_s`` (wall seconds in the dispatcher's
    rounds), ``solve_s`` (wall seconds before the run: CP-SAT's solve), and planner-specific ``notes``."""

    decisions: int = 0
    decide_s: float = 0.0
    solve_s: float = 0.0
    #: the same in this process's CPU seconds (steadier than wall time on a shared machine)
    decide_cpu_s: float = 0.0
    solve_cpu_s: float = 0.0
    notes: dict = field(default_factory=dict)

    @property
    def planning_s(self) -> float:
        return self.solve_s + self.decide_s

    @property
    def planning_cpu_s(self) -> float:
        return self.solve_cpu_s + self.decide_cpu_s

    @property
    def ms_per_decision(self) -> float | None:
        return None if not self.decisions else 1000.0 * self.decide_s / self.decisions

    @property
    def cpu_ms_per_decision(self) -> float | None:
        return None if not self.decisions else 1000.0 * self.decide_cpu_s / self.decisions


class Timed(Dispatcher):
    """A dispatcher that counts its decisions and the wall time of its rounds into ``stats``."""

    def __init__(self, inner: Dispatcher, stats: PlanStats):
        self.inner, self.stats, self.name = inner, stats, inner.name

    def awards(self, sim) -> list[Award] | None:
        started, cpu = time.perf_counter(), time.process_time()
        chosen = self.inner.awards(sim)
        self.stats.decide_s += time.perf_counter() - started
        self.stats.decide_cpu_s += time.process_time() - cpu
        self.stats.decisions += len(chosen or ())
        return chosen


# ---------------------------------------------------------------- CP-SAT replayed
class ReplayDispatcher(Dispatcher):
    """CP-SAT's plan (``assignment``: task key -> robot, ``start``: task key -> work start s) executed by
    the simulation: a robot takes the next task of its CP-SAT sequence once that task is published. CP-SAT's
    precedences are the simulation's (:func:`~bimrobot.planning.optimal_graph.task_graph`), so neither
    fallback is expected: when nothing runs and no robot's next task is ready, each idle robot takes its
    earliest planned ready task out of order (counted in ``reordered``); a published task CP-SAT did not
    plan goes to the least-cost idle robot (``unplanned``)."""

    name = "cp-sat"

    def __init__(self, assignment: dict[str, str], start: dict[str, float]):
        self.queues: dict[str, list[str]] = {}
        for key in sorted(assignment, key=lambda k: (start[k], k)):
            self.queues.setdefault(assignment[key], []).append(key)
        self.assignment = assignment
        self.reordered = 0
        self.unplanned = 0

    def awards(self, sim) -> list[Award]:
        now = sim.build.env.now
        ready = {_request_key(sim, r): r for pool in sim.build.pending.values() for r in pool}
        idle = {n for names in sim.build.idle.values() for n in names}
        chosen = []
        for name in sorted(idle):
            queue = self.queues.get(name)
            if queue and queue[0] in ready:
                chosen.append(self._award(sim, ready.pop(queue.pop(0)), name, now))
        running = any(r.task is not None for r in sim.build.robots.values())
        if not chosen and not running:
            for name in sorted(idle):
                mine = [k for k in self.queues.get(name, ()) if k in ready]
                if mine:
                    self.queues[name].remove(mine[0])
                    self.reordered += 1
                    chosen.append(self._award(sim, ready.pop(mine[0]), name, now))
        free = idle - {a.robot for a in chosen}
        for key, request in sorted(ready.items(), key=lambda kv: kv[1].priority):
            if key in self.assignment:
                continue
            names = [n for n in sorted(free & sim.build.idle[request.activity])
                     if not incapability(sim.build.robots[n].spec, request) and not self.queues.get(n)]
            if names:
                self.unplanned += 1
                award = min((self._award(sim, request, n, now) for n in names), key=lambda a: (a.proposal.cost, a.robot))
                chosen.append(award)
                free.discard(award.robot)
        return chosen

    @staticmethod
    def _award(sim, request, name: str, now: float) -> Award:
        robot = sim.build.robots[name]
        return Award(request, name, propose(robot.spec, sim.position_now(robot), now, True, request), 1)


# ---------------------------------------------------------------- the registry
@dataclass(frozen=True)
class Planner:
    """A named planner: ``make(problem, stats)`` returns the dispatcher that carries out its plan."""

    name: str
    description: str
    make: Callable


def _market(evaluator: str) -> Callable:
    return lambda problem, stats, **_: MarketDispatcher(make_evaluator(evaluator))


def _rule(rule: str) -> Callable:
    return lambda problem, stats, **_: RuleDispatcher(rule)


def _cpsat(problem, stats: PlanStats, time_limit_s: float = CPSAT_TIME_LIMIT_S,
           deterministic_s: float | None = CPSAT_DETERMINISTIC_S, workers: int = 1, **_) -> Dispatcher:
    """Solve with CP-SAT (per joint) from the portfolio's shortest schedule, keep its objective, bound and
    starting point in ``stats.notes``, replay its plan."""
    from bimrobot.planning.optimal import solve_optimal

    if problem.per_node:
        raise InputError("--planner cp-sat plans per joint (CP-SAT's tasks): add --per-joint")
    if problem.breakdowns:
        raise InputError("--planner cp-sat plans without breakdowns: leave out --breakdown")
    started, cpu = time.perf_counter(), time.process_time()
    # CP-SAT starts from the shortest of the portfolio's schedules, the market's among them: seconds of
    # simulation that spare the search the market's detours (GEELEN, 20 deterministic s: 6,915.7 s from
    # shortest-handling's schedule, 7,394.3 s from the market's; the same bound)
    runs = _portfolio_runs(problem)
    start_from = min(PORTFOLIO, key=lambda name: runs[name].makespan)  # min keeps the first of equals
    schedule = solve_optimal(problem.smart, problem.fleet, problem.site, problem.storey_elevations,
                             time_limit_s=time_limit_s, workers=workers, deterministic_limit=deterministic_s,
                             hint=runs[start_from])
    stats.solve_s += time.perf_counter() - started
    stats.solve_cpu_s += time.process_time() - cpu
    stats.notes.update(cpsat_makespan_s=schedule.makespan, cpsat_lower_bound_s=schedule.lower_bound,
                       cpsat_status=schedule.status, cpsat_method=schedule.method, cpsat_tasks=schedule.tasks,
                       cpsat_hint=start_from, cpsat_hint_s=schedule.hinted_s, market_s=runs["market"].makespan)
    replay = ReplayDispatcher(schedule.assignment, schedule.start)
    stats.notes["replay"] = replay
    return replay


def _portfolio_runs(problem) -> dict:
    """Each :data:`PORTFOLIO` member's run of ``problem`` (name -> ``SimulationResult``), executed by the
    event simulation: cheap, deterministic planners."""
    return {name: plan(name, problem)[0] for name in PORTFOLIO}


def _portfolio(problem, stats: PlanStats, **_) -> Dispatcher:
    """Play every :data:`PORTFOLIO` member on ``problem``, keep the shortest makespan (s; the first in
    order on a tie) and return a fresh dispatcher of that member: the planners are deterministic, so the
    run it drives repeats the member's schedule. Each member's makespan goes into ``stats.notes``."""
    started, cpu = time.perf_counter(), time.process_time()
    makespans = {name: float(run.makespan) for name, run in _portfolio_runs(problem).items()}
    chosen = min(PORTFOLIO, key=lambda name: makespans[name])  # min keeps the first of equals
    stats.solve_s += time.perf_counter() - started
    stats.solve_cpu_s += time.process_time() - cpu
    stats.notes.update(portfolio_chosen=chosen, portfolio_makespans_s={k: round(v, 3) for k, v in makespans.items()})
    return _REGISTRY[chosen].make(problem, stats)


def _learned(path: str | None, greedy: bool = False) -> Callable:
    """``search``: the rollouts of the policy's decision-time search (None: the default budget)."""
    def make(problem, stats, search: int | None = None, **_):
        if path is not None and not Path(path).is_file():
            raise InputError(f"--planner {path}: no such policy file")
        try:
            from bimrobot.planning.learned import LearnedPlanner
        except ModuleNotFoundError as exc:
            if exc.name != "bimrobot.planning.learned":
                raise
            raise InputError("--planner learned: no learned policy is installed (bimrobot.planning.learned is "
                             "missing from this bimrobot)") from None
        # the policy plays the whole build (and the search's rollouts) here: that is its planning time
        started, cpu = time.perf_counter(), time.process_time()
        planner = LearnedPlanner(path, search=0 if greedy else search)
        dispatcher = planner if isinstance(planner, Dispatcher) else planner.dispatcher(problem)
        stats.solve_s += time.perf_counter() - started
        stats.solve_cpu_s += time.process_time() - cpu
        stats.notes.update(getattr(planner, "last", {}))
        return dispatcher
    return make


def _rollout(problem, stats: PlanStats, search: int | None = None, **_) -> Dispatcher:
    """The learned planner's search without a policy: the portfolio's best schedule, improved by rollouts
    of the advisers' first choices (:func:`bimrobot.planning.learned_search.search`, ``policy`` None;
    ``search`` rollouts, None: the default budget)."""
    from bimrobot.planning.learned_search import DEFAULT_BUDGET, AwardsReplay
    from bimrobot.planning.learned_search import search as rollouts

    started, cpu = time.perf_counter(), time.process_time()
    found = rollouts(problem, None, DEFAULT_BUDGET if search is None else search)
    awards = found.awards  # recorded by the episode that found the schedule
    stats.solve_s += time.perf_counter() - started
    stats.solve_cpu_s += time.process_time() - cpu
    stats.notes.update(found.notes())
    return AwardsReplay(awards)


_REGISTRY: dict[str, Planner] = {
    "market": Planner("market", "the thesis' market, least-cost (simulate's default)", _market("least-cost")),
    "market:quickest-finish": Planner("market:quickest-finish", "the market, quickest-finish", _market("quickest-finish")),
    **{f"rule:{r}": Planner(f"rule:{r}", f"priority rule: {r.replace('-', ' ')}", _rule(r)) for r in RULES},
    "portfolio": Planner("portfolio", "the shortest of the market's and the rules' schedules", _portfolio),
    "rollout": Planner("rollout", "the portfolio's best improved by rollouts of the advisers' choices", _rollout),
    "cp-sat": Planner("cp-sat", "CP-SAT's schedule replayed (per joint)", _cpsat),
    "learned": Planner("learned", "the learned policy shipped with bimrobot, with decision-time search", _learned(None)),
    "learned:greedy": Planner("learned:greedy", "the shipped learned policy alone, guarded by the market",
                              _learned(None, greedy=True)),
}


def planner_for(name: str) -> Planner:
    """The planner called ``name`` (:data:`PLANNERS`, or a policy file ``PATH.zip``); one sentence
    (InputError) listing the choices otherwise."""
    if name in _REGISTRY:
        return _REGISTRY[name]
    if name.endswith(".zip"):
        return Planner(name, f"learned policy {name}", _learned(name))
    raise InputError(f"unknown planner {name!r}: choose one of {', '.join(PLANNERS)} or a policy file PATH.zip")


def dispatcher_for(name: str, problem, stats: PlanStats | None = None, **options) -> Dispatcher:
    """The dispatcher that carries out planner ``name``'s plan of ``problem`` (a ``DispatchProblem``),
    timed into ``stats``. ``options``: the planner's own (CP-SAT: ``time_limit_s``, ``deterministic_s``,
    ``workers``; ``learned``, ``PATH.zip`` and ``rollout``: ``search``, the rollouts)."""
    stats = stats if stats is not None else PlanStats()
    return Timed(planner_for(name).make(problem, stats, **options), stats)


def plan(name: str, problem, **options):
    """Plan ``problem`` with planner ``name`` and execute the plan on the event simulation: returns
    (``SimulationResult``, :class:`PlanStats`)."""
    from bimrobot.coordination.simulation import simulate

    stats = PlanStats()
    dispatcher = dispatcher_for(name, problem, stats, **options)
    result = simulate(problem.smart, problem.fleet, problem.site, "least-cost", 0, problem.breakdowns,
                      problem.storey_elevations, per_node=problem.per_node, dispatcher=dispatcher)
    return result, stats


def check_planner(name: str, per_node: bool, breakdowns=()) -> Planner:
    """Refuse, in one sentence and before any work, a planner that cannot plan this run."""
    planner = planner_for(name)
    if name == "cp-sat" and per_node:
        raise InputError("--planner cp-sat plans per joint (CP-SAT's tasks): add --per-joint")
    if name == "cp-sat" and breakdowns:
        raise InputError("--planner cp-sat plans without breakdowns: leave out --breakdown")
    if name.endswith(".zip") and not Path(name).is_file():
        raise InputError(f"--planner {name}: no such policy file")
    return planner


def plan_record(name: str, result, stats: PlanStats) -> str:
    """``plan.json`` (``simulate --planner``): which planner made the plan, what planning cost (wall
    seconds, so it varies run to run) and, for CP-SAT, its own objective and bound against the executed
    makespan (s)."""
    import json

    from bimrobot.core.io import signature

    record = {"bimrobot": signature("plan record"), "planner": name, "makespan_s": round(result.makespan, 3),
              "decisions": stats.decisions, "planning_s": round(stats.planning_s, 3), "solve_s": round(stats.solve_s, 3),
              "ms_per_decision": None if stats.ms_per_decision is None else round(stats.ms_per_decision, 3)}
    for key, value in stats.notes.items():
        if key == "replay":
            record.update(reordered=value.reordered, unplanned=value.unplanned)
        else:
            record[key] = round(value, 3) if isinstance(value, float) else value
    return json.dumps(record, indent=2, sort_keys=True) + "\n"


def plan_line(result, stats: PlanStats) -> str:
    """One line for the terminal: planning time, decisions, and CP-SAT's objective against the run."""
    text = f"planned by {result.evaluator}: {stats.planning_s:.2f} s planning, {stats.decisions} decisions"
    notes = stats.notes
    if "portfolio_chosen" in notes:
        text += f"; portfolio: {notes['portfolio_chosen']} was shortest of {len(notes['portfolio_makespans_s'])}"
    if "search_rollouts" in notes:
        greedy = "" if notes.get("policy_greedy_s") is None else f"policy alone {notes['policy_greedy_s']:.1f} s, "
        text += (f"; search: {greedy}portfolio {notes['portfolio_s']:.1f} s ({notes['portfolio_member']}), "
                 f"{notes['search_rollouts']} of {notes['search_budget']} rollouts, planned {notes['planned_s']:.1f} s")
    if "cpsat_makespan_s" in notes:
        text += (f"; CP-SAT's own objective {notes['cpsat_makespan_s']:.1f} s ({notes['cpsat_status']}, lower bound "
                 f"{notes['cpsat_lower_bound_s']:.1f} s; started from {notes['cpsat_hint']}'s "
                 f"{notes['cpsat_hint_s']:.1f} s), executed {result.makespan:.1f} s")
    return text
