"""Exact planner for the assembly environment: an optimal action sequence and its return for any state.

Why it is exact. The components are handled in a fixed order and a placed component never moves again, so
an episode is a sequence of independent path problems linked only by *which slot* each component fills:
that choice decides what stands (and blocks) later, and which slots stay eligible. For a fixed slot the
cost of a component is monotone in its number of steps (every step costs ``r0 / c`` or ``2 r0 / c``, the
placement pays a constant ``+k``), so its best path is a shortest path, found by breadth-first search over
the poses of its min corner with everything else standing still. Paths may not cross the pose of another
eligible free slot (arrival there is automatic). Dynamic programming over (component, set of filled
slots) then tries every slot assignment, i.e. it is an exhaustive search with memoisation: the plan it
returns is optimal among all action sequences that complete the structure.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bimrobot.assembly.env import MOVES, AssemblyEnv, AssemblyState
from bimrobot.assembly.scenario import SETTINGS, benchmark_scenario, lifted_pose, run_cells
from bimrobot.core.errors import BimrobotError, InputError

REFERENCE_FILE = Path(__file__).with_name("settings") / "reference_returns.json"
REFERENCE_EPISODES = 100


@dataclass
class Plan:
    """An optimal action sequence from a state, its return, and the slot each component fills."""

    actions: list[int]
    return_: float
    assignment: dict[str, str] = field(default_factory=dict)  # component id -> target id

    @property
    def steps(self) -> int:
        return len(self.actions)


class _Search:
    """Shortest paths and the dynamic programme over slot assignments for one episode state."""

    def __init__(self, state: AssemblyState, r0: float, epsilon: int, completion_bonus: float):
        cs = state.compiled
        self.cs, self.state = cs, state
        self.r0, self.epsilon, self.bonus = r0, epsilon, completion_bonus
        W, L, H = cs.W, cs.L, cs.H
        # padded occupancy (one cell of margin all round, blocked), so shifts need no bounds checks
        self.shape = (W + 2, L + 2, H + 2)
        base = np.ones(self.shape, bool)
        base[1:-1, 1:-1, 1:-1] = cs.static_blocked.reshape(W, L, H).astype(bool)
        for slot in state.prebuilt_slots:
            self._mark(base, cs.target_cells[slot])
        self.base = base
        self.waiting = [run_cells(*start) for start in state.starts]  # lying cells of each component
        self.n_prebuilt = len(state.prebuilt_slots)
        self._memo: dict[tuple[int, frozenset[int]], tuple[float, tuple[int, ...]]] = {}

    def _mark(self, occ: np.ndarray, flats) -> None:
        for f in flats:
            x, y, z = self.cs.unflat(f)
            occ[x + 1, y + 1, z + 1] = True

    def occupancy(self, i: int, filled: frozenset[int]) -> np.ndarray:
        """Blocked cells while component i moves: static, prebuilt, placed slots, later waiting ones."""
        occ = self.base.copy()
        prebuilt = set(self.state.prebuilt_slots)
        for t in filled:
            if t not in prebuilt:
                self._mark(occ, self.cs.target_cells[t])
        for j in range(i + 1, self.cs.n_comp):
            for x, y, z in self.waiting[j]:
                occ[x + 1, y + 1, z + 1] = True
        return occ

    def valid_poses(self, i: int, occ: np.ndarray) -> np.ndarray:
        """Padded bool grid: True where component i's min corner may be (all its cells free)."""
        free = ~occ
        n, axis = self.cs.comp_len[i], self.cs.comp_axis[i]
        valid = free.copy()
        for k in range(1, n):
            shifted = np.zeros_like(free)
            src = [slice(None)] * 3
            dst = [slice(None)] * 3
            src[axis] = slice(k, None)
            dst[axis] = slice(0, -k)
            shifted[tuple(dst)] = free[tuple(src)]
            valid &= shifted
        return valid

    def eligible(self, i: int, filled: frozenset[int]) -> dict[tuple[int, int, int], int]:
        """Padded min-corner cell -> target index, for the slots component i may fill now."""
        out = {}
        for corner_flat, t in self.cs.comp_arrival[i].items():
            if t in filled or any(s not in filled for s in self.cs.target_supports[t]):
                continue
            x, y, z = self.cs.unflat(corner_flat)
            out[(x + 1, y + 1, z + 1)] = t
        return out

    def start_pose(self, i: int, occ: np.ndarray, corner) -> tuple[int, int, int]:
        if corner is not None:
            return corner
        cs = self.cs

        class View:
            def __contains__(self, cell):
                return bool(occ[cell[0] + 1, cell[1] + 1, cell[2] + 1])

        comp = cs.scenario.handled[i]
        pose = lifted_pose(cs.scenario, comp, self.state.starts[i], View())
        if pose is None:
            raise InputError(f"{cs.scenario.source}: components.{comp.id}: the crane cannot lift it free of other objects")
        return pose[0]

    def distances(self, valid: np.ndarray, start, goals: dict) -> np.ndarray:
        """Breadth-first distances (int32, -1 unreached) from ``start``; goal poses are not expanded."""
        dist = np.full(self.shape, -1, np.int32)
        absorbing = np.zeros(self.shape, bool)
        for cell in goals:
            absorbing[cell] = True
        frontier = np.zeros(self.shape, bool)
        frontier[start] = True
        dist[start] = 0
        reached = frontier.copy()
        remaining = set(goals) - {start}
        d = 0
        while remaining and frontier.any():
            d += 1
            grown = np.zeros(self.shape, bool)
            grown[1:] |= frontier[:-1]
            grown[:-1] |= frontier[1:]
            grown[:, 1:] |= frontier[:, :-1]
            grown[:, :-1] |= frontier[:, 1:]
            grown[:, :, 1:] |= frontier[:, :, :-1]
            grown[:, :, :-1] |= frontier[:, :, 1:]
            new = grown & valid & ~reached
            dist[new] = d
            reached |= new
            frontier = new & ~absorbing
            remaining = {g for g in remaining if dist[g] < 0}
        if start in goals:  # arrival needs a move: step out to a free neighbour and back
            if any(dist[_shift(start, a)] == 1 and not absorbing[_shift(start, a)] for a in range(6)):
                dist[start] = 2
            else:
                dist[start] = -1
        return dist

    def component_cost(self, i: int, moves: int, steps_before: int) -> float:
        """Return of component i placed on its ``moves``-th step after ``steps_before`` steps on it."""
        c = i + 1
        first, last = steps_before + 1, steps_before + moves - 1  # the non-placing steps
        single = max(0, min(last, self.epsilon) - first + 1)
        double = max(0, last - max(first, self.epsilon + 1) + 1)
        k = self.n_prebuilt + i + 1
        cost = self.r0 / c * (single + 2 * double) + k
        if i == self.cs.n_comp - 1:
            cost += self.bonus
        return cost

    def best(self, i: int, filled: frozenset[int]) -> tuple[float, tuple[int, ...]]:
        """Best return from component i on (its pick-up) given the filled slots, and the slots chosen."""
        if i >= self.cs.n_comp:
            return 0.0, ()
        key = (i, filled)
        if key not in self._memo:
            self._memo[key] = self._best(i, filled)
        return self._memo[key]

    def _best(self, i: int, filled: frozenset[int]) -> tuple[float, tuple[int, ...]]:
        first = i == self.state.current
        corner = self.state.corner if first else None
        steps = self.state.steps if first else 0
        occ = self.occupancy(i, filled)
        valid = self.valid_poses(i, occ)
        start = tuple(v + 1 for v in self.start_pose(i, occ, corner))
        goals = self.eligible(i, filled)
        dist = self.distances(valid, start, goals)
        best_value, best_slots = -np.inf, ()
        for cell, t in goals.items():
            d = int(dist[cell])
            if d <= 0:
                continue
            rest_value, rest_slots = self.best(i + 1, filled | {t})
            value = self.component_cost(i, d, steps) + rest_value
            if value > best_value:
                best_value, best_slots = value, (t,) + rest_slots
        return best_value, best_slots

    def path(self, i: int, filled: frozenset[int], target: int) -> list[int]:
        """The actions of a shortest path of component i onto ``target`` (ties: lowest action first)."""
        first = i == self.state.current
        occ = self.occupancy(i, filled)
        valid = self.valid_poses(i, occ)
        start = tuple(v + 1 for v in self.start_pose(i, occ, self.state.corner if first else None))
        goals = self.eligible(i, filled)
        dist = self.distances(valid, start, goals)
        goal = next(cell for cell, t in goals.items() if t == target)
        if goal == start:
            for a in range(6):
                out = _shift(start, a)
                if dist[out] == 1 and out not in goals:
                    return [a, a ^ 2 if a < 4 else 9 - a]
        actions = []
        cell = goal
        while cell != start:
            d = dist[cell]
            for a in range(6):
                prev = _shift(cell, a, -1)
                if dist[prev] == d - 1 and (prev == start or prev not in goals):
                    actions.append(a)
                    cell = prev
                    break
            else:  # pragma: no cover - BFS invariant
                raise RuntimeError("broken shortest-path tree")
        return actions[::-1]


