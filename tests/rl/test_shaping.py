"""Potential-based distance shaping: the potential is minus the distance (shortest unblocked path, or Manhattan)
to the nearest eligible slot."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """numba and torch (about 3 s of imports), imported when these tests run, not at collection."""
    global AssemblySB3VecEnv, DistanceShaping
    from bimrobot.assembly.vector import AssemblySB3VecEnv
    from bimrobot.rl.shaping import DistanceShaping


X_PLUS, Y_PLUS, Z_MINUS = 2, 3, 5


def test_potential_and_shaped_reward_on_env2_s2():
    """Env2 S2: col2 is lifted at corner (7, 3, 2); the column slots' corners are (9, 9, 1) and (9, 13, 1),
    9 and 13 cells away (the spec's worked example: 9 moves to slot (9, 9))."""
    venv = DistanceShaping(AssemblySB3VecEnv("E2S2", num_envs=2, seed=0), scale=0.5, metric="manhattan")
    venv.reset()
    assert venv.potential().tolist() == [-9.0, -9.0]
    _, rewards, _, _ = venv.step(np.array([X_PLUS, Z_MINUS]))
    # env reward -1 per step; shaping +0.5 for a move one cell closer
    assert rewards == pytest.approx([-0.5, -0.5])
    _, rewards, _, _ = venv.step(np.array([0, 0]))  # x-1: back away from the slot, 8 -> 9 cells
    assert rewards == pytest.approx([-1.5, -1.5])


def test_episode_returns_in_infos_stay_unshaped_and_placing_is_never_punished():
    """Along the optimal plan every move is one cell of progress: the shaping adds exactly +1 per action,
    with no penalty when the next component is picked up far from its slot."""
    venv = DistanceShaping(AssemblySB3VecEnv("E2S2", num_envs=1, seed=0), scale=1.0)
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
    assert shaped_total == pytest.approx(episode["r"] + len(actions))


def test_no_shaping_on_a_time_limit_truncation():
    venv = DistanceShaping(AssemblySB3VecEnv("E1S2", num_envs=1, seed=0), scale=1.0)
    venv.reset()
    total, steps = 0.0, 0
    while True:  # shuttle up (away from the slot) and down until the 100-step limit
        _, rewards, dones, infos = venv.step(np.array([4 if steps % 2 == 0 else 5]))
        total, steps = total + float(rewards[0]), steps + 1
        if dones[0]:
            break
    assert infos[0]["TimeLimit.truncated"] and steps == 100 and infos[0]["episode"]["r"] == -185.0
    # 50 moves away (-1 each), 49 back (+1 each); the truncating step's move earns nothing
    assert total == pytest.approx(-185.0 - 1.0)


@pytest.mark.parametrize("setting", [f"E{e}S{s}" for e in range(1, 5) for s in range(1, 5)])
def test_path_potential_is_the_planners_shortest_path(setting):
    """At every reset the path potential is minus the exact planner's breadth-first distance (computed
    forwards from the lifted pose, ours backwards from the slots) to the nearest slot the component may fill."""
    from bimrobot.assembly import make_env
    from bimrobot.assembly.planner import _Search

    envs = 4
    venv = DistanceShaping(AssemblySB3VecEnv(setting, num_envs=envs, seed=100), scale=1.0)
    venv.reset()
    potentials = venv.potential()
    single = make_env(setting).unwrapped
    for i in range(envs):
        single.reset(seed=100 + i)
        state = single.snapshot()
        search = _Search(state, single.r0, single.epsilon, single.completion_bonus)
        filled = frozenset(state.prebuilt_slots)
        occ = search.occupancy(0, filled)
        start = tuple(v + 1 for v in search.start_pose(0, occ, state.corner))
        goals = search.eligible(0, filled)
        dist = search.distances(search.valid_poses(0, occ), start, goals)
        nearest = min(int(dist[cell]) for cell in goals if dist[cell] > 0)
        assert potentials[i] == -nearest, f"{setting} env {i}"


def test_path_potential_sees_the_obstacle_that_manhattan_walks_into():
    """E1S4: col3 is lifted at (7, 2, 2) (cells z 2..5) and its slots lie beyond the obstacle x 9..14, y 5..7,
    z 1..4, so it must pass at x = 7..8. Moving to x = 8 is progress for both potentials; moving on to x = 9
    brings it closer in Manhattan distance but leaves it one move further from the slot (it must come back)."""
    path = DistanceShaping(AssemblySB3VecEnv("E1S4", num_envs=2, seed=0), metric="path")
    manhattan = DistanceShaping(AssemblySB3VecEnv("E1S4", num_envs=2, seed=0), metric="manhattan")
    path.reset(), manhattan.reset()
    assert path.sim.pos.tolist() == [[7, 2, 2], [7, 2, 2]]
    seen = []
    for _ in range(2):
        path.step(np.array([X_PLUS, X_PLUS]))
        manhattan.step(np.array([X_PLUS, X_PLUS]))
        seen.append((path.potential().copy(), manhattan.potential().copy()))
    (path_x8, manhattan_x8), (path_x9, manhattan_x9) = seen
    assert (path_x9 == path_x8 - 1).all()
    assert (manhattan_x9 == manhattan_x8 + 1).all()
