"""Potential-based distance shaping: the potential is minus the Manhattan distance to the nearest eligible slot."""

from __future__ import annotations

import numpy as np
import pytest

from bimrobot.assembly.vector import AssemblySB3VecEnv
from bimrobot.rl.shaping import DistanceShaping

X_PLUS, Y_PLUS, Z_MINUS = 2, 3, 5


def test_potential_and_shaped_reward_on_env2_s2():
    """Env2 S2: col2 is lifted at corner (7, 3, 2); the column slots' corners are (9, 9, 1) and (9, 13, 1),
    9 and 13 cells away (the spec's worked example: 9 moves to slot (9, 9))."""
    venv = DistanceShaping(AssemblySB3VecEnv("E2S2", num_envs=2, seed=0), gamma=0.9, scale=1.0)
    venv.reset()
    assert venv.potential().tolist() == [-9.0, -9.0]
    _, rewards, _, _ = venv.step(np.array([X_PLUS, Z_MINUS]))
    # env reward -1 per step; shaping 0.9 * (-8) - (-9) = +1.8 for both moves towards the slot
    assert rewards == pytest.approx([0.8, 0.8])
    _, rewards, _, _ = venv.step(np.array([0, 0]))  # x-1: back away from the slot, 8 -> 9 cells
    assert rewards == pytest.approx([-1 + 0.9 * -9 + 8, -1 + 0.9 * -9 + 8])


def test_episode_returns_in_infos_stay_unshaped():
    venv = DistanceShaping(AssemblySB3VecEnv("E2S2", num_envs=1, seed=0), gamma=0.9, scale=1.0)
    venv.reset()
    # follow the exact planner's optimal plan to the end of the episode
    from bimrobot.assembly import make_env
    from bimrobot.assembly.planner import plan

    env = make_env("E2S2")
    env.reset(seed=0)
    actions = plan(env.unwrapped).actions
    shaped_total, episode = 0.0, None
    for action in actions:
        _, rewards, dones, infos = venv.step(np.array([action]))
        shaped_total += float(rewards[0])
        if dones[0]:
            episode = infos[0]["episode"]
    assert episode is not None and episode["r"] == pytest.approx(-1.8333, abs=1e-3)  # the spec's optimum
    assert shaped_total != pytest.approx(episode["r"])
