"""Decision-time search for the learned planner (issue 38): the policy proposes, rollouts decide.

A fortified rollout (as the pilot teacher of :mod:`bimrobot.planning.learned_advice`, with its
:class:`~bimrobot.planning.learned_advice.Rollouts`):

1. the incumbent is the shortest of the portfolio's schedules (the least-cost and quickest-finish
   markets and the five priority rules, :data:`~bimrobot.planning.rules.PORTFOLIO`, each a whole
   episode of the event simulation) and of the policy's own greedy schedule;
2. the build follows the incumbent; at each decision with more than one valid action, the candidates
   are the policy's ``top_k`` valid actions (by logit; the greedy one first) and the advisers' first
   choices. From each candidate that is not the incumbent's next action, the build is completed by the
   base planners (the least-cost market and the portfolio's best member on this problem); a shorter
   complete schedule becomes the incumbent;
3. a second pass runs from the new incumbent if rollouts are left.

The result is never longer than the incumbent it started from, so never longer than the portfolio's
schedule nor the market's, by construction. The search is bounded by rollouts (``budget`` in all,
``cap`` per decision), never by wall time, and deterministic. The rollouts are spread over the
build: each decision earns ``budget / decisions`` of credit, spent where there is a choice.

``policy`` None is the ablation: the same search on the advisers' first choices only, starting from
the portfolio alone (no learned part). Times in seconds.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field

from bimrobot.coordination.market import Award, Dispatcher, MarketDispatcher, make_evaluator, propose
from bimrobot.core.errors import BimrobotError
from bimrobot.planning.dispatch import DispatchEnv, DispatchProblem, request_key
from bimrobot.planning.learned_advice import (RolloutEnv, Rollouts, advice_sparse, complete_build, completer,
                                              first_choices)
from bimrobot.planning.learned_pool import sizes
from bimrobot.planning.rules import PORTFOLIO

#: rollouts for ``--planner learned`` (each one a whole episode of the event simulation)
DEFAULT_BUDGET = 400
#: simulated decisions the search may spend in all, each whole episode counted as the building's task-graph
#: nodes (about its decisions): the portfolio's members after the market, then the rollouts, while it lasts.
#: Every shared real model per joint (at most 344 nodes) keeps the whole portfolio and 400 rollouts; a
#: 1,000-component building (7,302 nodes) about 20 rollouts; a 10,000-component one (75,100) the market and
#: the policy only
DECISION_BUDGET = 200_000
#: the policy's candidates per decision (its best valid actions by logit)
TOP_K = 3
#: the most rollouts spent at one decision
CAP = 12
#: passes over the build (the second from the incumbent the first one found)
PASSES = 2


@dataclass
class SearchResult:
    """The search's schedule (``actions`` of the environment, ``makespan_s``) and what it cost and found."""

    makespan_s: float
    actions: list[int]
    budget: int
    rollouts: int
    passes: int
    policy_s: float | None
    portfolio_s: float
    portfolio_chosen: str
    market_s: float
    members_s: dict = field(default_factory=dict)
    started_from: str = ""
    awards: list = field(default_factory=list)  # (time s, task key, robot) of the schedule's awards, in order

    def notes(self) -> dict:
        """What ``plan.json`` records (s; rounded)."""
        return {"search_budget": self.budget, "search_rollouts": self.rollouts, "search_passes": self.passes,
                "policy_greedy_s": None if self.policy_s is None else round(self.policy_s, 3),
                "portfolio_s": round(self.portfolio_s, 3), "portfolio_member": self.portfolio_chosen,
                "market_s": round(self.market_s, 3), "search_started_from": self.started_from,
                "planned_s": round(self.makespan_s, 3), "planned_decisions": len(self.actions),
                "search_members": list(self.members_s)}


