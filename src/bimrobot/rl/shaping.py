"""Potential-based reward shaping for training on the batched assembly simulator (optional).

The benchmark's reward is sparse: every step costs the same whatever its direction, and only a placement
pays. A random walk of 100 steps almost never carries a component the ~14 cells to its slot, so on-policy
learners see nearly no reward (measured: MaskablePPO on E1S2, 100k steps, no placement learnt).

:class:`DistanceShaping` adds ``F = scale * (psi(s') - psi(s))`` to the *training* reward. The potential
``psi`` is the distance progress so far (cells): the sum, over the components picked up so far, of each
one's distance to its nearest eligible free slot at pick-up, minus the current component's distance now.
So a move towards the slot earns ``+scale``, a move away or a blocked move towards nothing ``-scale`` or 0,
the placing move ``+scale`` (its last cell of distance), and picking up the next component costs nothing.
The distance is measured in moves from the current component's pose to the nearest pose at which it would
fill an eligible free slot, by one of two metrics:

* ``"path"`` (default): the length of the shortest path of moves that are not blocked, found by a
  breadth-first search over the component's free poses (obstacles, foundations, waiting and placed
  components all block). Nothing but the current component moves while it is current, so one search per
  component, when it is picked up, serves all its steps. Poses from which no slot can be reached get the
  distance ``2 (W + L + H)``.
* ``"manhattan"``: the L1 distance, blind to obstacles (the first version; on the crowded S4 settings it
  points straight into the obstacles and training stalls, see docs/rl.md).

Why undiscounted progress and not the textbook ``gamma * phi(s') - phi(s)`` with ``phi = -distance``: with
the thesis' gamma = 0.9 and distances of 10-20 cells, the term ``(1 - gamma) * distance`` pays +1..+2 per
step, as much as the step cost, and every pick-up costs ``gamma *`` the next component's distance (about
-12) against a placement reward of +2..+13. Measured on E1S4 (MaskablePPO, 200k steps): the agent learnt
to carry the column to the far corner of the site and shuttle there, never placing (score 0.18). Shaping by
a potential difference leaves the optimal policies of the episodic, undiscounted objective unchanged (Ng,
Harada & Russell 1999): the shaped return of an episode is its return plus ``psi(end) - psi(start)``.
It is applied to the training signal only:
the Monitor-style ``episode`` returns, the evaluation and every reported figure are the environment's own
reward. The policy still acts on observations alone.

It reads the batched simulator's state (``sim.pos``, ``sim.pflat``, ``sim.occ``, ``sim.cur``, ``sim.filled``,
``sim.supports``, ``sim.arrival``), so it only wraps :func:`bimrobot.assembly.vector.AssemblySB3VecEnv`.
"""

from __future__ import annotations

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

from bimrobot.rl.names import SHAPING_METRICS


def slot_corners(sim) -> np.ndarray:
    """(n_comp + 1, n_target, 3) float: the min-corner cell at which component c fills target t, NaN
    where it cannot (other type or axis); the extra last row (no current component) is all NaN."""
    cs = sim.cs
    corners = np.full((cs.n_comp + 1, cs.n_target, 3), np.nan)
    for c, table in enumerate(cs.comp_arrival):
        for flat, t in table.items():
            corners[c, t] = cs.unflat(flat)
    return corners


def path_distances(sim, envs: np.ndarray) -> np.ndarray:
    """(len(envs), P) int32: moves from each padded min-corner pose of env e's current component to its
    nearest eligible free slot pose, by breadth-first search from the slots over the free poses; poses
    that are not free or reach no slot get ``2 (W + L + H)``. Envs are searched together, as arrays."""
    cs = sim.cs
    R, P = len(envs), sim.P
    far = 2 * (cs.W + cs.L + cs.H)
    comps = np.minimum(sim.cur[envs], cs.n_comp)  # n_comp (no current component) is the padding row
    # a pose is free when none of the component's cells is occupied; cells past the grid's end are blocked
    occupied = np.ones((R, P + int(sim.offsets.max()) + 1), bool)
    occupied[:, :P] = sim.occ[envs] != 0
    cells = np.arange(P)[None, :, None] + sim.offsets[comps][:, None, :]
    free = ~np.take_along_axis(occupied, cells.reshape(R, -1), axis=1).reshape(R, P, -1).any(axis=2)
    slot = sim.arrival[comps]  # (R, P): target filled by arriving at that pose, -1 none
    target = np.maximum(slot, 0)
    rows = np.arange(R)[:, None]
    filled = sim.filled[envs]
    eligible = (
        (slot >= 0)
        & ~filled[rows, target]
        & filled[rows, sim.supports[target, 0]]
        & filled[rows, sim.supports[target, 1]]
    )
    distance = np.full((R, P), far, np.int32)
    frontier = eligible & free
    reached = frontier.copy()
    steps = 0
    while frontier.any():
        distance[frontier] = steps
        steps += 1
        grown = np.zeros_like(frontier)
        for shift in sim.stride.tolist():  # one cell along x, y or z
            grown[:, shift:] |= frontier[:, :-shift]
            grown[:, :-shift] |= frontier[:, shift:]
        frontier = grown & free & ~reached
        reached |= frontier
    return np.minimum(distance, far)


