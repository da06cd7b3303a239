"""What the learned planner's advised policy sees besides the environment, and its teacher (issue 38).

The advice (:func:`advice`): at each decision the next awards of the market and of the priority rules
(:data:`ADVISERS`, pair and wait features) and each ready task's place in the market's request heap
(:data:`EXTRA_NODE_FEATURES`). The pilot (:func:`pilot_demonstrations`): a rollout of the least-cost
market that tries the advisers' first choices wherever they disagree and keeps the shortest schedule
found, so it is never longer than the market.

Times in seconds, positions in metres (site frame x, y; model frame z, z up), masses in kg.
"""

from __future__ import annotations

import weakref

import gymnasium as gym
import numpy as np

from bimrobot.coordination.market import Dispatcher
from bimrobot.planning.dispatch import DispatchEnv, DispatchProblem, MarketPolicy

#: the planners (``bimrobot.planning.planners`` names) whose awards at the current decision the advised
#: policy sees, as pair features (1 for each one's first award, 0.5 for its later awards of the round) and
#: wait features (1 where it would award nothing now)
ADVISERS = ("market", "market:quickest-finish", "rule:most-successors", "rule:longest-path", "rule:nearest",
            "rule:shortest-handling")
#: node features the advised policy adds to ``NODE_FEATURES``: a ready task's place in its activity's
#: request heap (1 = the market's next, 2 = the one after, ...; 0 = not ready): the market's order within a kind
EXTRA_NODE_FEATURES = ("order_in_kind",)
_ADVICE: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _adviser(name: str) -> Dispatcher:
    from bimrobot.coordination.market import MarketDispatcher, make_evaluator
    from bimrobot.planning.rules import RuleDispatcher

    if name.startswith("rule:"):
        return RuleDispatcher(name.split(":", 1)[1])
    return MarketDispatcher(make_evaluator(name.split(":", 1)[1] if ":" in name else "least-cost", 0))


def advice(env: DispatchEnv) -> dict:
    """The advised policy's extra arrays at ``env``'s current decision (read-only on the simulation):
    ``advice`` (max_tasks, max_robots, advisers), ``advice_wait`` (advisers,), ``order_in_kind`` (max_tasks,)."""
    env = env.unwrapped
    return dense_advice(env, *advice_sparse(env))


def dense_advice(env: DispatchEnv, awarded: dict, wait: np.ndarray, order: np.ndarray) -> dict:
    """:func:`advice`'s arrays from :func:`advice_sparse`'s result."""
    pairs = np.zeros((env.max_tasks, env.max_robots, len(ADVISERS)), np.float32)
    for (node, robot), values in awarded.items():
        pairs[node, robot] = values
    return {"advice": pairs, "advice_wait": wait, "order_in_kind": order}


def advice_sparse(env: DispatchEnv) -> tuple[dict, np.ndarray, np.ndarray]:
    """:func:`advice` without the dense pair array: ({(node, robot): the advisers' values (advisers,)} of
    the pairs some adviser awards now, ``advice_wait``, ``order_in_kind``)."""
    env = env.unwrapped
    mine = _ADVICE.setdefault(env, {})
    awarded: dict = {}
    wait = np.zeros(len(ADVISERS), np.float32)
    order = np.zeros(env.max_tasks, np.float32)
    if env.sim is None:
        return awarded, wait, order
    if mine.get("sim") is not env.sim:  # a new episode: new advisers (the rules keep per-build scores)
        mine.update(sim=env.sim, dispatchers=[_adviser(name) for name in ADVISERS])
    for k, dispatcher in enumerate(mine["dispatchers"]):
        awards = dispatcher.awards(env.sim) or []
        wait[k] = not awards
        for rank, award in enumerate(awards):
            pair = divmod(env.action_of(award.request, award.robot), env.max_robots)
            awarded.setdefault(pair, np.zeros(len(ADVISERS), np.float32))[k] = 1.0 if rank == 0 else 0.5
    for pool in env.sim.build.pending.values():
        for rank, request in enumerate(sorted(pool)):  # the heap's order: the request's priority
            order[env._node_of(request)] = rank + 1
    return awarded, wait, order