def search(problem: DispatchProblem, policy=None, budget: int = DEFAULT_BUDGET, top_k: int = TOP_K, cap: int = CAP,
           passes: int = PASSES, env: DispatchEnv | None = None, decisions: int = DECISION_BUDGET) -> SearchResult:
    """The fortified rollout of the module docstring on ``problem``. ``policy``: a
    :class:`~bimrobot.planning.learned.LearnedPolicy` playing on ``env`` (the problem's environment with
    observations, padded to its own size), or None for the advisers' choices only. ``decisions``: the
    simulated decisions it may spend (:data:`DECISION_BUDGET`): the market's episode and the policy's are
    always played; each further portfolio member and each rollout costs one episode (the padded nodes)."""
    if env is None:
        pad = sizes(problem)
        env = DispatchEnv(problem, max_tasks=pad[0], max_robots=pad[1], max_edges=max(pad[2], 1), copy_observation=False)
    sandbox = RolloutEnv(problem, max_tasks=env.max_tasks, max_robots=env.max_robots, max_edges=env.max_edges)
    episodes = decisions // max(1, env.max_tasks) - 1 - (policy is not None)  # left after the market and the policy
    played = PORTFOLIO[: 1 + max(0, min(len(PORTFOLIO) - 1, episodes))]  # the market first
    budget = max(0, min(budget, episodes - (len(played) - 1)))
    if policy is not None and len(played) == 1 and budget == 0:  # the market and the policy only: see _market_or_policy
        return _market_or_policy(problem, policy, env, sandbox)
    members = {name: complete_build(sandbox, [], completer(name)) for name in played}
    chosen = min(played, key=lambda name: members[name][0])  # the first of equals
    best, started = members[chosen], chosen
    policy_s = None
    if policy is not None:
        greedy = complete_build(env, [], policy)
        policy_s = greedy[0]
        if greedy[0] < best[0] - 1e-9:
            best, started = greedy, "policy"
    rollouts = Rollouts(sandbox, best, completers=dict.fromkeys(("market", chosen)), budget=budget)
    done = 0
    while done < passes and rollouts.left >= 1:
        done += 1
        if not _pass(env, rollouts, policy, top_k, cap):
            break
    return SearchResult(rollouts.best[0], rollouts.best[1], budget, rollouts.used, done, policy_s, members[chosen][0],
                        chosen, members["market"][0], {k: v[0] for k, v in members.items()}, started, rollouts.best[2])


def _market_or_policy(problem: DispatchProblem, policy, env: DispatchEnv, sandbox: DispatchEnv) -> SearchResult:
    """:func:`search` where its budget plays the market and the policy only (the largest buildings): the
    shorter of the two schedules. The market's makespan comes from ``simulate``'s own run of the market
    (the environment's market episode gives the same schedule, docs/planning.md "Exactness"), in a forked
    process while this one plays the policy's episode; the market's episode is played in the sandbox,
    for its actions and awards, only where its schedule is the shorter (the policy's is taken only where
    it is shorter, as in :func:`search`). Same result as :func:`search`'s general path. Where the forked
    process dies without a result, the market's makespan is computed here after the policy's episode."""
    forked = _fork(_market_makespan, problem)
    market_s = None
    try:
        greedy = complete_build(env, [], policy)
        if forked is not None:
            with contextlib.suppress(_Died):
                market_s = forked.outcome(_Died)
    finally:
        if forked is not None:
            forked.stop()
    market_s = _market_makespan(problem) if market_s is None else market_s
    if greedy[0] < market_s - 1e-9:
        best, started = greedy, "policy"
    else:
        best, started = complete_build(sandbox, [], completer("market")), "market"
        if abs(best[0] - market_s) > 1e-6 and best[0] < float("inf"):
            raise BimrobotError(f"the market's episode took {best[0]:.3f} s, simulate's run {market_s:.3f} s: they must agree")
    return SearchResult(best[0], best[1], 0, 0, 0, greedy[0], market_s, "market", market_s, {"market": market_s}, started,
                        best[2])


class _Died(Exception):
    """The forked process ended without sending a result (its exit code)."""


def _market_makespan(problem: DispatchProblem) -> float:
    """The least-cost market's makespan (s) on ``problem``: ``simulate``'s run; inf where it stalls."""
    from bimrobot.coordination.simulation import simulate

    try:
        return float(simulate(problem.smart, problem.fleet, problem.site, "least-cost", 0, problem.breakdowns,
                              problem.storey_elevations, per_node=problem.per_node).makespan)
    except BimrobotError:
        return float("inf")


def _fork(function, *args):
    """``function(*args)`` in a forked process (:class:`~bimrobot.core.forked.Forked`), or None where
    forking is unsafe (:func:`bimrobot.core.cores.can_fork`; the caller then calls it here)."""
    from bimrobot.core.cores import can_fork
    from bimrobot.core.forked import Forked

    return Forked(function, args) if can_fork() else None