class DistanceShaping(VecEnvWrapper):
    """Adds ``scale * (psi(s') - psi(s))`` to the rewards of an AssemblySB3VecEnv (see module doc).

    On a step that places a component (or ends the episode by placing the last) that is ``scale *`` the
    distance before the step; on a time-limit truncation (the simulator has already reset) it is 0.
    """

    def __init__(self, venv: VecEnv, scale: float = 1.0, metric: str = "path"):
        super().__init__(venv)
        if not hasattr(venv, "sim"):
            raise TypeError("DistanceShaping needs the batched assembly simulator (AssemblySB3VecEnv)")
        if metric not in SHAPING_METRICS:
            raise ValueError(f"unknown shaping metric {metric!r}: choose one of {', '.join(SHAPING_METRICS)}")
        self.sim = venv.sim
        self.scale, self.metric = float(scale), metric
        self.corners = slot_corners(self.sim)
        self._phi_before = np.zeros(self.num_envs)
        self._fields = np.zeros((self.num_envs, self.sim.P), np.int32)  # path distances, per env
        self._field_of = np.full((self.num_envs, 2), -1, np.int64)  # (episode count, component) searched

    def potential(self) -> np.ndarray:
        """Minus the distance (cells) from each env's current component to its nearest eligible slot pose
        (the part of ``psi`` that changes while one component moves)."""
        if self.metric == "path":
            return self._path_potential()
        sim = self.sim
        corners = self.corners[np.minimum(sim.cur, len(self.corners) - 1)]  # (N, T, 3)
        filled = sim.filled[:, :-1]
        supported = sim.filled[:, sim.supports[:, 0]] & sim.filled[:, sim.supports[:, 1]]
        eligible = ~filled & supported & ~np.isnan(corners[..., 0])
        distance = np.abs(corners - sim.pos[:, None, :]).sum(axis=2)
        distance = np.where(eligible, distance, np.inf).min(axis=1)
        return -np.where(np.isfinite(distance), distance, 0.0)

    def _path_potential(self) -> np.ndarray:
        sim = self.sim
        # a component's search stays valid until the next one is picked up or the episode restarts
        now = np.stack([self._episodes, sim.cur], axis=1)
        stale = np.flatnonzero((now != self._field_of).any(axis=1))
        if stale.size:
            self._fields[stale] = path_distances(sim, stale)
            self._field_of[stale] = now[stale]
        return -self._fields[np.arange(self.num_envs), sim.pflat].astype(np.float64)

    def reset(self):
        obs = self.venv.reset()
        self._episodes = np.zeros(self.num_envs, np.int64)
        self._field_of[:] = -1
        self._phi_before = self.potential()
        self._component_before = self.sim.cur.copy()
        return obs

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        self._episodes += dones
        phi_after = self.potential()
        truncated = np.array([bool(info.get("TimeLimit.truncated", False)) for info in infos])
        placed = (dones & ~truncated) | (~dones & (self.sim.cur != self._component_before))
        moved = ~dones & ~placed
        shaping = np.zeros(self.num_envs)
        shaping[placed] = -self._phi_before[placed]  # the last cell of distance; the next pick-up is free
        shaping[moved] = phi_after[moved] - self._phi_before[moved]
        rewards += self.scale * shaping
        self._phi_before = phi_after
        self._component_before = self.sim.cur.copy()
        return obs, rewards, dones, infos
