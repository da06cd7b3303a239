"""N assembly environments stepped at once with numpy, with the single env's exact semantics.

:class:`BatchedAssemblySim` is the engine (arrays over environments, automatic resets, the time limit of
the registered ids); :class:`AssemblyVectorEnv` wraps it as a ``gymnasium.vector.VectorEnv``
(same-step autoreset) and :class:`AssemblySB3VecEnv` as a Stable-Baselines3 ``VecEnv``.

Environment ``i`` behaves exactly like ``gym.make("bimrobot/Assembly-<setting>-v0")`` reset first with
``seed + i`` and then, after every episode end, with no seed (its generator carries on); the property
tests check observations, rewards, flags and masks against that. Only ``obs_mode="thesis"`` is batched.
"""

from __future__ import annotations

from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding

from bimrobot.assembly.env import ACTION_HELP, MOVES, N_CHANNELS, ActionError, AssemblyEnv, _shown, reward_constants
from bimrobot.assembly.scenario import (
    Scenario,
    benchmark_scenario,
    compile_scenario,
    sample_layout,
    sample_prebuilt_slots,
)
from bimrobot.errors import InputError

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
    a = a.reshape(num_envs).astype(np.int64)
    bad = np.flatnonzero((a < 0) | (a >= len(MOVES)))
    if bad.size:
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
    and, where an episode ended, ``info["final_observation"]`` (the last observation before the automatic
    reset; the returned observation is already the next episode's first).
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
        self.occ = np.zeros((N, self.P), np.uint8)
        self._occ_flat = self.occ.reshape(-1)
        self._env_base = np.arange(N, dtype=np.int64) * self.P
        self.pos = np.zeros((N, 3), np.int64)  # min corner of the current component, grid cells
        self.pflat = np.zeros(N, np.int64)  # the same as a padded flat index
        self.cur = np.zeros(N, np.int64)
        self.steps = np.zeros(N, np.int64)
        self.elapsed = np.zeros(N, np.int64)
        self.k = np.zeros(N, np.int64)
        self.filled = np.zeros((N, T + 1), bool)  # the last column is "always filled" (no support needed)
        self.starts = np.zeros((N, C, 2, 3), np.int64)
        self.wait_cells = np.zeros((N, C, 4), np.int64)
        self.wait_top = np.zeros((N, C, W * L), np.int8)
        self.obs = np.zeros((N, W * L * N_CHANNELS), np.int8)
        self.mask = np.zeros((N, 6), bool)
        self.fp = np.zeros((N, 4), np.int64)  # obs indices of the current component's drawn footprint
        self.env_move_cells = np.zeros((N, 6, 4), np.int64)  # move_cells of each env's current component
        self.done = np.ones(N, bool)
        self.rngs: list[np.random.Generator] = [None] * N  # type: ignore[list-item]
        self._seed(seed)
        self._arange = np.arange(N)

    # ------------------------------------------------------------------------------------ tables

    def _build_tables(self) -> None:
        cs = self.cs
        W, L, H, C, T = cs.W, cs.L, cs.H, cs.n_comp, cs.n_target
        # occupancy is kept on a grid padded by one blocked cell all round (flat index over (W+2, L+2, H+2)):
        # a move shifts a valid pose by one cell, so its cells never leave the padded grid and the
        # blocked test is a single gather
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
        # per component and move: padded flat offsets of the cells the moved pose occupies
        self.move_cells = self.delta[None, :, None] + self.offsets[:, None, :]  # (C + 1, 6, 4)
        self.arrival = np.full((C + 1, self.P), -1, np.int64)
        for c, table in enumerate(cs.comp_arrival):
            for corner, t in table.items():
                self.arrival[c, self._pad(corner)] = t
        self.supports = np.full((T, 2), T, np.int64)
        for t, sup in enumerate(cs.target_supports):
            self.supports[t, : len(sup)] = sup
        self.target_cells = np.array(
            [[self._pad(f) for f in (cells + [cells[-1]] * 4)[:4]] for cells in cs.target_cells], np.int64
        )
        self.target_fp = cs.target_fp.reshape(T, W * L).astype(np.float32)
        self.target_top = cs.target_top.reshape(T, W * L)
        self.obstacle_top = cs.obstacle_top.reshape(-1)
        static = np.ones(self.padded, np.uint8)
        static[1:-1, 1:-1, 1:-1] = cs.static_blocked.reshape(W, L, H)
        self.static = static.reshape(-1)
        self.n_prebuilt = len(cs.prebuilt_slots)

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
        self._draw_current(self._arange)
        self._compute_masks(self._arange)
        return self.observations(), {"action_mask": self.mask.copy()}

    def observations(self) -> np.ndarray:
        cs = self.cs
        return self.obs.reshape(self.num_envs, cs.W, cs.L, N_CHANNELS).copy()

    def step(self, actions: np.ndarray, autoreset: bool = True):
        """Advance every environment by one action; ended episodes restart at once when ``autoreset``
        (without it, ended environments ignore their actions and pay 0 until :meth:`reset`)."""
        N = self.num_envs
        a = check_actions(actions, N)
        active = ~self.done
        idx = np.flatnonzero(active)
        self._clear_current(idx)
        moving = active & self.mask[self._arange, a]
        self.pos += _MOVES[a] * moving[:, None]
        self.pflat += self.delta[a] * moving
        self.steps += active
        self.elapsed += active
        target = np.where(moving, self.arrival[self.cur, self.pflat], -1)
        tgt = np.maximum(target, 0)
        arrive = (
            (target >= 0)
            & ~self.filled[self._arange, tgt]
            & self.filled[self._arange, self.supports[tgt, 0]]
            & self.filled[self._arange, self.supports[tgt, 1]]
        )
        step_cost = self.r0 / (self.cur + 1) * np.where(self.steps > self.epsilon, 2.0, 1.0)
        last = self.cur == self.cs.n_comp - 1
        reward = np.where(arrive, self.k + 1 + np.where(last, self.completion_bonus, 0.0), step_cost)
        reward = np.where(active, reward, 0.0)
        placed = np.flatnonzero(arrive)
        if placed.size:
            self._place(placed, target[placed])
        terminated = active & self.done
        truncated = active & (self.elapsed >= self.time_limit)
        info: dict[str, Any] = {"blocked": active & ~moving, "placed": arrive}
        ended = np.flatnonzero(terminated | truncated)
        if ended.size:
            self.done[ended] = True
            still = ended[self.cur[ended] < self.cs.n_comp]
            self._draw_current(still)
            final = self.observations()
            info["final_observation"] = final
            info["_final_observation"] = terminated | truncated
            if autoreset:
                self._clear_current(still)
                self._reset_envs(ended)
        self._draw_current(np.flatnonzero(~self.done))
        self._compute_masks(self._arange)
        info["action_mask"] = self.mask.copy()
        return self.observations(), reward, terminated, truncated, info

    # ---------------------------------------------------------------------------------- dynamics

    def _reset_envs(self, envs: np.ndarray) -> None:
        cs = self.cs
        R = len(envs)
        if R == 0:
            return
        # the per-env draws, in the single env's order (prebuilt slots, then the layout)
        random_slots = any(len(options) > 1 for options in cs.prebuilt_slots)
        if random_slots or cs.fixed_starts is None:
            slots, layouts = [], []
            for e in envs.tolist():
                rng = self.rngs[e]
                slots.append(sample_prebuilt_slots(cs, rng))
                if cs.fixed_starts is None:
                    layouts.append(sample_layout(cs, rng))
            prebuilt = np.array(slots, np.int64).reshape(R, self.n_prebuilt)
            self.starts[envs] = np.array(layouts if layouts else [cs.fixed_starts] * R, np.int64)
        else:
            prebuilt = np.array([[options[0] for options in cs.prebuilt_slots]] * R, np.int64).reshape(R, -1)
            self.starts[envs] = np.array(cs.fixed_starts, np.int64)
        self.occ[envs] = self.static
        self.filled[envs] = False
        self.filled[envs, -1] = True
        if self.n_prebuilt:
            rows = envs[:, None]
            self.filled[rows, prebuilt] = True
            self.occ[rows, self.target_cells[prebuilt].reshape(R, -1)] = 1
        # waiting cells: min corner + k * stride along the lying axis
        starts = self.starts[envs]  # (R, C, 2, 3)
        lo = starts.min(axis=2)
        span = starts.max(axis=2) - lo  # (R, C, 3)
        length = span.max(axis=2) + 1
        axis = np.argmax(span, axis=2)
        axis = np.where(span.max(axis=2) == 0, 2, axis)
        ks = np.minimum(np.arange(4)[None, None, :], (length - 1)[..., None])
        corner = lo @ np.array([cs.L * cs.H, cs.H, 1])
        cells = corner[..., None] + ks * np.array([cs.L * cs.H, cs.H, 1])[axis][..., None]  # unpadded flat
        z = cells % cs.H
        xy = cells // cs.H
        cells = self._pad(cells)
        self.wait_cells[envs] = cells
        self.occ[envs[:, None], cells.reshape(R, -1)] = 1
        self.wait_top[envs] = 0
        C = cs.n_comp
        r_idx = np.broadcast_to(envs[:, None, None], cells.shape)
        c_idx = np.broadcast_to(np.arange(C)[None, :, None], cells.shape)
        np.maximum.at(self.wait_top, (r_idx, c_idx, xy), z.astype(np.int8))
        self.k[envs] = self.n_prebuilt
        self.elapsed[envs] = 0
        self.done[envs] = False
        self.obs[envs] = 0
        self._become_current(envs, np.zeros(R, np.int64))
        self._refresh_static(envs)

    def _place(self, envs: np.ndarray, targets: np.ndarray) -> None:
        self.occ[envs[:, None], self.target_cells[targets]] = 1
        self.filled[envs, targets] = True
        self.k[envs] += 1
        nxt = self.cur[envs] + 1
        finished = nxt >= self.cs.n_comp
        self.cur[envs[finished]] = nxt[finished]
        self.done[envs[finished]] = True
        going = ~finished
        self._become_current(envs[going], nxt[going])
        self._refresh_static(envs)

    def _become_current(self, envs: np.ndarray, comps: np.ndarray) -> None:
        """Pick up component ``comps[r]`` in env ``envs[r]``: the lifted pose of the spec."""
        if len(envs) == 0:
            return
        cs = self.cs
        W, L, H = cs.W, cs.L, cs.H
        self.occ[envs[:, None], self.wait_cells[envs, comps]] = 0
        starts = self.starts[envs, comps]  # (R, 2, 3)
        node1 = starts[:, 0]
        lo = starts.min(axis=1)
        hi = starts.max(axis=1)
        n = self.comp_len[comps]
        axis = self.comp_axis[comps]
        column = self.comp_is_column[comps]
        # beam centre cell: the ((len-1)//2)-th cell from the low end of its lying run
        span = hi - lo
        lying_axis = np.where(span.max(axis=1) == 0, 2, np.argmax(span, axis=1))
        centre = lo.copy()
        centre[np.arange(len(envs)), lying_axis] += (span.max(axis=1)) // 2
        corner = np.where(column[:, None], np.stack([node1[:, 0], node1[:, 1], lo[:, 2] + 1], 1), 0)
        beam_corner = np.stack([centre[:, 0], centre[:, 1], self.comp_target_z[comps]], 1)
        beam_corner[np.arange(len(envs)), axis] -= np.where(column, 0, (n - 1) // 2)
        corner = np.where(column[:, None], corner, beam_corner)
        ext = self.ext[comps]
        corner[:, 0] = np.clip(corner[:, 0], 0, W - ext[:, 0])
        corner[:, 1] = np.clip(corner[:, 1], 0, L - ext[:, 1])
        top = H - ext[:, 2]
        offsets = self.offsets[comps]
        lifted = np.full(len(envs), -1, np.int64)
        for dz in range(H):
            z = corner[:, 2] + dz
            ok = (z <= top) & (lifted < 0)
            if not ok.any():
                continue
            flat = (corner[:, 0] + 1) * self.stride[0] + (corner[:, 1] + 1) * self.stride[1] + np.minimum(z, H - 1) + 1
            cells = flat[:, None] + offsets
            free = ~self.occ[envs[:, None], cells].any(axis=1)
            lifted = np.where(ok & free, z, lifted)
        if (lifted < 0).any():
            bad = self.cs.scenario.handled[int(comps[np.argmax(lifted < 0)])].id
            raise InputError(f"{self.cs.scenario.source}: components.{bad}: the crane cannot lift it free of other objects")
        corner[:, 2] = lifted
        self.pos[envs] = corner
        self.pflat[envs] = (corner + 1) @ self.stride
        self.cur[envs] = comps
        self.env_move_cells[envs] = self.move_cells[comps]
        self.steps[envs] = 0

    def _refresh_static(self, envs: np.ndarray) -> None:
        """Channels 0, 1, 3, 5, 6 of the given environments (after a reset or a placement)."""
        if len(envs) == 0:
            return
        cs = self.cs
        WL = cs.W * cs.L
        obs = self.obs[envs].reshape(len(envs), WL, N_CHANNELS)
        filled = self.filled[envs, :-1]
        free = ~filled
        obs[:, :, 0] = (free.astype(np.float32) @ self.target_fp) > 0
        obs[:, :, 3] = np.max(np.where(free[:, :, None], self.target_top[None], 0), axis=1)
        waiting = np.arange(cs.n_comp)[None, :] > self.cur[envs][:, None]
        obs[:, :, 1] = np.max(np.where(waiting[:, :, None], self.wait_top[envs], 0), axis=1)
        placed_fp = (filled.astype(np.float32) @ self.target_fp) > 0
        obs[:, :, 5] = placed_fp * self.k[envs][:, None]
        obs[:, :, 6] = self.obstacle_top
        self.obs[envs] = obs.reshape(len(envs), -1)

    def _footprint(self, envs: np.ndarray) -> np.ndarray:
        cs = self.cs
        base = (self.pos[envs, 0] * cs.L + self.pos[envs, 1]) * N_CHANNELS
        return base[:, None] + self.fp_offsets[self.cur[envs]]

    def _clear_current(self, envs: np.ndarray) -> None:
        if len(envs) == 0:
            return
        fp = self.fp[envs]
        rows = envs[:, None]
        self.obs[rows, fp + 2] = 0
        self.obs[rows, fp + 4] = 0

    def _draw_current(self, envs: np.ndarray) -> None:
        if len(envs) == 0:
            return
        fp = self._footprint(envs)
        self.fp[envs] = fp
        rows = envs[:, None]
        top = self.pos[envs, 2] + self.top_offset[self.cur[envs]]
        self.obs[rows, fp + 2] = top[:, None]
        self.obs[rows, fp + 4] = (self.steps[envs] > self.epsilon)[:, None]

    def _compute_masks(self, envs: np.ndarray) -> None:
        """``mask[e, a]``: action a would move env e's current component (not blocked)."""
        cells = (self.pflat[envs] + self._env_base[envs])[:, None, None] + self.env_move_cells[envs]
        # the 4 occupancy bytes of a move's cells read as one uint32: nonzero means blocked
        hit = self._occ_flat[cells].view(np.uint32)[..., 0]  # (R, 6)
        self.mask[envs] = (hit == 0) & ~self.done[envs][:, None]

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
    global _SB3_CLASS
    if _SB3_CLASS is not None:
        return _SB3_CLASS
    from bimrobot.errors import require_extra

    vec_env = require_extra("stable_baselines3.common.vec_env", "rl")
    import time

    class _AssemblySB3VecEnv(vec_env.VecEnv):
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

    _SB3_CLASS = _AssemblySB3VecEnv
    return _SB3_CLASS
