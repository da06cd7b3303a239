"""AssemblyEnv: Gymnasium compliance, the spec's dynamics, rewards and observation channels."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import bimrobot.assembly as assembly
from bimrobot.assembly.env import CURRENT, FREE_TARGET, OBSTACLE, PLACED, WAITING, AssemblyEnv
from bimrobot.core.errors import InputError

UP, DOWN = 4, 5
X_MINUS, Y_MINUS, X_PLUS, Y_PLUS = 0, 1, 2, 3


@pytest.mark.parametrize("setting", assembly.SETTINGS)
def test_check_env_passes(setting):
    env = assembly.make_env(setting)
    check_env(env.unwrapped, skip_render_check=True)
    assert env.spec.id == f"bimrobot/Assembly-{setting}-v0"
    assert env.spec.max_episode_steps == {"E1": 100, "E2": 100, "E3": 300, "E4": 600}[setting[:2]]


def test_observation_bounds_are_true_bounds():
    env = AssemblyEnv("E4S4")
    space = env.observation_space
    assert space.shape == (15, 15, 7) and space.dtype == np.int8
    assert space.high[0, 0].tolist() == [1, 8, 8, 8, 1, 13, 8]
    assert (space.low == 0).all()


@pytest.mark.parametrize("setting,expected", [("E1S1", -185.0), ("E2S4", -185.0), ("E3S3", -585.0), ("E4S2", -1185.0)])
def test_never_placing_policy_earns_the_spec_values(setting, expected):
    env = assembly.make_env(setting)
    env.reset(seed=3)
    total, steps = 0.0, 0
    terminated = truncated = False
    while not (terminated or truncated):
        # up, then down: the component hovers and never reaches a slot
        _, reward, terminated, truncated, info = env.step(UP if steps % 2 == 0 else DOWN)
        total += reward
        steps += 1
    assert truncated and not terminated
    assert total == pytest.approx(expected)


def test_reset_seed_reproduces_layouts_and_nothing_leaks():
    env = assembly.make_env("E4S3")
    first, _ = env.reset(seed=11)
    other, _ = env.reset(seed=12)
    assert not np.array_equal(first, other)
    for _ in range(40):
        env.step(X_PLUS)
    again, info = env.reset(seed=11)
    np.testing.assert_array_equal(first, again)
    assert info["steps_on_component"] == 0 and info["standing"] == 0
    # the time limit restarts too: 600 more steps are allowed
    truncated = False
    for step in range(600):
        _, _, _, truncated, _ = env.step(UP if step % 2 == 0 else DOWN)
        assert truncated == (step == 599)


def test_random_layouts_lie_flat_in_the_yard_without_overlaps():
    env = AssemblyEnv("E4S1")
    for seed in range(30):
        env.reset(seed=seed)
        cells = [cell for cid, (state, cs) in env.component_cells().items() if state == "waiting" for cell in cs]
        # col2 is current; 5 columns x 4 cells + 7 beams x 3 cells wait
        assert len(cells) == len(set(cells)) == 5 * 4 + 7 * 3
        assert all(z == 1 and 0 <= x <= 11 and 0 <= y <= 7 for x, y, z in cells)


def test_column_pick_up_and_blocked_moves():
    env = AssemblyEnv("E2S2")
    obs, info = env.reset(seed=0)
    state, cells = env.component_cells()["col2"]
    assert state == "current" and cells == [(7, 3, 2), (7, 3, 3), (7, 3, 4), (7, 3, 5)]
    assert obs[7, 3, 2] == 5  # channel 2: top z of the current component
    assert obs[7, 2, 1] == 1 and obs[4, 4, 1] == 1  # channel 1: waiting col3 and beam1 at z = 1
    assert info["action_mask"].all()  # nothing around it; its own lying cells are free now
    obs, reward, _, _, info = env.step(DOWN)
    assert not info["blocked"] and reward == -1.0 and obs[7, 3, 2] == 4
    assert not info["action_mask"][DOWN]  # the ground is below
    cells = env.component_cells()["col2"][1]
    obs2, reward, terminated, truncated, info = env.step(DOWN)
    assert info["blocked"] and reward == -1.0
    np.testing.assert_array_equal(obs, obs2)
    assert env.component_cells()["col2"][1] == cells
    # a waiting component blocks too: col3 lies at (4..7, 2, 1)
    env.step(Y_MINUS)
    _, _, _, _, info = env.step(Y_MINUS)
    assert info["blocked"]


def test_beam_turns_onto_its_target_axis_at_pick_up():
    env = AssemblyEnv("E2S2")
    env.reset(seed=0)
    env.restore(_with_current(env, 2))
    state, cells = env.component_cells()["beam1"]
    # lying (4,4)->(6,4) along x; centre (5,4); target beam1 runs along y at z = 4
    assert state == "current" and cells == [(5, 3, 4), (5, 4, 4), (5, 5, 4)]


def _with_current(env, index):
    """A snapshot in which every component before ``index`` stands on its own slot."""
    from dataclasses import replace

    snap = env.snapshot()
    targets = [t.id for t in env.scenario.targets]
    placed = tuple((i, targets.index(env.scenario.handled[i].target)) for i in range(index))
    return replace(snap, placed=placed, current=index, corner=None, steps=0)


def test_epsilon_doubles_the_step_cost_and_sets_channel_4():
    env = AssemblyEnv("E2S2")
    env.reset(seed=0)
    rewards, late = [], []
    for step in range(17):
        obs, reward, *_ = env.step(UP if step % 2 == 0 else DOWN)
        rewards.append(reward)
        late.append(int(obs[7, 3, 4]))
    assert rewards == [-1.0] * 15 + [-2.0] * 2
    assert late == [0] * 15 + [1] * 2


def test_placement_rewards_serial_numbers_and_channel_5():
    env = assembly.make_env("E2S2")
    env.reset(seed=0)
    # col2 stands at (7,3) z 2..5: 2 x +1, 6 y +1, 1 z -1 onto slot (9,9)
    rewards = [env.step(a)[1] for a in [X_PLUS] * 2 + [Y_PLUS] * 6]
    obs, reward, terminated, _, info = env.step(DOWN)
    assert rewards == [-1.0] * 8 and reward == 1.0 and info["placed"] == "col2" and not terminated
    assert obs[9, 9, 5] == 1 and obs[9, 9, 0] == 0  # the slot is filled: no free target above (9, 9)
    assert obs[9, 13, 0] == 1 and obs[9, 13, 3] == 4  # col3's slot still free
    # col3 is now current with serial number 2: each step costs -1/2
    _, reward, *_ = env.step(Y_PLUS)
    assert reward == -0.5


def test_env1_prebuilt_column_slot():
    s1 = AssemblyEnv("E1S1")
    s2 = AssemblyEnv("E1S2")
    slots_s1, slots_s2 = set(), []
    for seed in range(60):
        s1.reset(seed=seed)
        slots_s1.add(tuple(s1.component_cells()["col2"][1][0]))
        s2.reset(seed=seed)
        slots_s2.append(tuple(s2.component_cells()["col2"][1][0]))
    assert slots_s1 == {(9, 9, 1)}
    share = slots_s2.count((9, 13, 1)) / len(slots_s2)
    assert set(slots_s2) == {(9, 9, 1), (9, 13, 1)} and 0.3 < share < 0.7


def test_s4_obstacles_block_and_show():
    env = AssemblyEnv("E2S4")
    obs, info = env.reset(seed=0)
    assert obs[1, 5, 6] == 6 and obs[9, 5, 6] == 4 and obs[0, 0, 6] == 0
    # col2 stands at (7,3); moving it to y = 5 puts it at x 7 ... outside the first obstacle (x 1..6)
    # walk x-1 toward the obstacle at x <= 6, y >= 5: at (6, 4) a y+1 move must be blocked
    env.step(X_MINUS)
    _, _, _, _, info = env.step(Y_PLUS)
    assert not info["blocked"]  # (6, 4) is free
    _, _, _, _, info = env.step(Y_PLUS)
    assert info["blocked"]  # (6, 5, 2..5) is inside x 1..6, y 5..14, z 1..6


def test_action_mask_matches_blocking():
    env = assembly.make_env("E3S4")
    rng = np.random.default_rng(0)
    obs, info = env.reset(seed=0)
    for _ in range(300):
        action = int(rng.integers(6))
        mask = info["action_mask"]
        obs, _, terminated, truncated, info = env.step(action)
        if not info["placed"]:
            assert info["blocked"] == (not mask[action])
        if terminated or truncated:
            break
    np.testing.assert_array_equal(env.unwrapped.action_masks(), info["action_mask"])


def test_voxel_observation_codes():
    env = AssemblyEnv("E2S4", obs_mode="voxels")
    obs, _ = env.reset(seed=0)
    assert obs.shape == (15, 15, 9) and env.observation_space.contains(obs)
    assert (obs[7, 3, 2:6] == CURRENT).all()
    assert obs[4, 4, 1] == WAITING and obs[9, 9, 1] == FREE_TARGET and obs[1, 5, 1] == OBSTACLE
    check_env(env, skip_render_check=True)
    env.reset(seed=0)
    for a in [Y_PLUS] * 6 + [X_PLUS] * 2 + [DOWN]:  # x = 9 first would cross the obstacle x 9..14, y 5..7
        obs, *_ = env.step(a)
    assert (obs[9, 9, 1:5] == PLACED).all()


def test_render_modes():
    env = AssemblyEnv("E2S2", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (480, 640, 3) and frame.dtype == np.uint8
    colours = {tuple(c) for c in frame.reshape(-1, 3)[::7]}
    assert (0x2F, 0x6F, 0xDB) in colours  # the moving component, blue
    assert (0xF3, 0x9C, 0x34) in colours  # waiting, orange
    text = AssemblyEnv("E2S4", render_mode="ansi")
    text.reset(seed=0)
    out = text.render()
    assert "moving col2" in out and out.count("\n") == 18 and "X" in out
    with pytest.raises(InputError, match="render_mode"):
        AssemblyEnv("E2S2", render_mode="video")


def test_check_env_including_rendering():
    # through gym.make the checker also tries the other render modes (human draws nothing without a display)
    check_env(assembly.make_env("E2S4", render_mode="rgb_array").unwrapped)



@pytest.mark.parametrize("action", [6, -1, 2.0, "up", None, True, np.array([1, 2]), np.int64(99)])
def test_an_action_outside_the_action_space_is_one_clear_sentence(action):
    """Not an IndexError (6), not a silent wrap-around (-1 used to move as action 5), not a TypeError."""
    env = assembly.make_env("E2S2")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"is outside the action space Discrete\(6\): give an integer 0\.\.5") as error:
        env.step(action)
    assert isinstance(error.value, InputError) and "\n" not in str(error.value)
    # the refused step changed nothing: the next move gives what it gives right after a reset
    reference = assembly.make_env("E2S2")
    reference.reset(seed=0)
    expected = reference.step(X_PLUS)
    observed = env.step(X_PLUS)
    np.testing.assert_array_equal(observed[0], expected[0])
    assert observed[1] == expected[1]


def test_numpy_integers_and_one_element_arrays_are_actions():
    """What a policy's predict() returns is accepted as it is."""
    rewards = []
    for action in (X_PLUS, np.int64(X_PLUS), np.array(X_PLUS), np.array([X_PLUS])):
        env = assembly.make_env("E2S2")
        env.reset(seed=0)
        rewards.append(env.step(action)[1])
    assert rewards == [-1.0] * 4


@pytest.mark.parametrize(
    "kwargs,message",
    [
        ({"r0": float("nan")}, "r0 must be a finite number"),
        ({"r0": 1.0}, r"r0 must be >= -1e\+06 and < 0"),
        ({"epsilon": -2}, "epsilon must be a whole number of steps from 0 to 100000"),
        ({"completion_bonus": float("inf")}, "completion_bonus must be a finite number"),
    ],
)
def test_impossible_reward_constants_are_refused(kwargs, message):
    from bimrobot.assembly.vector import BatchedAssemblySim

    for make in (AssemblyEnv, BatchedAssemblySim):
        with pytest.raises(InputError, match=message):
            make(**kwargs)