def _shift(cell, action: int, sign: int = 1):
    dx, dy, dz = MOVES[action]
    return cell[0] + sign * dx, cell[1] + sign * dy, cell[2] + sign * dz


def plan(env_or_state: AssemblyEnv | AssemblyState) -> Plan:
    """An optimal plan from the env's current state (call after ``reset``) or from a snapshot.

    ``return_`` is the sum of the rewards the env pays along ``actions`` (step costs, placements and the
    completion bonus). Raises BimrobotError when no action sequence can complete the structure.
    """
    if isinstance(env_or_state, AssemblyState):
        state = env_or_state
        r0, eps, bonus = (state.compiled.scenario.reward.r0, state.compiled.scenario.reward.epsilon,
                          state.compiled.scenario.reward.completion_bonus)
    else:
        env = getattr(env_or_state, "unwrapped", env_or_state)
        state = env.snapshot()
        r0, eps, bonus = env.r0, env.epsilon, env.completion_bonus
    cs = state.compiled
    if state.current >= cs.n_comp:
        return Plan([], 0.0)
    search = _Search(state, r0, eps, bonus)
    filled = frozenset(state.prebuilt_slots) | frozenset(t for _, t in state.placed)
    value, slots = search.best(state.current, filled)
    if not np.isfinite(value):
        comp = cs.scenario.handled[state.current].id
        raise BimrobotError(f"{cs.scenario.name}: no action sequence completes the structure from here (stuck at {comp})")
    actions: list[int] = []
    assignment = {}
    for offset, t in enumerate(slots):
        i = state.current + offset
        actions += search.path(i, filled, t)
        filled = filled | {t}
        assignment[cs.scenario.handled[i].id] = cs.scenario.targets[t].id
    return Plan(actions, float(value), assignment)


