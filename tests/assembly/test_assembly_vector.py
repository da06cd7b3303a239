"""The batched simulator equals N single envs; its Gymnasium and Stable-Baselines3 faces."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import bimrobot.assembly as assembly
from bimrobot.assembly.env import AssemblyEnv
from bimrobot.assembly.planner import plan
from bimrobot.core.errors import InputError


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """bimrobot.assembly.vector with numba (about 0.6 s of imports), imported when these tests run, not at
    collection."""
    global vector, AssemblySB3VecEnv, AssemblyVectorEnv, BatchedAssemblySim
    import bimrobot.assembly.vector as vector
    from bimrobot.assembly.vector import AssemblySB3VecEnv, AssemblyVectorEnv, BatchedAssemblySim


INVERSE = {0: 2, 1: 3, 2: 0, 3: 1, 4: 5, 5: 4}


class GuidedRandomPolicy:
    """Mostly the planner's actions with random detours, so that episodes place components and end."""

    def __init__(self, env, rng: np.random.Generator, explore: float):
        self.env, self.rng, self.explore = env, rng, explore
        self.queue: list[int] = []

    def __call__(self, info) -> int:
        if self.rng.random() < self.explore:
            action = int(self.rng.integers(6))
            if info["action_mask"][action]:
                self.queue.insert(0, INVERSE[action])
            return action
        if not self.queue:
            self.queue = plan(self.env.unwrapped).actions
        return self.queue.pop(0)

    def replan(self) -> None:
        self.queue = []


def assert_same_as_single_envs(setting: str, num_envs: int, steps: int, seed: int, explore: float) -> tuple[int, int]:
    """Step a batch and num_envs registered envs (seeded seed + i) with the same actions; compare all."""
    sim = BatchedAssemblySim(setting, num_envs, seed=seed)
    envs = [assembly.make_env(setting) for _ in range(num_envs)]
    batch_obs, batch_info = sim.reset()
    infos = []
    for i, env in enumerate(envs):
        obs, info = env.reset(seed=seed + i)
        np.testing.assert_array_equal(batch_obs[i], obs)
        np.testing.assert_array_equal(batch_info["action_mask"][i], info["action_mask"])
        infos.append(info)
    rng = np.random.default_rng(seed)
    policies = [GuidedRandomPolicy(env, rng, explore) for env in envs]
    episodes = placements = 0
    for t in range(steps):
        actions = np.array([policy(info) for policy, info in zip(policies, infos)])
        obs_b, rew_b, term_b, trunc_b, info_b = sim.step(actions)
        for i, env in enumerate(envs):
            obs, reward, terminated, truncated, info = env.step(actions[i])
            where = f"{setting} step {t} env {i}"
            assert reward == pytest.approx(rew_b[i], abs=1e-12), where
            assert (terminated, truncated) == (term_b[i], trunc_b[i]), where
            assert bool(info["placed"]) == info_b["placed"][i], where
            assert info["blocked"] == info_b["blocked"][i], where
            if info["placed"]:
                policies[i].replan()
                placements += 1
            if terminated or truncated:
                np.testing.assert_array_equal(info_b["final_observation"][i], obs, err_msg=where)
                obs, info = env.reset()
                policies[i].replan()
                episodes += 1
            np.testing.assert_array_equal(obs_b[i], obs, err_msg=where)
            np.testing.assert_array_equal(info_b["action_mask"][i], info["action_mask"], err_msg=where)
            infos[i] = info
    return episodes, placements


@pytest.mark.parametrize("setting", assembly.SETTINGS)
def test_batched_equals_single_envs_on_random_actions(setting):
    assert_same_as_single_envs(setting, num_envs=3, steps=220, seed=7, explore=1.0)


@pytest.mark.parametrize("setting", ["E1S1", "E1S2", "E1S3", "E2S4", "E3S1", "E3S3", "E4S3", "E4S4"])
def test_batched_equals_single_envs_through_placements_and_episode_ends(setting):
    episodes, placements = assert_same_as_single_envs(setting, num_envs=3, steps=400, seed=3, explore=0.3)
    assert episodes >= 3 and placements >= 9  # every env places components and ends episodes