def _pass(env: DispatchEnv, rollouts: Rollouts, policy, top_k: int, cap: int) -> int:
    """One pass along the incumbent, its budget's rest spread over its decisions: the rollouts run."""
    env.reset(seed=0)
    share = rollouts.left / max(1, len(rollouts.best[1]))
    taken, credit, spent, done, truncated = [], 0.0, 0, False, False
    while not (done or truncated):
        credit = min(credit + share, float(cap))
        if credit >= 1 and len(env.valid_actions()) > 1:
            following = rollouts.next_action(taken)
            choices = [a for a in candidates(env, policy, top_k) if a != following]
            ran = rollouts.explore(taken, choices, int(credit)) if choices else 0
            credit, spent = credit - ran, spent + ran
        action = rollouts.next_action(taken)
        taken.append(action)
        _, _, done, truncated, _ = env.step(action)
    return spent


def candidates(env: DispatchEnv, policy, top_k: int = TOP_K) -> list[int]:
    """The actions worth a rollout now, each once: the policy's best valid action, the advisers' first
    choices (an award, or waiting where that is valid), then the policy's next ``top_k - 1``."""
    awarded, wait, order = advice_sparse(env)
    advisers = first_choices(env, awarded, wait)
    if policy is None:
        return advisers
    ranked = policy.ranked(env, (awarded, wait, order))[:top_k]
    return list(dict.fromkeys([*ranked[:1], *advisers, *ranked[1:]]))


def awards_of(problem: DispatchProblem, actions: list[int]) -> tuple[list[tuple[float, str, str]], object]:
    """The awards (time s, task key, robot) of an action sequence played on ``problem`` from its start,
    and the simulation result: what :class:`~bimrobot.planning.learned.ReplayDispatcher` replays."""
    n, r, e = sizes(problem)
    env = RolloutEnv(problem, max_tasks=n, max_robots=r, max_edges=max(e, 1))
    env.reset(seed=0)
    awards = []
    for action in actions:
        if action != env.wait_action and env._valid(action):
            node, robot = divmod(action, env.max_robots)
            awards.append((float(env.sim.build.env.now), env.graph.keys[node], env.robot_names[robot]))
        env.step(action)
    return awards, env.result


class AwardsReplay(Dispatcher):
    """Recorded awards (time s, task key, robot) given back to ``simulate``'s event simulation: at each
    allocation round, those recorded at the current time whose task is pending and robot idle, in their
    order. Should the run ever leave the recording (nothing to replay while no robot works), the
    least-cost market decides that round (counted in ``fallbacks``)."""

    name = "rollout"

    def __init__(self, awards: list[tuple[float, str, str]]):
        self.remaining = list(awards)
        self.market = MarketDispatcher(make_evaluator("least-cost", 0))
        self.fallbacks = 0

    def awards(self, sim) -> list[Award]:
        now = sim.build.env.now
        ready = {request_key(sim, r): r for pool in sim.build.pending.values() for r in pool}
        chosen, used, keep = [], set(), []
        for entry in self.remaining:
            at, key, name = entry
            request = ready.get(key)
            if abs(at - now) < 1e-9 and request is not None and name not in used and name in sim.build.idle[request.activity]:
                robot = sim.build.robots[name]
                chosen.append(Award(request, name, propose(robot.spec, sim.position_now(robot), now, True, request), 1))
                used.add(name)
                del ready[key]
            else:
                keep.append(entry)
        self.remaining = keep
        if not chosen and not any(r.task is not None for r in sim.build.robots.values()):
            chosen = self.market.awards(sim)
            self.fallbacks += bool(chosen)
        return chosen


def search_teacher(pool, pad: tuple[int, int, int], budget: int = DEFAULT_BUDGET, observation: str = "full"):
    """The search without a policy (``rollout``) as a teacher: on each training building, padded to
    ``pad``, its schedule's decisions as demonstrations ((observations stacked per key, masks, actions),
    as :func:`~bimrobot.planning.learned_pool.pilot_teacher`; advised with the full observation, not
    with the local one), and {spec: its makespan (s)}."""
    from bimrobot.planning.learned_advice import kept, observe
    from bimrobot.planning.learned_pool import _stack

    observations, masks, actions, makespans = [], [], [], {}
    for entry in pool:
        env = DispatchEnv(entry.problem, max_tasks=pad[0], max_robots=pad[1], max_edges=pad[2], observation=observation)
        found = search(entry.problem, None, budget, env=env)
        env.reset(seed=0)
        for action in found.actions:
            observations.append(kept(observe(env, observation == "full")))
            masks.append(env.action_masks())
            actions.append(action)
            env.step(action)
        assert env.result is not None and abs(env.result.makespan - found.makespan_s) < 1e-6
        makespans[entry.spec] = round(found.makespan_s, 3)
    return _stack(observations, masks, actions), makespans
