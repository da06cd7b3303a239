"""The ros2 backend against the shipped ROS 2 robot node (real rclpy, Fast DDS over shared memory)."""

from __future__ import annotations

import random
import re
import time

import pytest

from bimrobot.rcan.activities import ActivityKind as K, Pose, RcanActivity
from bimrobot.rcan.generation import load_capabilities
from bimrobot.rcan.node import RcanNode
from bimrobot.rcan.plans import COLUMN_ID, FOOTING_ID, experiment
from bimrobot.rcan.system import run_plan

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module")
def ros2_robots():
    """The shipped robot node in a subprocess, on a random ROS_DOMAIN_ID with shared-memory transport."""
    from bimrobot.rcan.backends import ros2

    ok, why = ros2.ros2_available()
    if not ok:
        pytest.skip(why)
    patch = pytest.MonkeyPatch()
    patch.setenv("ROS_DOMAIN_ID", str(random.randint(1, 200)))
    patch.setenv("FASTDDS_BUILTIN_TRANSPORTS", "SHM")
    before = ros2._fastdds_files()
    try:
        with ros2.robot_node_process():
            yield ros2
    finally:
        ros2.cleanup_fastdds(before)
        patch.undo()


@pytest.fixture(scope="module")
def backend(ros2_robots):
    backend = ros2_robots.Ros2Backend(load_capabilities(), server_timeout_s=20.0)
    yield backend
    backend.close()


@pytest.mark.parametrize("number, component", [(1, COLUMN_ID), (2, COLUMN_ID), (3, FOOTING_ID)])
def test_experiments_over_ros2_match_the_sim_backend(ros2_robots, number, component):
    caps = load_capabilities()
    ros_log, sim_log = [], []
    on_ros = run_plan(experiment(number).activities, caps, backend="ros2", log=ros_log.append)
    run_plan(experiment(number).activities, caps, backend="sim", log=sim_log.append)
    assert on_ros.status == "completed" and on_ros.component_states == {component: "Assembled"}
    # the same interaction, step by step (robot times differ: the robot node's site carries on between
    # experiments, like a real site, while each sim run starts at home)
    untimed = lambda lines: [re.sub(r" \(t [0-9.]+-[0-9.]+ s\)", "", line) for line in lines]  # noqa: E731
    assert [line.replace("backend ros2", "backend sim") for line in untimed(ros_log)] == untimed(sim_log)


def test_feedback_idempotent_goal_and_robot_checks(backend):
    robot_node_state = []
    node = RcanNode("rcan/F.1", RcanActivity("F.1", "COLX", K.MOVE_TO_COMPONENT, Pose(1.0, 2.0, 0.0, 0.5)),
                    "heavy_mobile_manipulator", "ros2")
    first = backend.execute(node, 1, ready_at_s=100.0, feedback=lambda p, phase: robot_node_state.append((p, phase)))
    assert first.success and first.started_s == pytest.approx(100.0)
    assert first.duration_s == pytest.approx(((1 + 5) ** 2 + (2 + 5) ** 2) ** 0.5 / 0.8)  # from home (-5, -5) at 0.8 m/s
    # ROS 2 delivers feedback on its own topic: the last message may land just after the result.
    deadline = time.monotonic() + 5.0
    while len(robot_node_state) < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert [p for p, _ in robot_node_state] == [0.0, 1.0]
    assert backend.execute(node, 1) == first  # the same goal again: the robot node returns its result
    pick = RcanNode("rcan/F.2", RcanActivity("F.2", "COLX", K.PICK_UP, Pose(9.0, 9.0, 0.0)), "heavy_mobile_manipulator", "ros2")
    refused = backend.execute(pick, 1)
    assert not refused.success and "not at the pick up pose of COLX" in refused.message


def test_missing_action_server_is_a_failed_attempt(ros2_robots):
    backend = ros2_robots.Ros2Backend(load_capabilities(), server_timeout_s=1.0)
    try:
        node = RcanNode("rcan/G.1", RcanActivity("G.1", "C", K.INSTALL, Pose(0, 0, 0)), "ghost_robot", "ros2")
        result = backend.execute(node, 1)
    finally:
        backend.close()
    assert not result.success and "no ROS 2 action server /bimrobot/ghost_robot/install" in result.message


def test_cli_experiment_on_ros2_spawns_and_stops_its_robot_node(ros2_robots, tmp_path):
    import os
    import subprocess
    import sys

    before = ros2_robots._fastdds_files()
    env = {**os.environ, "ROS_DOMAIN_ID": str(random.randint(1, 200)), "FASTDDS_BUILTIN_TRANSPORTS": "SHM"}
    run = subprocess.run([sys.executable, "-m", "bimrobot", "rcan", "run", "--experiment", "3", "--backend", "ros2"],
                         capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "[rcan/E3.4] robot husky_ur5 executes 'Transport' of 1kTvXnbbzCWw8lcMd1dR4o" in run.stdout
    assert "== completed: 6/6 activities done; components: 1 Assembled" in run.stdout
    assert ros2_robots._fastdds_files() - before == set()  # the run cleaned up after its robot node
