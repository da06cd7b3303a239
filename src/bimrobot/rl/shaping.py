"""Potential-based reward shaping for training on the batched assembly simulator (optional).

The benchmark's reward is sparse: every step costs the same whatever its direction, and only a placement
pays. A random walk of 100 steps almost never carries a component the ~14 cells to its slot, so on-policy
learners see nearly no reward (measured: MaskablePPO on E1S2, 100k steps, no placement learnt).

:class:`DistanceShaping` adds ``F = scale * (gamma * phi(s') - phi(s))`` to the *training* reward, with
``phi(s) = -`` the Manhattan distance (cells) from the current component's pose to the nearest pose at
which it would fill an eligible free slot (obstacles ignored). Potential-based shaping of this form leaves
the optimal policies unchanged (Ng, Harada & Russell 1999). It is applied to the training signal only:
the Monitor-style ``episode`` returns, the evaluation and every reported figure are the environment's own
reward. The policy still acts on observations alone.

It reads the batched simulator's state (``sim.pos``, ``sim.cur``, ``sim.filled``, ``sim.supports``,
``sim.cs.comp_arrival``), so it only wraps :func:`bimrobot.assembly.vector.AssemblySB3VecEnv`.
"""

from __future__ import annotations

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper


def slot_corners(sim) -> np.ndarray:
    """(n_comp + 1, n_target, 3) float: the min-corner cell at which component c fills target t, NaN
    where it cannot (other type or axis); the extra last row (no current component) is all NaN."""
    cs = sim.cs
    corners = np.full((cs.n_comp + 1, cs.n_target, 3), np.nan)
    for c, table in enumerate(cs.comp_arrival):
        for flat, t in table.items():
            corners[c, t] = cs.unflat(flat)
    return corners


class DistanceShaping(VecEnvWrapper):
    """Adds ``scale * (gamma * phi(s') - phi(s))`` to the rewards of an AssemblySB3VecEnv (see module doc).

    ``phi(s')`` is 0 for a terminal state; for a time-limit truncation (the simulator has already reset)
    it is taken as ``phi(s)``.
    """

    def __init__(self, venv: VecEnv, gamma: float, scale: float = 1.0):
        super().__init__(venv)
        if not hasattr(venv, "sim"):
            raise TypeError("DistanceShaping needs the batched assembly simulator (AssemblySB3VecEnv)")
        self.sim = venv.sim
        self.gamma, self.scale = float(gamma), float(scale)
        self.corners = slot_corners(self.sim)
        self._phi_before = np.zeros(self.num_envs)

    def potential(self) -> np.ndarray:
        """phi of every env's current state: minus the L1 distance (cells) to the nearest eligible slot pose."""
        sim = self.sim
        corners = self.corners[np.minimum(sim.cur, len(self.corners) - 1)]  # (N, T, 3)
        filled = sim.filled[:, :-1]
        supported = sim.filled[:, sim.supports[:, 0]] & sim.filled[:, sim.supports[:, 1]]
        eligible = ~filled & supported & ~np.isnan(corners[..., 0])
        distance = np.abs(corners - sim.pos[:, None, :]).sum(axis=2)
        distance = np.where(eligible, distance, np.inf).min(axis=1)
        return -np.where(np.isfinite(distance), distance, 0.0)

    def reset(self):
        obs = self.venv.reset()
        self._phi_before = self.potential()
        return obs

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        phi_after = self.potential()
        for i in np.flatnonzero(dones):
            truncated = infos[i].get("TimeLimit.truncated", False)
            phi_after_i = self._phi_before[i] if truncated else 0.0
            rewards[i] += self.scale * (self.gamma * phi_after_i - self._phi_before[i])
        alive = ~dones
        rewards[alive] += self.scale * (self.gamma * phi_after[alive] - self._phi_before[alive])
        self._phi_before = phi_after
        return obs, rewards, dones, infos
