"""The assembly-planning Gymnasium environment (thesis chapter 6, ``../shared/specs/assembly-env.md``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from bimrobot.assembly.render import EpisodeView, Renderer, render_ansi
from bimrobot.assembly.scenario import (
    CompiledScenario,
    Scenario,
    benchmark_scenario,
    compile_scenario,
    lifted_pose,
    run_cells,
    sample_layout,
    sample_prebuilt_slots,
)
from bimrobot.core.errors import InputError

# action -> (dx, dy, dz); thesis names: forward, left, back, right, up, down
MOVES = ((-1, 0, 0), (0, -1, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, -1))
ACTION_NAMES = ("x-1", "y-1", "x+1", "y+1", "z+1", "z-1")
N_CHANNELS = 7

# cell codes of obs_mode="voxels"
EMPTY, GROUND, FOUNDATION, OBSTACLE, WAITING, CURRENT, PLACED, FREE_TARGET = range(8)
VOXEL_CODES = ("empty", "ground", "foundation", "obstacle", "waiting", "current", "placed", "free target")
#: Largest reset seed the commands accept: NumPy's legacy seeding (used by SB3) takes seeds below 2**32,
#: and runs add env indices and evaluation offsets to the seed they are given.
MAX_SEED = 2**31 - 1
ACTION_HELP = ", ".join(f"{i} {name}" for i, name in enumerate(ACTION_NAMES))


class ActionError(InputError, ValueError):
    """An action outside the action space ``Discrete(6)`` (a ValueError too, as Gymnasium users expect)."""


def _shown(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def check_action(action) -> int:
    """``action`` as an int in 0..5, or an :class:`ActionError` naming it and the valid range.

    Accepted: a Python or NumPy integer, or an integer array holding one element (what a policy's
    ``predict`` returns). Floats, booleans and anything else are refused, as ``Discrete(6).contains`` does.
    """
    value = action
    if isinstance(value, np.ndarray) and value.size == 1 and np.issubdtype(value.dtype, np.integer):
        value = value.reshape(())[()]
    if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)) and 0 <= value < len(MOVES):
        return int(value)
    raise ActionError(f"action {_shown(action)} is outside the action space Discrete(6): give an integer 0..5 ({ACTION_HELP})")


def reward_constants(reward, r0, epsilon, completion_bonus) -> tuple[float, int, float]:
    """The scenario's reward constants with the given overrides (None keeps the scenario's), checked as
    a scenario file's are: ``r0`` finite and negative (every step costs, which the planner relies on),
    ``epsilon`` a whole number of steps >= 0, ``completion_bonus`` finite and >= 0."""
    import math

    from bimrobot.assembly.scenario import MAX_REWARD, MAX_TIME_LIMIT

    r0 = reward.r0 if r0 is None else r0
    epsilon = reward.epsilon if epsilon is None else epsilon
    bonus = reward.completion_bonus if completion_bonus is None else completion_bonus
    for name, value in (("r0", r0), ("completion_bonus", bonus)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) or not math.isfinite(value):
            raise InputError(f"{name} must be a finite number, got {value!r}")
    if not -MAX_REWARD <= r0 < 0:
        raise InputError(f"r0 must be >= {-MAX_REWARD:g} and < 0 (the cost of a step), got {r0!r}")
    if not 0 <= bonus <= MAX_REWARD:
        raise InputError(f"completion_bonus must be from 0 to {MAX_REWARD:g}, got {bonus!r}")
    if isinstance(epsilon, bool) or not isinstance(epsilon, (int, np.integer)) or not 0 <= epsilon <= MAX_TIME_LIMIT:
        raise InputError(f"epsilon must be a whole number of steps from 0 to {MAX_TIME_LIMIT}, got {epsilon!r}")
    return float(r0), int(epsilon), float(bonus)


@dataclass(frozen=True)
class AssemblyState:
    """A snapshot of an episode, enough for the planner to continue from it.

    ``starts`` are the lying poses (node1, node2) of the handled components; ``placed`` maps the index
    of every placed handled component to the target index it fills; ``prebuilt_slots`` the target index
    of each prebuilt component; ``current`` the index of the current component (``n_comp`` when done),
    ``corner`` its min-corner cell and ``steps`` the steps already spent on it.
    """

    compiled: CompiledScenario
    starts: tuple
    prebuilt_slots: tuple[int, ...]
    placed: tuple[tuple[int, int], ...]
    current: int
    corner: tuple[int, int, int] | None
    steps: int
    elapsed: int


class AssemblyEnv(gym.Env):
    """A crane brings prefabricated columns and beams from a yard into a structure, one cell per step.

    ## Description

    The voxel simulator of the thesis bimrobot implements (chapter 6, DRL for assembly planning): the site is
    a 15 x 15 x 9 grid of unit cells (x, y, z; z up; z = 0 is the ground where the foundations are). Columns
    are runs of 4 cells, beams of 3. The components are handled one at a time in a fixed order (columns before
    the beams they support): the *current* component is the first one not yet placed. When it becomes
    current, the crane lifts it at no cost: a column stands up on its node1 (x, y) with its bottom at z = 2;
    a beam rises to its target's height and turns about its centre onto its target's axis (shifted inward if
    that leaves the grid; lifted further, one cell at a time, while it overlaps anything). The agent then
    moves it one cell per step. As soon as its cells are exactly those of an eligible free target it is
    placed there for good, and the next component becomes current. With interchangeable targets (scenarios
    S2-S4) a component may fill any free slot of its type (beams: of their axis, once both supporting column
    slots are filled), so the agent also chooses, implicitly, which slot each component fills.

    The 16 benchmark settings combine four structures (Env1: col2 prebuilt + col3 + beam1; Env2: two columns
    and a beam; Env3: four columns and four beams; Env4: six columns and seven beams) with four scenarios
    (S1 random layout, own targets; S2 fixed layout, interchangeable targets; S3 random layout,
    interchangeable; S4 fixed layout, interchangeable, with obstacles that block and show). Custom scenarios
    come from YAML files (:func:`bimrobot.assembly.scenario.load_scenario`).

    ## Action Space

    ``Discrete(6)``: translate the current component by one cell.

    | action | move | thesis name |
    |---|---|---|
    | 0 | x - 1 | forward |
    | 1 | y - 1 | left |
    | 2 | x + 1 | back |
    | 3 | y + 1 | right |
    | 4 | z + 1 | up |
    | 5 | z - 1 | down |

    A move is *blocked* (nothing moves, the step still costs, ``info["blocked"] = True``) when a cell it
    would occupy is outside the grid, below z = 1, or occupied by another component (waiting or placed), a
    foundation or an obstacle. Target cells are free space. ``info["action_mask"]`` (bool, shape (6,)) is
    True for the moves that would not be blocked.

    ## Observation Space

    ``obs_mode="thesis"`` (default): ``Box(0, high, (W, L, 7), int8)`` over the (x, y) columns of the grid:

    | channel | value at (x, y) | bounds |
    |---|---|---|
    | 0 | 1 where a free (unfilled) target cell lies above (x, y) | 0..1 |
    | 1 | top z of waiting components | 0..H-1 |
    | 2 | top z of the current component | 0..H-1 |
    | 3 | top z of free target cells | 0..H-1 |
    | 4 | 1 on the current component's cells once more than ``epsilon`` steps were spent on it | 0..1 |
    | 5 | number of standing components (prebuilt included), on the cells of placed components | 0..n |
    | 6 | top z of obstacles | 0..H-1 |

    ``obs_mode="voxels"``: ``Box(0, 7, (W, L, H), int8)``, one code per cell: 0 empty, 1 ground,
    2 foundation, 3 obstacle, 4 waiting component, 5 current component, 6 placed component, 7 free target.

    ## Rewards

    Thesis eq. 6.1-6.2 with ``r0 = -1`` and ``epsilon = 15``. Each step on the current component costs
    ``r0 / c`` where ``c`` is its serial number among the handled components (1 for the first); from its
    16th step on (``epsilon + 1``), ``2 * r0 / c``. Blocked steps count. The step that places a component
    pays ``+k`` instead, k being the number of components standing after it (prebuilt included); placing
    the last one pays ``+k + 10``. Example, E2S2's optimum: ``8 * -1 + 1 + 13 * -1/2 + 2 + 10 * -1/3 + 3 + 10
    = -1.83``. A policy that never places anything earns -185 in Env1/2, -585 in Env3, -1185 in Env4.

    ## Starting State

    Fixed layouts (S2, S4) always start the same; Env1's prebuilt column stands on (9, 9) or (9, 13), 50/50
    (S1: always (9, 9)). Random layouts (S1, S3) put every component flat at z = 1 in the yard, along x or y,
    without overlaps, drawn from the env's ``np_random``: ``reset(seed=s)`` reproduces the layout.

    ## Episode End

    1. Termination: every component is placed.
    2. Truncation: the time limit (100 steps for Env1/Env2, 300 for Env3, 600 for Env4), applied by
       Gymnasium's ``TimeLimit`` wrapper of the registered ids (the unwrapped env never truncates).

    ## Arguments

    ```python
    import gymnasium as gym
    import bimrobot.assembly
    env = gym.make("bimrobot/Assembly-E2S2-v0", render_mode="rgb_array", obs_mode="thesis")
    # or any setting / custom scenario: bimrobot.assembly.make_env("E4S3") / AssemblyEnv(scenario=load_scenario(path))
    ```

    ``r0``, ``epsilon`` and ``completion_bonus`` override the scenario's reward constants.

    ## Version History

    * v0: first release; fixes the reference implementation's bugs listed in the specification (obstacles
      that block and show, interchangeable targets everywhere, seeded non-overlapping layouts, no state
      leaking between episodes, terminated/truncated split, true observation bounds).
    """

    metadata = {"render_modes": ["rgb_array", "ansi", "human"], "render_fps": 4}

    def __init__(
        self,
        setting: str | None = "E2S2",
        scenario: Scenario | None = None,
        obs_mode: str = "thesis",
        render_mode: str | None = None,
        r0: float | None = None,
        epsilon: int | None = None,
        completion_bonus: float | None = None,
    ):
        if scenario is None:
            scenario = benchmark_scenario(setting)
        if obs_mode not in ("thesis", "voxels"):
            raise InputError(f"obs_mode must be 'thesis' or 'voxels', got {obs_mode!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise InputError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.scenario = scenario
        self.obs_mode = obs_mode
        self.render_mode = render_mode
        reward = scenario.reward
        self.r0, self.epsilon, self.completion_bonus = reward_constants(reward, r0, epsilon, completion_bonus)
        cs = self._cs = compile_scenario(scenario)
        W, L, H = scenario.grid
        self.action_space = spaces.Discrete(6)
        if obs_mode == "thesis":
            high = np.zeros((W, L, N_CHANNELS), np.int8)
            high[..., [0, 4]] = 1
            high[..., [1, 2, 3, 6]] = H - 1
            high[..., 5] = cs.n_total
            self.observation_space = spaces.Box(np.zeros_like(high), high, dtype=np.int8)
        else:
            self.observation_space = spaces.Box(0, FREE_TARGET, (W, L, H), dtype=np.int8)
        # flat-index change of each action (cells are flattened as (x * L + y) * H + z)
        self._delta = [(dx * L + dy) * H + dz for dx, dy, dz in MOVES]
        self._renderer = None
        self._obs = np.zeros((W, L, N_CHANNELS), np.int8)
        self._obs_flat = self._obs.reshape(-1)
        self._done = True
        self._started = False

    # ----------------------------------------------------------------------------------------- API

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        cs = self._cs
        prebuilt = sample_prebuilt_slots(cs, self.np_random)
        starts = cs.fixed_starts if cs.fixed_starts is not None else sample_layout(cs, self.np_random)
        self._start_state(tuple(starts), tuple(prebuilt), placed=(), current=0, corner=None, steps=0, elapsed=0)
        return self._observation(), self._info(False, None)

    def step(self, action):
        a = check_action(action)
        if not self._started:
            raise gym.error.ResetNeeded("call reset() before step()")
        if self._done:  # stepping a finished episode changes nothing (reset to start another)
            return self._observation(), 0.0, True, False, self._info(False, None)
        mask = self._mask
        self._elapsed += 1
        self._steps += 1
        self._last_placed = placed_id = None
        if not mask[a]:
            blocked = True
            if self._steps == self.epsilon + 1:  # channel 4 switches on even when nothing moves
                self._draw_current_obs()
        else:
            blocked = False
            dx, dy, dz = MOVES[a]
            self._clear_current_obs()
            self._x += dx
            self._y += dy
            self._z += dz
            self._p += self._delta[a]
            target = self._arrival.get(self._p)
            if target is not None and self._eligible(target):
                placed_id = self._place(target)
            else:
                self._draw_current_obs()
                self._mask = self._mask_at()
        if placed_id is not None:
            reward = float(self._k)
            if self._done:
                reward += self.completion_bonus
        else:
            reward = self._step_cost * (2.0 if self._steps > self.epsilon else 1.0)
        if self.render_mode == "human":
            self.render()
        return self._observation(), reward, self._done, False, self._info(blocked, placed_id)

    def action_masks(self) -> np.ndarray:
        """The moves that would not be blocked (for sb3-contrib's MaskablePPO)."""
        return np.array(self._mask if not self._done else (False,) * 6, dtype=bool)

    def snapshot(self) -> AssemblyState:
        """The episode's state, for the planner."""
        corner = None if self._done else (self._x, self._y, self._z)
        return AssemblyState(
            self._cs, self._starts, self._prebuilt, tuple(self._placed), self._cur, corner, self._steps, self._elapsed
        )

    def restore(self, state: AssemblyState) -> None:
        """Continue from a snapshot taken on an env of the same scenario."""
        if state.compiled.scenario != self.scenario:
            raise InputError("the snapshot belongs to another scenario")
        self._start_state(
            state.starts, state.prebuilt_slots, state.placed, state.current, state.corner, state.steps, state.elapsed
        )

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; use render_mode='rgb_array', 'ansi' or 'human'")
            return None
        if self.render_mode == "ansi":
            return render_ansi(self.view())
        if self._renderer is None:
            self._renderer = Renderer(self.scenario)
        frame = self._renderer.draw(self.view())
        if self.render_mode == "human":
            self._renderer.show(frame)
            return None
        return frame

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # ------------------------------------------------------------------------------ read-only views

    @property
    def current_component(self) -> str | None:
        """Id of the component being moved (None once all are placed)."""
        return None if self._done else self.scenario.handled[self._cur].id

    def component_cells(self) -> dict[str, tuple[str, list[tuple[int, int, int]]]]:
        """Every component's state ('waiting', 'current', 'placed', 'prebuilt') and cells, for renderers."""
        cs, sc = self._cs, self.scenario
        out = {}
        for comp, slot in zip(sc.prebuilt, self._prebuilt):
            out[comp.id] = ("prebuilt", [cs.unflat(f) for f in cs.target_cells[slot]])
        placed = dict(self._placed)
        for i, comp in enumerate(sc.handled):
            if i in placed:
                out[comp.id] = ("placed", [cs.unflat(f) for f in cs.target_cells[placed[i]]])
            elif i == self._cur and not self._done:
                out[comp.id] = ("current", [cs.unflat(self._p + o) for o in self._offsets])
            else:
                out[comp.id] = ("waiting", run_cells(*self._starts[i]))
        return out

    def filled_targets(self) -> list[bool]:
        return list(self._filled)

    def view(self) -> EpisodeView:
        """This moment of the episode, as the renderers draw it (grid cells, z up)."""
        current = self.current_component
        return EpisodeView(
            scenario=self.scenario, components=self.component_cells(), filled_targets=self.filled_targets(),
            current=current, arrived=self.last_placed,
            start_cells=None if current is None else run_cells(*self._starts[self._cur]),
            elapsed=self._elapsed, steps=self._steps, standing=self._k, total=self._cs.n_total,
        )

    @property
    def last_placed(self) -> str | None:
        """Id of the component placed by the latest step (the thesis' 'arrived', drawn green)."""
        return self._last_placed

    # ----------------------------------------------------------------------------------- internals

    def _start_state(self, starts, prebuilt, placed, current, corner, steps, elapsed) -> None:
        cs = self._cs
        self._started = True
        self._starts = starts
        self._prebuilt = prebuilt
        self._placed = list(placed)
        self._filled = [False] * cs.n_target
        occ = bytearray(cs.static_blocked.tobytes())
        for slot in prebuilt:
            self._filled[slot] = True
            for f in cs.target_cells[slot]:
                occ[f] = 1
        for _, slot in placed:
            self._filled[slot] = True
            for f in cs.target_cells[slot]:
                occ[f] = 1
        self._waiting_cells = []
        for i, start in enumerate(starts):
            cells = [cs.flat(*c) for c in run_cells(*start)]
            self._waiting_cells.append(cells)
            if i > current:
                for f in cells:
                    occ[f] = 1
        self._occ = occ
        self._k = len(prebuilt) + len(placed)
        self._elapsed = elapsed
        self._last_placed = None
        self._cur = current
        self._done = current >= cs.n_comp
        if not self._done:
            self._become_current(current, corner, steps)
        self._refresh_static_obs()
        if not self._done:
            self._draw_current_obs()

    def _become_current(self, i: int, corner=None, steps: int = 0) -> None:
        cs = self._cs
        comp = self.scenario.handled[i]
        for f in self._waiting_cells[i]:
            self._occ[f] = 0
        if corner is None:
            pose = lifted_pose(self.scenario, comp, self._starts[i], _BlockedView(self._occ, cs))
            if pose is None:
                raise InputError(f"{self.scenario.source}: components.{comp.id}: the crane cannot lift it free of other objects")
            corner = pose[0]
        self._cur = i
        self._steps = steps
        self._step_cost = self.r0 / (i + 1)
        self._x, self._y, self._z = corner
        self._p = cs.flat(*corner)
        axis, n = cs.comp_axis[i], cs.comp_len[i]
        self._axis, self._len = axis, n
        self._offsets = [k * cs.stride(axis) for k in range(n)]
        self._ext = [n if a == axis else 1 for a in range(3)]
        self._arrival = cs.comp_arrival[i]
        self._mask_cache: dict[int, tuple[bool, ...]] = {}
        self._mask = self._mask_at()
        ch = N_CHANNELS
        if axis == 2:
            self._fp_offsets = [0]
            self._top_offset = n - 1
        else:
            step = cs.L * ch if axis == 0 else ch
            self._fp_offsets = [k * step for k in range(n)]
            self._top_offset = 0

    def _mask_at(self) -> tuple[bool, ...]:
        mask = self._mask_cache.get(self._p)
        if mask is None:
            mask = tuple(self._free(k) for k in range(6))
            self._mask_cache[self._p] = mask
        return mask

    def _free(self, a: int) -> bool:
        cs = self._cs
        dx, dy, dz = MOVES[a]
        x, y, z = self._x + dx, self._y + dy, self._z + dz
        ex, ey, ez = self._ext
        if x < 0 or y < 0 or z < 1 or x + ex > cs.W or y + ey > cs.L or z + ez > cs.H:
            return False
        p = self._p + self._delta[a]
        occ = self._occ
        for o in self._offsets:
            if occ[p + o]:
                return False
        return True

    def _eligible(self, target: int) -> bool:
        if self._filled[target]:
            return False
        for s in self._cs.target_supports[target]:
            if not self._filled[s]:
                return False
        return True

    def _place(self, target: int) -> str:
        cs = self._cs
        for f in cs.target_cells[target]:
            self._occ[f] = 1
        self._filled[target] = True
        self._placed.append((self._cur, target))
        self._k += 1
        placed_id = self.scenario.handled[self._cur].id
        nxt = self._cur + 1
        if nxt >= cs.n_comp:
            self._done = True
            self._cur = nxt
        else:
            self._become_current(nxt)
        self._refresh_static_obs()
        if not self._done:
            self._draw_current_obs()
        self._last_placed = placed_id
        return placed_id

    # observation ------------------------------------------------------------------------------------

    def _refresh_static_obs(self) -> None:
        """Recompute every channel but the current component's (after a reset, pick-up or placement)."""
        cs = self._cs
        obs = self._obs
        obs[...] = 0
        free = np.array([not f for f in self._filled])
        if free.any():
            obs[..., 0] = cs.target_fp[free].any(axis=0)
            obs[..., 3] = cs.target_top[free].max(axis=0)
        waiting = obs[..., 1]
        for i in range(self._cur + 1, cs.n_comp):
            for f in self._waiting_cells[i]:
                x, y, z = cs.unflat(f)
                if z > waiting[x, y]:
                    waiting[x, y] = z
        filled = ~free
        if filled.any():
            obs[..., 5] = cs.target_fp[filled].any(axis=0) * self._k
        obs[..., 6] = cs.obstacle_top

    def _clear_current_obs(self) -> None:
        base = (self._x * self._cs.L + self._y) * N_CHANNELS
        flat = self._obs_flat
        for o in self._fp_offsets:
            flat[base + o + 2] = 0
            flat[base + o + 4] = 0

    def _draw_current_obs(self) -> None:
        base = (self._x * self._cs.L + self._y) * N_CHANNELS
        flat = self._obs_flat
        top = self._z + self._top_offset
        late = 1 if self._steps > self.epsilon else 0
        for o in self._fp_offsets:
            flat[base + o + 2] = top
            flat[base + o + 4] = late

    def _observation(self) -> np.ndarray:
        if self.obs_mode == "thesis":
            return self._obs.copy()
        return self._voxels()

    def _voxels(self) -> np.ndarray:
        cs = self._cs
        vox = np.zeros((cs.W, cs.L, cs.H), np.int8)
        vox[:, :, 0] = GROUND
        for x, y in self.scenario.foundations:
            vox[x, y, 0] = FOUNDATION
        flat = vox.reshape(-1)
        obstacle = np.frombuffer(cs.static_blocked.tobytes(), np.uint8).astype(bool)
        obstacle[:: cs.H] = False
        flat[obstacle] = OBSTACLE
        for t, filled in enumerate(self._filled):
            flat[cs.target_cells[t]] = PLACED if filled else FREE_TARGET
        for i in range(self._cur + 1, cs.n_comp):
            flat[self._waiting_cells[i]] = WAITING
        if not self._done:
            flat[[self._p + o for o in self._offsets]] = CURRENT
        return vox

    def _info(self, blocked: bool, placed_id: str | None) -> dict[str, Any]:
        return {
            "action_mask": np.array(self._mask if not self._done else (False,) * 6, dtype=bool),
            "blocked": blocked,
            "placed": placed_id,
            "standing": self._k,
            "steps_on_component": self._steps if not self._done else 0,
        }


class _BlockedView:
    """``cell in view`` for the occupancy bytearray (used by the pick-up search)."""

    def __init__(self, occ: bytearray, cs: CompiledScenario):
        self.occ, self.cs = occ, cs

    def __contains__(self, cell) -> bool:
        return bool(self.occ[self.cs.flat(*cell)])
