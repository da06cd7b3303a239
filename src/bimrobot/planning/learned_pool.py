"""The buildings the learned planner trains on and the demonstrations it imitates (issue 38): generated
buildings only (real IFC models are the test set), each with its own fleet and site and the least-cost
market's makespan; one training environment drawing them, reward in per cent of the market's makespan;
the decisions of the market or of the pilot on them, stacked.

Times in seconds.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np

from bimrobot.planning.dispatch import DispatchEnv, DispatchProblem, MarketPolicy, play
from bimrobot.planning.learned_advice import Advised, kept, observe, pilot_demonstrations

# ---------------------------------------------------------------- buildings for training
#: the generated buildings of the training pool: (kind, grid) drawn with the run's seed
TRAIN_SPECS = (("steel", "2x2x2"), ("steel", "3x2x1"), ("steel", "2x3x2"), ("steel", "3x3x1"),
               ("precast", "2x2x2"), ("precast", "3x2x1"), ("panel", "2x2x1"), ("panel", "3x2x1"))


@dataclass
class PoolEntry:
    """One training building: its spec, problem and the least-cost market's makespan on it (s)."""

    spec: str
    problem: DispatchProblem
    market_s: float


def generated_problem(spec: str, per_joint: bool = False) -> DispatchProblem:
    """The problem of a generated building (``generated:KIND:GRID:seed=S``) with its own random fleet and
    site (:mod:`bimrobot.site.generated`), as ``simulate`` reads it (``per_joint``: with ``--per-joint``)."""
    from bimrobot.site.fleet import fleet_yaml
    from bimrobot.planning.dispatch import simulate_problem
    from bimrobot.site.generated import generate, parse_spec
    from bimrobot.site.site import site_yaml

    parsed = parse_spec(spec)
    with tempfile.TemporaryDirectory(prefix="bimrobot-train-") as folder:
        made = generate(parsed, Path(folder) / "building.ifc")
        (Path(folder) / "fleet.yaml").write_text(fleet_yaml(made.fleet, parsed.text()), encoding="utf-8")
        (Path(folder) / "site.yaml").write_text(site_yaml(made.site, parsed.text()), encoding="utf-8")
        return simulate_problem([str(made.path), "--fleet", str(Path(folder) / "fleet.yaml"),
                                 "--site", str(Path(folder) / "site.yaml"), *(["--per-joint"] if per_joint else [])])


def sizes(problem: DispatchProblem) -> tuple[int, int, int]:
    """(tasks + gates, robots, precedences) of ``problem``: its own padding."""
    from bimrobot.coordination.simulation import ConstructionSimulation
    from bimrobot.planning.dispatch import AgentDispatcher, problem_graph

    sim = ConstructionSimulation(problem.smart, problem.fleet, problem.site, breakdowns=problem.breakdowns,
                                 storey_elevations=problem.storey_elevations, per_node=problem.per_node,
                                 dispatcher=AgentDispatcher())
    sim.start()
    graph = problem_graph(problem, sim)  # kept for the problem's environments
    return len(graph.keys), len(problem.fleet.robots), len(graph.edges)


def env_for(problem: DispatchProblem, copy_observation: bool = True, observation: str = "full") -> DispatchEnv:
    """The environment of ``problem`` padded to its own size (``copy_observation``, ``observation``: see
    :class:`DispatchEnv`)."""
    n, r, e = sizes(problem)
    return DispatchEnv(problem, max_tasks=n, max_robots=r, max_edges=max(e, 1), copy_observation=copy_observation,
                       observation=observation)


def training_pool(seed: int, specs=TRAIN_SPECS, per_joint: bool = False) -> list[PoolEntry]:
    """Generated buildings of ``specs``, each drawn with ``seed`` (and its index), with the market's makespan;
    per node (``simulate``'s default) or ``per_joint`` (CP-SAT's tasks)."""
    pool = []
    for i, (kind, grid) in enumerate(specs):
        spec = f"generated:{kind}:{grid}:seed={seed * 100 + i}"
        problem = generated_problem(spec, per_joint)
        _, result = play(env_for(problem), MarketPolicy(), seed=0)
        pool.append(PoolEntry(spec, problem, float(result.makespan)))
    return pool


class _Drawn:
    """The ``problem`` callable of a training environment: a building of the pool drawn at each reset."""

    def __init__(self, pool: list[PoolEntry]):
        self.pool, self.last = pool, 0

    def __call__(self, rng: np.random.Generator) -> DispatchProblem:
        self.last = int(rng.integers(len(self.pool)))
        return self.pool[self.last].problem


class PerCentOfMarket(gym.Wrapper):
    """Reward in per cent of the market's makespan on the drawn building (return = -100 x makespan / market)."""

    def __init__(self, env: DispatchEnv, drawn: _Drawn):
        super().__init__(env)
        self.drawn = drawn

    def step(self, action):
        obs, reward, done, truncated, info = self.env.step(action)
        return obs, 100.0 * reward / self.drawn.pool[self.drawn.last].market_s, done, truncated, info

    def action_masks(self) -> np.ndarray:
        return self.env.unwrapped.action_masks()


