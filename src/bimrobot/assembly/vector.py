"""N assembly environments stepped at once (numba kernels over numpy arrays), with the single env's exact semantics.

:class:`BatchedAssemblySim` is the engine (arrays over environments, automatic resets, the time limit of
the registered ids); :class:`AssemblyVectorEnv` wraps it as a ``gymnasium.vector.VectorEnv``
(same-step autoreset) and :class:`AssemblySB3VecEnv` as a Stable-Baselines3 ``VecEnv``.

Environment ``i`` behaves exactly like ``gym.make("bimrobot/Assembly-<setting>-v0")`` reset first with
``seed + i`` and then, after every episode end, with no seed (its generator carries on); the property
tests check observations, rewards, flags and masks against that. Only ``obs_mode="thesis"`` is batched.

The per-environment work is done by the numba kernels of :mod:`bimrobot.assembly.vector_kernels` (compiled
on first use and cached next to that file), one pass over the environments per step; see "Speed" in
docs/assembly.md.
"""

from __future__ import annotations

import time
from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding

from bimrobot.assembly.compiled import (
    MAX_LAYOUT_ATTEMPTS,
    _lying_candidates,
    _lying_table,
    compile_scenario,
    sample_prebuilt_slots,
)
from bimrobot.assembly.env import ACTION_HELP, MOVES, N_CHANNELS, ActionError, AssemblyEnv, _shown, reward_constants
from bimrobot.assembly.scenario import Scenario, benchmark_scenario
from bimrobot.assembly.vector_kernels import _NO_ERROR, _k_layouts, _k_reset, _k_step
from bimrobot.core.errors import InputError

_MOVES = np.array(MOVES, np.int64)
#: Most environments of one batch (a few kB each; SB3 rollouts hold n_steps observations of each).
MAX_ENVS = 4096


def check_actions(actions, num_envs: int) -> np.ndarray:
    """``actions`` as an (N,) int64 array of moves 0..5, or an :class:`ActionError` naming the first bad one."""
    try:
        a = np.asarray(actions)
    except (TypeError, ValueError):  # ragged nested lists
        a = np.asarray([None])
    if a.size != num_envs or not np.issubdtype(a.dtype, np.integer):
        raise ActionError(
            f"actions {_shown(actions)} are not {num_envs} integer moves 0..5, one per environment ({ACTION_HELP})"
        )
    a = np.ascontiguousarray(a.reshape(num_envs), dtype=np.int64)
    if a.min() < 0 or a.max() >= len(MOVES):
        bad = np.flatnonzero((a < 0) | (a >= len(MOVES)))
        raise ActionError(
            f"action {a[bad[0]]} of environment {bad[0]} is outside the action space Discrete(6): "
            f"give integers 0..5 ({ACTION_HELP})"
        )
    return a