@pytest.mark.parametrize("setting", ["E1S3", "E3S1", "E4S3"])
def test_batched_random_layouts_draw_exactly_what_the_single_env_draws(setting, monkeypatch):
    """Each env's layout, and its generator's state after the reset, equal the single env's: also where a
    layout attempt runs into a second block of uniforms (status 1) or starts over because a component
    fits nowhere (status 2), both frequent in Env4's crowded yard."""
    statuses: list[int] = []
    kernel = vector._k_layouts

    def spy(block, rows, status, *rest):
        kernel(block, rows, status, *rest)
        statuses.extend(status.tolist())

    monkeypatch.setattr(vector, "_k_layouts", spy)
    n = 60
    sim = BatchedAssemblySim(setting, n, seed=100)
    sim.reset()
    sim.reset()  # the second episodes: each generator carries on
    env = AssemblyEnv(setting)
    for i in range(n):
        env.reset(seed=100 + i)
        env.reset()
        assert sim.starts[i].tolist() == [[list(node) for node in start] for start in env.snapshot().starts]
        assert sim.rngs[i].random() == env.np_random.random()  # the same number of uniforms consumed
    if setting == "E4S3":
        assert {1, 2} <= set(statuses)


def test_batched_reward_accounting_matches_the_spec():
    sim = BatchedAssemblySim("E3S3", 8, seed=0)
    sim.reset()
    totals = np.zeros(8)
    for _ in range(300):
        _, reward, terminated, truncated, _ = sim.step(np.where(np.arange(8) % 2 == 0, 4, 5) * 0 + 4)
        totals += reward
    # always up: never placed, truncated at 300 steps: 15 x -1 + 285 x -2
    assert truncated.all() and not terminated.any()
    np.testing.assert_allclose(totals, -585.0)


def test_final_observation_holds_the_ended_envs_only():
    """An episode's last observation is in its row of info["final_observation"]; the rows of the envs
    that go on are zeros (their observation is the returned one)."""
    sim = BatchedAssemblySim("E2S2", 2, seed=0)
    sim.reset()
    single = assembly.AssemblyEnv("E2S2")
    single.reset(seed=0)
    actions = plan(single).actions
    for t, action in enumerate(actions):
        obs, _, terminated, _, info = sim.step(np.array([action, 4 if t % 2 == 0 else 5]))
        assert terminated.tolist() == [t == len(actions) - 1, False]
    assert info["_final_observation"].tolist() == [True, False]
    assert info["final_observation"][0, :, :, 5].max() == 3  # the finished structure: 3 components standing
    assert not info["final_observation"][1].any() and obs[1, :, :, 2].any()  # env 1 still moves its column


def test_gymnasium_vector_env():
    import gymnasium as gym

    envs = AssemblyVectorEnv("E1S2", 4, seed=0)
    assert envs.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    obs, info = envs.reset(seed=0)
    assert obs.shape == (4, 15, 15, 7) and envs.observation_space.contains(obs)
    assert info["action_mask"].shape == (4, 6)
    ended = 0
    for _ in range(100):
        obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
        assert envs.observation_space.contains(obs)
        if (terminated | truncated).any():
            ended += int((terminated | truncated).sum())
            assert "final_obs" in info and info["final_info"]["episode"]["l"].max() == 100
    assert ended == 4  # every env truncated at step 100, reset in the same step


def test_sb3_vec_env_with_monitor_style_infos():
    pytest.importorskip("stable_baselines3")
    venv = AssemblySB3VecEnv("E2S2", 2, seed=0)
    obs = venv.reset()
    assert obs.shape == (2, 15, 15, 7)
    assert venv.action_masks().shape == (2, 6) and venv.action_masks().dtype == bool
    assert len(venv.env_method("action_masks")) == 2
    # env 0 follows the optimal plan, env 1 hovers up and down
    single = assembly.AssemblyEnv("E2S2")
    single.reset(seed=0)
    actions = plan(single).actions
    total = np.zeros(2)
    for t in range(100):
        step_actions = np.array([actions[t] if t < len(actions) else 4, 4 if t % 2 == 0 else 5])
        obs, rewards, dones, infos = venv.step(step_actions)
        total += rewards
        if dones[0] and t == len(actions) - 1:
            assert infos[0]["episode"]["r"] == pytest.approx(-1.8333, abs=1e-3)
            assert infos[0]["episode"]["l"] == 34
            assert infos[0]["TimeLimit.truncated"] is False
            assert infos[0]["terminal_observation"].shape == (15, 15, 7)
    assert dones[1] and infos[1]["TimeLimit.truncated"] is True
    assert infos[1]["episode"]["r"] == pytest.approx(-185.0)