def _pad(pool: list[PoolEntry]) -> tuple[int, int, int]:
    n, r, e = zip(*(sizes(p.problem) for p in pool))
    return max(n), max(r), max(e)


def make_training_env(pool: list[PoolEntry], seed: int, advised: bool = True, observation: str = "full") -> gym.Env:
    """One environment drawing the pool's buildings, padded to the largest of them, reward per cent of
    market; with the :func:`advice` arrays in its observations when ``advised``."""
    n, r, e = _pad(pool)
    drawn = _Drawn(pool)
    inner = DispatchEnv(drawn, max_tasks=n, max_robots=r, max_edges=e, observation=observation)
    env = PerCentOfMarket(Advised(inner) if advised else inner, drawn)
    env.reset(seed=seed)
    return env


# ---------------------------------------------------------------- imitation of the market
def market_demonstrations(pool: list[PoolEntry], pad: tuple[int, int, int], advised: bool = False,
                          observation: str = "full") -> tuple[dict, np.ndarray, np.ndarray]:
    """Every decision of the least-cost market on the pool's buildings, padded to ``pad``:
    (observations stacked per key, action masks (D, A), the market's actions (D,))."""
    observations, masks, actions = [], [], []
    for entry in pool:
        env = DispatchEnv(entry.problem, max_tasks=pad[0], max_robots=pad[1], max_edges=pad[2], observation=observation)
        play_demonstrations(env, MarketPolicy(), advised, observations, masks, actions)
    return _stack(observations, masks, actions)


def play_demonstrations(env: DispatchEnv, policy, advised: bool, observations: list, masks: list, actions: list) -> None:
    """One episode of ``policy`` (``policy(env) -> action``) on ``env`` from ``reset(seed=0)``: each
    decision's observation (with the advice where ``advised``), action mask and action, appended."""
    env.reset(seed=0)
    done = truncated = False
    while not (done or truncated):
        observations.append(kept(observe(env, advised)))
        actions.append(policy(env))
        masks.append(env.action_masks())
        _, _, done, truncated, _ = env.step(actions[-1])


def pilot_teacher(pool: list[PoolEntry], pad: tuple[int, int, int]) -> tuple[tuple[dict, np.ndarray, np.ndarray], dict]:
    """The pilot's decisions (:func:`pilot_demonstrations`) on the pool's buildings, padded to ``pad``, as
    demonstrations, and {spec: the pilot's makespan (s)}."""
    observations, masks, actions, makespans = [], [], [], {}
    for entry in pool:
        obs, mask, taken, makespan, _ = pilot_demonstrations(entry.problem, pad)
        observations += obs
        masks += mask
        actions += taken
        makespans[entry.spec] = round(makespan, 3)
    return _stack(observations, masks, actions), makespans


def _stack(observations: list[dict], masks: list, actions: list) -> tuple[dict, np.ndarray, np.ndarray]:
    stacked = {k: np.stack([o[k] for o in observations]) for k in observations[0]}
    return stacked, np.stack(masks), np.array(actions, dtype=np.int64)


# ---------------------------------------------------------------- imitation: behaviour cloning of a teacher
def imitate(policy, demonstrations, steps: int, seed: int, batch: int = 32, lr: float = 1e-3) -> float:
    """Behaviour cloning: ``steps`` Adam steps of cross-entropy between the masked policy and the market's
    actions, mini-batches drawn with ``seed``. Returns the accuracy (0-1) of the greedy policy on them."""
    import torch as th

    obs, masks, actions = demonstrations
    rng = np.random.default_rng(seed)
    optimizer = th.optim.Adam(policy.parameters(), lr=lr)
    policy.set_training_mode(True)
    for _ in range(steps):
        pick = rng.integers(len(actions), size=min(batch, len(actions)))
        distribution = policy.get_distribution(_tensors(obs, pick), action_masks=masks[pick])
        loss = -distribution.log_prob(th.as_tensor(actions[pick])).mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    return imitation_accuracy(policy, demonstrations)


def imitation_accuracy(policy, demonstrations) -> float:
    """Share (0-1) of the demonstrations where the greedy masked policy picks the market's action."""
    import torch as th

    obs, masks, actions = demonstrations
    policy.set_training_mode(False)
    hits = 0
    with th.no_grad():
        for start in range(0, len(actions), 64):
            pick = np.arange(start, min(start + 64, len(actions)))
            chosen = policy.get_distribution(_tensors(obs, pick), action_masks=masks[pick]).get_actions(deterministic=True)
            hits += int((chosen.numpy() == actions[pick]).sum())
    return hits / max(len(actions), 1)


def _tensors(obs: dict, pick: np.ndarray) -> dict:
    import torch as th

    return {k: th.as_tensor(v[pick]).float() for k, v in obs.items()}