class BatchedAssemblySim:
    """``num_envs`` copies of one assembly setting as arrays.

    Args:
        setting: a benchmark setting ("E1S1" .. "E4S4"), or None with ``scenario``.
        num_envs: number of environments N.
        seed: environment i's generator is seeded with ``seed + i`` (None: fresh entropy).
        scenario: a custom :class:`Scenario` instead of a setting.
        time_limit: steps per episode (default: the scenario's, as in the registered ids).
        r0, epsilon, completion_bonus: reward constants (default: the scenario's).

    ``step(actions)`` returns ``obs (N, W, L, 7) int8, reward (N,) float64, terminated (N,), truncated (N,),
    info`` with ``info["action_mask"] (N, 6) bool``, ``info["blocked"]``, ``info["placed"]`` (N,) bool,
    and, where an episode ended, ``info["final_observation"]`` (N, W, L, 7): for the environments flagged
    in ``info["_final_observation"]`` the last observation before the automatic reset (the returned
    observation is already the next episode's first), zeros for the others.
    """

    render_mode = None

    def __init__(
        self,
        setting: str | None = "E2S2",
        num_envs: int = 1,
        seed: int | None = None,
        scenario: Scenario | None = None,
        time_limit: int | None = None,
        obs_mode: str = "thesis",
        r0: float | None = None,
        epsilon: int | None = None,
        completion_bonus: float | None = None,
    ):
        if obs_mode != "thesis":
            raise InputError("the batched simulator supports obs_mode='thesis' only")
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or not 1 <= num_envs <= MAX_ENVS:
            raise InputError(f"num_envs must be an integer from 1 to {MAX_ENVS}, got {num_envs!r}")
        scenario = scenario if scenario is not None else benchmark_scenario(setting)
        self.scenario = scenario
        self.num_envs = N = int(num_envs)
        cs = self.cs = compile_scenario(scenario)
        reward = scenario.reward
        self.r0, self.epsilon, self.completion_bonus = reward_constants(reward, r0, epsilon, completion_bonus)
        self.time_limit = int(scenario.time_limit if time_limit is None else time_limit)
        self.single_observation_space = AssemblyEnv(scenario=scenario).observation_space
        self.single_action_space = gym.spaces.Discrete(6)
        self._build_tables()
        W, L, C, T = cs.W, cs.L, cs.n_comp, cs.n_target
        self.occ = np.zeros((N, self.P), np.uint8)  # padded occupancy: 1 blocked
        self.pos = np.zeros((N, 3), np.int64)  # min corner of the current component, grid cells
        self.pflat = np.zeros(N, np.int64)  # the same as a padded flat index
        self.cur = np.zeros(N, np.int64)  # current component (C once all are placed)
        self.steps = np.zeros(N, np.int64)  # steps spent on the current component
        self.elapsed = np.zeros(N, np.int64)  # steps in the episode
        self.k = np.zeros(N, np.int64)  # components standing
        self.filled = np.zeros((N, T + 1), bool)  # the last column is "always filled" (no support needed)
        self.starts = np.zeros((N, C, 2, 3), np.int64)  # lying poses (node1, node2)
        self.wait_cells = np.zeros((N, C, 4), np.int64)  # padded flat cells of the lying poses (repeated)
        self.wait_xy = np.zeros((N, C, 4), np.int64)  # their x * L + y
        self.wait_z = np.zeros((N, C, 4), np.int64)  # and z
        self.obs = np.zeros((N, W * L * N_CHANNELS), np.int8)
        self.mask = np.zeros((N, 6), bool)
        self.fp = np.zeros((N, 4), np.int64)  # obs indices of the current component's drawn footprint
        self.done = np.ones(N, bool)
        self.rngs: list[np.random.Generator] = [None] * N  # type: ignore[list-item]
        self._seed(seed)
        self._arange = np.arange(N)

    # ------------------------------------------------------------------------------------ tables

    def _build_tables(self) -> None:
        cs = self.cs
        W, L, H, C, T = cs.W, cs.L, cs.H, cs.n_comp, cs.n_target
        self.padded = (W + 2, L + 2, H + 2)
        self.P = int(np.prod(self.padded))
        self.stride = np.array([(L + 2) * (H + 2), H + 2, 1], np.int64)
        self.delta = _MOVES @ self.stride
        self.comp_len = np.array(cs.comp_len, np.int64)
        self.comp_axis = np.array(cs.comp_axis, np.int64)
        self.comp_is_column = np.array([t == "column" for t in cs.comp_type])
        self.comp_target_z = np.array([cs.scenario.target(c.target).node1[2] for c in cs.scenario.handled], np.int64)
        self.ext = np.ones((C + 1, 3), np.int64)
        self.offsets = np.zeros((C + 1, 4), np.int64)  # flat cell offsets, padded by repeating the last
        self.fp_offsets = np.zeros((C + 1, 4), np.int64)  # obs offsets of the (x, y) footprint
        self.top_offset = np.zeros(C + 1, np.int64)
        for c in range(C):
            n, axis = cs.comp_len[c], cs.comp_axis[c]
            self.ext[c, axis] = n
            ks = np.minimum(np.arange(4), n - 1)
            self.offsets[c] = ks * self.stride[axis]
            if axis == 2:
                self.top_offset[c] = n - 1
            else:
                self.fp_offsets[c] = ks * (L * N_CHANNELS if axis == 0 else N_CHANNELS)
        self.arrival = np.full((C + 1, self.P), -1, np.int64)  # target filled by arriving at a padded corner
        for c, table in enumerate(cs.comp_arrival):
            for corner, t in table.items():
                self.arrival[c, self._pad(corner)] = t
        self.supports = np.full((T, 2), T, np.int64)
        for t, sup in enumerate(cs.target_supports):
            self.supports[t, : len(sup)] = sup
        cells = np.array([(cells + [cells[-1]] * 4)[:4] for cells in cs.target_cells], np.int64).reshape(T, 4)
        self.target_cells = self._pad(cells)
        static = np.ones(self.padded, np.uint8)
        static[1:-1, 1:-1, 1:-1] = cs.static_blocked.reshape(W, L, H)
        self.static = static.reshape(-1)
        self.n_prebuilt = len(cs.prebuilt_slots)
        self._random_prebuilt = any(len(options) > 1 for options in cs.prebuilt_slots)
        self._fixed_prebuilt = np.array([[options[0] for options in cs.prebuilt_slots]], np.int64).reshape(1, -1)
        if cs.fixed_starts is not None:
            self._fixed_layout = np.array([cs.fixed_starts], np.int64).reshape(1, C, 2, 3)
        dims = np.array([W, L, H, C, T], np.int64)
        obstacle_top = np.ascontiguousarray(cs.obstacle_top.reshape(-1), dtype=np.int8)
        self._blank_obs = np.zeros((W * L, N_CHANNELS), np.int8)  # an episode's first obs before the kernel
        self._blank_obs[:, 6] = obstacle_top
        self._blank_obs = self._blank_obs.reshape(-1)
        target_xy, target_z = cells // H, cells % H  # (x * L + y, z) of each target's cells
        # the kernels' scenario tables, indexed by position there (G[0] .. G[16])
        self._G = (
            dims, self.stride, self.delta, _MOVES, self.comp_len, self.comp_axis, self.comp_is_column,
            self.comp_target_z, self.ext, self.offsets, self.fp_offsets, self.top_offset, self.arrival,
            self.supports, self.target_cells, target_xy, target_z,
        )  # fmt: skip
        if cs.fixed_starts is None:
            self._layout_tables()

    def _layout_tables(self) -> None:
        """scenario.sample_layout's tables as arrays, for the layout kernel."""
        cs = self.cs
        W, L, C = cs.W, cs.L, cs.n_comp
        self._yard_x = np.array(cs.yard_x, np.int64)
        self._yard_y = np.array([(cs.yard_y[x][0], cs.yard_y[x][1] - cs.yard_y[x][0] + 1) for x in cs.yard_x], np.int64)
        self._lying = np.full((C, 2 * W * L, 4), -1, np.int64)  # node1 index -> (x, y) cells, or -1
        counts = [len(_lying_candidates(cs, n)[0]) for n in cs.comp_len]
        self._candidates = np.zeros((C, max(counts + [1]), 4), np.int64)
        self._n_candidates = np.array(counts, np.int64)
        for c, n in enumerate(cs.comp_len):
            for index, run in enumerate(_lying_table(cs, n)):
                if run is not None:
                    self._lying[c, index, :n] = run
            self._candidates[c, : counts[c], :n] = _lying_candidates(cs, n)[0]

    def _state(self) -> tuple:
        return (
            self.occ, self.pos, self.pflat, self.cur, self.steps, self.elapsed, self.k, self.filled, self.starts,
            self.wait_cells, self.wait_xy, self.wait_z, self.obs, self.mask, self.fp, self.done,
        )  # fmt: skip

    # ------------------------------------------------------------------------------------- seeding

    def _seed(self, seed: int | Sequence[int] | None) -> None:
        if seed is None or isinstance(seed, (int, np.integer)):
            seeds = [None if seed is None else int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = [None if s is None else int(s) for s in seed]
            if len(seeds) != self.num_envs:
                raise InputError(f"expected {self.num_envs} seeds, got {len(seeds)}")
        for i, s in enumerate(seeds):
            self.rngs[i], _ = seeding.np_random(s)

    # --------------------------------------------------------------------------------------- API

    def reset(self, seed: int | None = None, seeds: Sequence[int] | None = None) -> tuple[np.ndarray, dict]:
        """Reset every environment (reseeding them when ``seed``/``seeds`` is given)."""
        if seed is not None or seeds is not None:
            self._seed(seeds if seeds is not None else seed)
        self._reset_envs(self._arange)
        return self.observations(), {"action_mask": self.mask.copy()}

    def observations(self) -> np.ndarray:
        cs = self.cs
        return self.obs.reshape(self.num_envs, cs.W, cs.L, N_CHANNELS).copy()

    def step(self, actions: np.ndarray, autoreset: bool = True):
        """Advance every environment by one action; ended episodes restart at once when ``autoreset``
        (without it, ended environments ignore their actions and pay 0 until :meth:`reset`)."""
        a = check_actions(actions, self.num_envs)
        N = self.num_envs
        reward = np.empty(N)
        terminated, truncated, blocked, placed = (np.empty(N, bool) for _ in range(4))
        error = _k_step(
            self._state(), self._G, a, self.r0, self.epsilon, self.completion_bonus, self.time_limit,
            reward, terminated, truncated, blocked, placed,
        )  # fmt: skip
        self._raise_if_stuck(error)
        info: dict[str, Any] = {"blocked": blocked, "placed": placed}
        ended_mask = terminated | truncated
        ended = np.flatnonzero(ended_mask)
        if ended.size:
            cs = self.cs
            final = np.zeros((N, cs.W, cs.L, N_CHANNELS), np.int8)
            final.reshape(N, -1)[ended] = self.obs[ended]
            info["final_observation"] = final
            info["_final_observation"] = ended_mask
            if autoreset:
                self._reset_envs(ended)
        info["action_mask"] = self.mask.copy()
        return self.observations(), reward, terminated, truncated, info

    # ---------------------------------------------------------------------------------- dynamics

    def _reset_envs(self, envs: np.ndarray) -> None:
        """New episodes in ``envs``: each env's draws in the single env's order (prebuilt slots, layout)."""
        cs = self.cs
        R = len(envs)
        if R == 0:
            return
        if self._random_prebuilt:
            prebuilt = np.array([sample_prebuilt_slots(cs, self.rngs[e]) for e in envs.tolist()], np.int64)
            prebuilt = prebuilt.reshape(R, self.n_prebuilt)
        else:
            prebuilt = self._fixed_prebuilt  # one row for all
        layouts = self._sample_layouts(envs) if cs.fixed_starts is None else self._fixed_layout  # (1, C, 2, 3)
        envs = np.ascontiguousarray(envs, np.int64)
        # the bulk of a reset as numpy row copies (memcpy), faster than element loops in the kernel
        self.occ[envs] = self.static
        self.obs[envs] = self._blank_obs
        error = _k_reset(self._state(), self._G, envs, layouts, prebuilt, self.epsilon)
        self._raise_if_stuck(error)

    def _sample_layouts(self, envs: np.ndarray) -> np.ndarray:
        """``scenario.sample_layout(cs, rngs[e])`` for each env e, drawing the same uniforms from each
        generator: blocks of 192, one at a time, a fresh block for each new attempt. The kernel goes on
        with an attempt where the previous block ended; only the drawing of blocks is per env in Python."""
        cs = self.cs
        R = len(envs)
        rngs = [self.rngs[e] for e in envs.tolist()]
        block = np.empty((R, 192))
        for j, rng in enumerate(rngs):
            rng.random(out=block[j])
        progress = np.zeros((R, 2), np.int64)  # component being drawn, its failed draws so far
        occupied = np.zeros((R, cs.W * cs.L), np.uint8)  # (x, y) cells taken in the current attempt
        attempts = np.ones(R, np.int64)
        out = np.zeros((R, cs.n_comp, 2, 3), np.int64)
        pending = np.arange(R)
        while True:
            status = np.zeros(len(pending), np.int64)
            _k_layouts(
                block, pending, status, progress, occupied, out, self.comp_len, self._yard_x, self._yard_y,
                self._lying, self._candidates, self._n_candidates, cs.L,
            )  # fmt: skip
            again = status != 0
            if not again.any():
                return out
            pending, status = pending[again], status[again]
            block = np.empty((len(pending), 192))
            for j, r in enumerate(pending.tolist()):
                if status[j] == 2:  # a component fits nowhere: a new attempt (the kernel has cleared it)
                    attempts[r] += 1
                    if attempts[r] > MAX_LAYOUT_ATTEMPTS:
                        raise InputError(
                            f"{cs.scenario.source}: impossible random layout: the yard cannot hold all "
                            f"{cs.n_comp} components without overlaps in {MAX_LAYOUT_ATTEMPTS} attempts"
                        )
                rngs[r].random(out=block[j])

    def _raise_if_stuck(self, component: int) -> None:
        if component != _NO_ERROR:
            bad = self.cs.scenario.handled[component].id
            raise InputError(
                f"{self.cs.scenario.source}: components.{bad}: the crane cannot lift it free of other objects"
            )

    def _pad(self, flat):
        """Unpadded flat cell index(es) of the scenario -> padded flat index(es)."""
        cs = self.cs
        flat = np.asarray(flat, np.int64)
        z = flat % cs.H
        xy = flat // cs.H
        x, y = xy // cs.L, xy % cs.L
        return (x + 1) * self.stride[0] + (y + 1) * self.stride[1] + z + 1


class AssemblyVectorEnv(gym.vector.VectorEnv):
    """A ``gymnasium.vector.VectorEnv`` of N assembly environments (same-step autoreset: an ended
    episode's last observation is in ``info["final_obs"]``, its info in ``info["final_info"]``).

    Also what ``gym.make_vec("bimrobot/Assembly-E2S2-v0", num_envs=64)`` returns (the registered
    ``vector_entry_point``)."""

    metadata = {"autoreset_mode": gym.vector.AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, setting: str, num_envs: int, seed: int | None = None, **env_kwargs):
        if "max_episode_steps" in env_kwargs:  # from gym.make_vec through the registration
            env_kwargs["time_limit"] = env_kwargs.pop("max_episode_steps")
        self.sim = BatchedAssemblySim(setting, num_envs, seed=seed, **env_kwargs)
        self.num_envs = num_envs
        self.single_observation_space = self.sim.single_observation_space
        self.single_action_space = self.sim.single_action_space
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, num_envs)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, num_envs)
        self._returns = np.zeros(num_envs)
        self._lengths = np.zeros(num_envs, np.int64)

    def reset(self, *, seed: int | list[int] | None = None, options: dict | None = None):
        if isinstance(seed, (list, tuple)):
            obs, info = self.sim.reset(seeds=seed)
        else:
            obs, info = self.sim.reset(seed=seed)
        self._returns[:] = 0
        self._lengths[:] = 0
        return obs, info

    def step(self, actions):
        obs, reward, terminated, truncated, info = self.sim.step(actions)
        self._returns += reward
        self._lengths += 1
        ended = terminated | truncated
        if ended.any():
            final = info.pop("final_observation")
            info.pop("_final_observation")
            info["final_obs"] = np.array([final[i] if ended[i] else None for i in range(self.num_envs)], dtype=object)
            info["_final_obs"] = ended
            info["final_info"] = {
                "episode": {"r": np.where(ended, self._returns, 0.0), "l": np.where(ended, self._lengths, 0)},
                "_episode": ended,
            }
            info["_final_info"] = ended
            self._returns[ended] = 0
            self._lengths[ended] = 0
        return obs, reward, terminated, truncated, info

    def action_masks(self) -> np.ndarray:
        return self.sim.mask.copy()