def test_maskable_ppo_runs_on_the_sb3_vec_env():
    pytest.importorskip("sb3_contrib")
    from sb3_contrib import MaskablePPO
    from sb3_contrib.common.maskable.utils import get_action_masks, is_masking_supported

    venv = AssemblySB3VecEnv("E1S1", 4, seed=0)
    assert is_masking_supported(venv)
    venv.reset()
    assert get_action_masks(venv).shape == (4, 6)
    model = MaskablePPO("MlpPolicy", venv, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=128)
    assert model.num_timesteps == 128


def test_bad_arguments():
    with pytest.raises(InputError, match="num_envs"):
        BatchedAssemblySim("E2S2", 0)
    with pytest.raises(InputError, match="obs_mode"):
        BatchedAssemblySim("E2S2", 2, obs_mode="voxels")
    sim = BatchedAssemblySim("E2S2", 2, seed=0)
    sim.reset()
    with pytest.raises(InputError, match="0..5"):
        sim.step(np.array([0, 6]))


@pytest.mark.parametrize(
    "actions,message",
    [
        ([0, 7], r"action 7 of environment 1 is outside the action space Discrete\(6\)"),
        ([-1, 0], r"action -1 of environment 0 is outside the action space"),
        ([0, 1, 2], r"are not 2 integer moves 0\.\.5, one per environment"),
        ([0.0, 1.0], r"are not 2 integer moves 0\.\.5"),
        ("ab", r"are not 2 integer moves"),
        ([[0], [1, 2]], r"are not 2 integer moves"),
    ],
)
def test_batched_actions_outside_the_action_space_are_one_clear_sentence(actions, message):
    """In the batched simulator and both its Gymnasium and SB3 faces: a ValueError naming the action."""
    for env in (BatchedAssemblySim("E2S2", 2, seed=0), AssemblyVectorEnv("E2S2", 2, seed=0)):
        env.reset()
        with pytest.raises(ValueError, match=message) as error:
            env.step(actions)
        assert isinstance(error.value, InputError) and "\n" not in str(error.value)
    sb3 = AssemblySB3VecEnv("E2S2", 2, seed=0)
    sb3.reset()
    with pytest.raises(ValueError, match=message):
        sb3.step(actions)


@pytest.mark.parametrize("num_envs", [0, -3, 10**9, 2.5])
def test_impossible_numbers_of_environments(num_envs):
    with pytest.raises(InputError, match=r"num_envs must be an integer from 1 to 4096"):
        BatchedAssemblySim("E2S2", num_envs)


def test_make_vec_gives_the_batched_simulator():
    import gymnasium as gym

    envs = gym.make_vec("bimrobot/Assembly-E3S1-v0", num_envs=8, seed=5)
    assert isinstance(envs, AssemblyVectorEnv) and envs.sim.time_limit == 300
    obs, _ = envs.reset(seed=5)
    single = assembly.make_env("E3S1")
    first, _ = single.reset(seed=5 + 3)
    np.testing.assert_array_equal(obs[3], first)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    setting=st.sampled_from(["E1S3", "E2S4", "E3S2"]),
    seed=st.integers(0, 10_000),
    actions=st.lists(st.lists(st.integers(0, 5), min_size=2, max_size=2), min_size=1, max_size=150),
)
def test_property_batched_equals_single_envs(setting, seed, actions):
    """Hypothesis: any seed and any action sequence give identical trajectories in the batch."""
    sim = BatchedAssemblySim(setting, 2, seed=seed)
    envs = [assembly.make_env(setting) for _ in range(2)]
    obs_b, _ = sim.reset()
    for i, env in enumerate(envs):
        np.testing.assert_array_equal(obs_b[i], env.reset(seed=seed + i)[0])
    for step_actions in actions:
        obs_b, rew_b, term_b, trunc_b, info_b = sim.step(np.array(step_actions))
        for i, env in enumerate(envs):
            obs, reward, terminated, truncated, info = env.step(step_actions[i])
            if terminated or truncated:
                obs, info = env.reset()
            assert reward == rew_b[i] and terminated == term_b[i] and truncated == trunc_b[i]
            np.testing.assert_array_equal(obs_b[i], obs)
            np.testing.assert_array_equal(info_b["action_mask"][i], info["action_mask"])