def planner_policy(env):
    """The planner as a policy, ``policy(obs, info) -> action`` (the signature of ``bimrobot.rl``'s
    ``load_policy``) for the given env. It plans again whenever the episode is not where its plan left
    it (a reset, or a step it did not choose), so it can also take over an episode half-way."""
    env = getattr(env, "unwrapped", env)
    queue: list[int] = []
    expected: list = [None]  # (episode's layout object, elapsed steps) after the last planned action

    def policy(obs, info) -> int:
        if not queue or expected[0] != (id(env._starts), env._elapsed):
            queue[:] = plan(env).actions
        action = queue.pop(0)
        expected[0] = (id(env._starts), env._elapsed + 1)
        return action

    return policy


def optimal_return(setting: str | None, seed: int | None = None, scenario=None) -> float:
    """The optimal return of a benchmark setting's (or a custom ``scenario``'s) reset with ``seed``."""
    env = AssemblyEnv(setting, scenario=scenario)
    env.reset(seed=seed)
    return plan(env).return_


def random_policy_returns(setting: str | None, episodes: int = REFERENCE_EPISODES, scenario=None) -> np.ndarray:
    """Returns of a uniformly random policy: episode e resets with seed e and draws actions from
    ``numpy.random.default_rng(e)``; the registered (or the custom ``scenario``'s) time limit applies."""
    from bimrobot.assembly.vector import BatchedAssemblySim

    sim = BatchedAssemblySim(setting, episodes, seed=None, scenario=scenario)
    sim.reset(seeds=list(range(episodes)))
    rngs = [np.random.default_rng(e) for e in range(episodes)]
    returns = np.zeros(episodes)
    done = np.zeros(episodes, bool)
    while not done.all():
        actions = np.array([rng.integers(6) for rng in rngs])
        _, rewards, terminated, truncated, _ = sim.step(actions, autoreset=False)
        returns += np.where(done, 0.0, rewards)
        done |= terminated | truncated
    return returns


def compute_reference_returns(setting: str | None, episodes: int = REFERENCE_EPISODES, scenario=None) -> dict[str, float]:
    """Optimal return (mean over ``episodes`` seeded resets when resets are random) and random-policy
    mean return (``episodes`` seeded episodes), with their standard errors, of a benchmark setting or
    of a custom ``scenario``."""
    custom = scenario
    scenario = custom if custom is not None else benchmark_scenario(setting)
    seeds = range(episodes) if scenario.is_stochastic else [0]
    optimal = np.array([optimal_return(setting, seed, custom) for seed in seeds])
    random = random_policy_returns(setting, episodes, custom)
    sem = lambda a: float(a.std(ddof=1) / np.sqrt(len(a))) if len(a) > 1 else 0.0  # noqa: E731
    return {
        "optimal": round(float(optimal.mean()), 4),
        "optimal_sem": round(sem(optimal), 4),
        "random": round(float(random.mean()), 4),
        "random_sem": round(sem(random), 4),
        "episodes": episodes,
    }


def reference_returns(setting: str) -> dict[str, float]:
    """``{"optimal": ..., "random": ...}`` of a benchmark setting, from the shipped table
    (``settings/reference_returns.json``, written by ``bimrobot assembly optimum --setting all --write``),
    computed on the fly when the table lacks the setting."""
    if setting not in SETTINGS:
        raise InputError(f"unknown assembly setting '{setting}': expected one of {', '.join(SETTINGS)}")
    if REFERENCE_FILE.is_file():
        table = json.loads(REFERENCE_FILE.read_text())
        if setting in table.get("settings", {}):
            return dict(table["settings"][setting])
    return compute_reference_returns(setting)


def normalised_score(setting: str, mean_return: float) -> float:
    """``(return - random) / (optimal - random)``: 0 for the random policy, 1 for the optimal planner."""
    ref = reference_returns(setting)
    return (mean_return - ref["random"]) / (ref["optimal"] - ref["random"])