def AssemblySB3VecEnv(setting: str, num_envs: int, seed: int | None = None, **env_kwargs):
    """A Stable-Baselines3 ``VecEnv`` of N assembly environments (imports SB3 lazily).

    ``action_masks()`` (also through ``env_method("action_masks")``) gives the (N, 6) bool masks for
    sb3-contrib's MaskablePPO; infos carry ``terminal_observation``, ``TimeLimit.truncated`` and
    Monitor-style ``episode`` statistics ``{"r", "l", "t"}``.
    """
    cls = _sb3_class()
    return cls(setting, num_envs, seed, **env_kwargs)


_SB3_CLASS = None


def _sb3_class():
    """The SB3 ``VecEnv`` subclass of :class:`_SB3VecEnvMethods`, made on first use (SB3 imported then)."""
    global _SB3_CLASS
    if _SB3_CLASS is None:
        from bimrobot.core.errors import require_extra

        vec_env = require_extra("stable_baselines3.common.vec_env", "rl")
        _SB3_CLASS = type("_AssemblySB3VecEnv", (_SB3VecEnvMethods, vec_env.VecEnv), {})
    return _SB3_CLASS


class _SB3VecEnvMethods:
    """What :func:`AssemblySB3VecEnv` adds to SB3's ``VecEnv`` (its base, given by :func:`_sb3_class`):
    the batched simulator behind the VecEnv calls, with Monitor-style episode statistics."""

    def __init__(self, setting, num_envs, seed=None, **env_kwargs):
        self.sim = BatchedAssemblySim(setting, num_envs, seed=seed, **env_kwargs)
        super().__init__(num_envs, self.sim.single_observation_space, self.sim.single_action_space)
        self._actions = np.zeros(num_envs, np.int64)
        self._returns = np.zeros(num_envs)
        self._lengths = np.zeros(num_envs, np.int64)
        self._t0 = time.time()

    def reset(self):
        if any(s is not None for s in self._seeds):  # set by VecEnv.seed(seed): seed + i
            obs, _ = self.sim.reset(seeds=[s if s is not None else 0 for s in self._seeds])
        else:
            obs, _ = self.sim.reset()
        self._reset_seeds()
        self._returns[:] = 0
        self._lengths[:] = 0
        return obs

    def step_async(self, actions):
        self._actions = actions  # checked by sim.step: N integers in 0..5

    def step_wait(self):
        obs, reward, terminated, truncated, info = self.sim.step(self._actions)
        self._returns += reward
        self._lengths += 1
        dones = terminated | truncated
        infos = [{} for _ in range(self.num_envs)]
        if dones.any():
            final = info["final_observation"]
            now = round(time.time() - self._t0, 6)
            for i in np.flatnonzero(dones):
                infos[i] = {
                    "terminal_observation": final[i],
                    "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                    "episode": {"r": float(self._returns[i]), "l": int(self._lengths[i]), "t": now},
                }
            self._returns[dones] = 0
            self._lengths[dones] = 0
        return obs, reward.astype(np.float32), dones, infos

    def action_masks(self) -> np.ndarray:
        return self.sim.mask.copy()

    def close(self):
        pass

    def has_attr(self, attr_name: str) -> bool:
        return attr_name == "action_masks" or hasattr(self.sim, attr_name)

    def get_attr(self, attr_name, indices=None):
        return [getattr(self.sim, attr_name)] * len(self._get_indices(indices))

    def set_attr(self, attr_name, value, indices=None):
        setattr(self.sim, attr_name, value)

    def env_method(self, method_name, *method_args, indices=None, **method_kwargs):
        idx = list(self._get_indices(indices))
        if method_name == "action_masks":
            masks = self.sim.mask.copy()
            return [masks[i] for i in idx]
        result = getattr(self.sim, method_name)(*method_args, **method_kwargs)
        return [result] * len(idx)

    def env_is_wrapped(self, wrapper_class, indices=None):
        return [False] * len(list(self._get_indices(indices)))