def advised_space(env: DispatchEnv) -> gym.spaces.Dict:
    """``env``'s observation space with the :func:`advice` arrays."""
    env = env.unwrapped
    h = len(ADVISERS)
    return gym.spaces.Dict({
        **env.observation_space.spaces,
        "advice": gym.spaces.Box(0.0, 1.0, (env.max_tasks, env.max_robots, h), np.float32),
        "advice_wait": gym.spaces.Box(0.0, 1.0, (h,), np.float32),
        "order_in_kind": gym.spaces.Box(0.0, float(env.max_tasks), (env.max_tasks,), np.float32),
    })


def observe(env: gym.Env, advised: bool = True) -> dict:
    """The observation at ``env``'s current decision, with the :func:`advice` arrays when ``advised``. The
    environment's arrays are read-only views, valid until its next step: :func:`kept` copies them."""
    env = env.unwrapped
    obs = dict(env._observation())
    return {**obs, **advice(env)} if advised else obs


def kept(obs: dict) -> dict:
    """A copy of an observation from :func:`observe`, to keep beyond the environment's next step."""
    return {k: v.copy() for k, v in obs.items()}


class Advised(gym.ObservationWrapper):
    """``env`` whose observations carry the :func:`advice` arrays (for PPO on the advised policy)."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        self.observation_space = advised_space(env)

    def observation(self, observation: dict) -> dict:
        return {**observation, **advice(self.env.unwrapped)}

    def action_masks(self) -> np.ndarray:
        return self.env.unwrapped.action_masks()


# ---------------------------------------------------------------- the pilot: a better teacher than the market
class RolloutEnv(DispatchEnv):
    """The environment without observations, for rollouts (the pilot's and the search's; the same
    simulation, about 1.6 x faster): only actions, masks and the result are read from it."""

    def _observation(self) -> dict:
        return {}


def complete_build(env: DispatchEnv, prefix: list[int], completer=None) -> tuple[float, list[int], list]:
    """Replay ``prefix`` on ``env`` from its start, then let ``completer`` (a policy ``policy(env) ->
    action``; None: the least-cost market) finish the build: (makespan s, every action, the awards
    (time s, task key, robot) made, as ``env.awarded``)."""
    obs, _ = env.reset(seed=0)
    done = truncated = False
    for action in prefix:
        _, _, done, truncated, _ = env.step(action)
    actions, completer = list(prefix), completer if completer is not None else MarketPolicy()
    while not (done or truncated):
        action = completer(env)
        actions.append(action)
        _, _, done, truncated, _ = env.step(action)
    return (float(env.result.makespan) if env.result is not None else float("inf")), actions, list(env.awarded)


class PlannerPolicy:
    """A planner of :data:`ADVISERS` (a ``bimrobot.planning.planners`` name) as a policy of
    :class:`DispatchEnv`, as :class:`MarketPolicy` is for the market: at each allocation round it plays
    the awards the planner's dispatcher makes, in its order, then waits. A fresh dispatcher per episode
    (the rules keep per-build scores). ``make``: the dispatcher of a new episode, where it is not the
    adviser's (CP-SAT's replay of one plan, :func:`~bimrobot.planning.learned_train.cpsat_teacher`)."""

    def __init__(self, name: str, make=None):
        self.name = name
        self._make = make or (lambda: _adviser(name))
        self._sim = self._round = None
        self._plan: list = []

    def __call__(self, env: gym.Env) -> int:
        env = env.unwrapped
        if self._sim is not env.sim:
            self._sim, self._dispatcher, self._round = env.sim, self._make(), None
        if self._round != env.round_id:
            self._round, self._plan = env.round_id, list(self._dispatcher.awards(env.sim) or [])[::-1]
        if self._plan:
            award = self._plan.pop()
            return env.action_of(award.request, award.robot)
        return env.wait_action


def completer(name: str):
    """A fresh policy that plays planner ``name`` (:data:`ADVISERS`): the market's own policy for
    ``market`` (``simulate``'s run exactly), :class:`PlannerPolicy` otherwise."""
    return MarketPolicy() if name == "market" else PlannerPolicy(name)


class Rollouts:
    """The incumbent of a fortified rollout and the rollouts that may replace it.

    ``best`` is the shortest complete schedule found so far, (makespan s, every action, its awards); a search
    follows it. :meth:`explore` completes the build from ``taken + [candidate]`` with each of the
    ``completers`` (planner names of :data:`ADVISERS`) on ``sandbox`` (the event simulation replayed
    from its start) and keeps any shorter schedule. ``budget`` bounds the rollouts run (None: no bound);
    ``used`` counts them; a prefix already completed by the same planner is not run again."""

    def __init__(self, sandbox: DispatchEnv, best: tuple[float, list[int]], completers=("market",), budget: int | None = None):
        self.sandbox, self.best = sandbox, best
        self.completers, self.budget = tuple(completers), budget
        self.used = 0
        self._seen: set = set()

    @property
    def left(self) -> float:
        return float("inf") if self.budget is None else self.budget - self.used

    def complete(self, prefix: list[int], name: str = "market") -> tuple[float, list[int], list] | None:
        """One rollout (counted), the incumbent updated; None when the budget is spent or it ran before."""
        key = (name, tuple(prefix))
        if self.left < 1 or key in self._seen:
            return None
        self._seen.add(key)
        self.used += 1
        found = complete_build(self.sandbox, prefix, completer(name))
        if found[0] < self.best[0] - 1e-9:
            self.best = found
        return found

    def explore(self, taken: list[int], candidates, limit: float = float("inf")) -> int:
        """Complete the build from each candidate next action (in order) with each completer, at most
        ``limit`` rollouts: returns those run."""
        before = self.used
        for action in candidates:
            for name in self.completers:
                if self.used - before >= limit:
                    return self.used - before
                self.complete(taken + [action], name)
        return self.used - before

    def next_action(self, taken: list[int]) -> int:
        """The incumbent's action after ``taken`` (a prefix of it)."""
        return self.best[1][len(taken)]


def first_choices(env: DispatchEnv, awarded: dict, wait) -> list[int]:
    """The advisers' first choices now, from :func:`advice_sparse`'s ``awarded`` and ``wait`` (an award,
    or waiting where that is valid), in :data:`ADVISERS`' order, each once."""
    chosen = []
    firsts = {k: pair for pair, values in awarded.items() for k, v in enumerate(values) if v == 1.0}
    for k in range(len(ADVISERS)):
        if wait[k]:
            action = env.wait_action if env.sim.can_wait() else None
        else:
            node, robot = firsts[k]
            action = int(node) * env.max_robots + int(robot)
        if action is not None and action not in chosen:
            chosen.append(action)
    return chosen


def pilot_demonstrations(problem: DispatchProblem, pad: tuple[int, int, int]) -> tuple[list, list, list, float, float]:
    """The pilot method (a fortified rollout of the least-cost market) on ``problem``: at each decision
    where the :data:`ADVISERS` disagree, each of their first choices is tried and the market finishes the
    build from there; the build follows the shortest complete schedule found so far, so its makespan is
    never longer than the market's. Returns the advised observations, action masks and actions along that
    schedule, its makespan and the market's (s)."""
    env = DispatchEnv(problem, max_tasks=pad[0], max_robots=pad[1], max_edges=pad[2])
    sandbox = RolloutEnv(problem, max_tasks=pad[0], max_robots=pad[1], max_edges=pad[2])
    rollouts = Rollouts(sandbox, complete_build(sandbox, []))
    market_s = rollouts.best[0]
    env.reset(seed=0)
    observations, masks, taken = [], [], []
    done = truncated = False
    while not (done or truncated):
        awarded, wait, order = advice_sparse(env)  # once: the observation's arrays and the choices
        obs = {**env._observation(), **dense_advice(env, awarded, wait, order)}
        choices = first_choices(env, awarded, wait)
        if len(choices) > 1:
            rollouts.explore(taken, choices)
        action = rollouts.next_action(taken)
        observations.append(kept(obs))
        masks.append(env.action_masks())
        taken.append(action)
        _, _, done, truncated, _ = env.step(action)
    return observations, masks, taken, float(env.result.makespan), market_s
