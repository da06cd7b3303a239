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
    before = ros2.fastdds_files()
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
    # ROS 2 delivers feedback on its own topic: the last message may land just after the result (it
    # took over 5 s once, with a MuJoCo run and other tests on both cores)
    deadline = time.monotonic() + 20.0
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

    before = ros2_robots.fastdds_files()
    env = {**os.environ, "ROS_DOMAIN_ID": str(random.randint(1, 200)), "FASTDDS_BUILTIN_TRANSPORTS": "SHM"}
    run = subprocess.run([sys.executable, "-m", "bimrobot", "rcan", "run", "--experiment", "3", "--backend", "ros2"],
                         capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "[rcan/E3.4] robot husky_ur5 executes 'Transport' of 1kTvXnbbzCWw8lcMd1dR4o" in run.stdout
    assert "== completed: 6/6 activities done; components: 1 Assembled" in run.stdout
    # the run cleaned up after its robot node: what is left is in use by a live process (this one)
    assert ros2_robots.stale_fastdds_files(before) == set()


def ros_env(**extra):
    import os

    return {**os.environ, "ROS_DOMAIN_ID": str(random.randint(1, 200)), "FASTDDS_BUILTIN_TRANSPORTS": "SHM", **extra}


def test_a_dead_robot_node_is_detected_and_its_activity_retried_on_another_robot(ros2_robots, tmp_path, monkeypatch):
    """crane_a and crane_b are served by two robot node processes; crane_a's is killed (SIGKILL) while it
    drives: RCAN notices within seconds (no heartbeat) and crane_b does the move."""
    import os
    import signal
    import subprocess
    import sys
    import threading

    from rcan_helpers import two_crane_capabilities, write_capabilities

    env = ros_env()
    for key in ("ROS_DOMAIN_ID", "FASTDDS_BUILTIN_TRANSPORTS"):
        monkeypatch.setenv(key, env[key])
    caps_file = write_capabilities(tmp_path / "caps.yaml")
    before = ros2_robots.fastdds_files()
    nodes = {}
    for robot in ("crane_a", "crane_b"):
        nodes[robot] = subprocess.Popen([sys.executable, "-m", "bimrobot", "rcan", "robot-node", "--capabilities",
                                         str(caps_file), "--robot", robot, "--time-scale", "1"],
                                        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    try:
        for process in nodes.values():
            assert "action servers" in process.stdout.readline()
        lines, killed = [], threading.Event()
        kill_time = []

        def log(line):
            lines.append((time.monotonic(), line))
            if "robot crane_a executes" in line and not killed.is_set():
                killed.set()

                def kill():
                    time.sleep(1.0)  # mid-drive: 12 m at 1 m/s takes 12 s
                    os.kill(nodes["crane_a"].pid, signal.SIGKILL)
                    kill_time.append(time.monotonic())

                threading.Thread(target=kill, daemon=True).start()

        move = RcanActivity("M.1", "C", K.MOVE_TO_COMPONENT, Pose(12.0, 0.0, 0.0), robot="crane_a", frees_robot=True)
        report = run_plan([move], two_crane_capabilities(), backend="ros2", log=log, timeout_s=120,
                          backend_options={"liveness_s": 2.0, "time_scale": 1.0, "server_timeout_s": 5.0})
    finally:
        for process in nodes.values():
            if process.poll() is None:
                process.terminate()
            process.wait(timeout=20)
            process.stdout.close()
        ros2_robots.cleanup_fastdds(before)
    assert report.status == "completed" and report.done == ["M.1"], [line for _, line in lines]
    out_of_service = [t for t, line in lines if "robot crane_a is out of service" in line]
    retried = [t for t, line in lines if "robot crane_b executes 'Move to component'" in line]
    assert out_of_service and retried
    assert retried[0] - kill_time[0] < 10.0  # detected and retried within 10 s of the kill
    print(f"\ndead robot node: detected {out_of_service[0] - kill_time[0]:.1f} s after the kill, "
          f"retried on crane_b after {retried[0] - kill_time[0]:.1f} s")
    # the node died either while driving (no heartbeat) or, on a loaded machine, before it took the goal
    why = [line for _, line in lines if "robot crane_a is out of service" in line]
    assert any("stopped answering" in line or "did not answer" in line for line in why), why


def test_ctrl_c_stops_a_ros2_run_cleanly(ros2_robots, tmp_path):
    import signal
    import subprocess
    import sys

    before = ros2_robots.fastdds_files()
    db = tmp_path / "run.sqlite"
    run = subprocess.Popen([sys.executable, "-m", "bimrobot", "rcan", "run", "--experiment", "2", "--backend", "ros2",
                            "--time-scale", "1", "--state-db", str(db)],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=ros_env())
    try:
        for line in run.stdout:
            if "executes 'Position for picking up'" in line:
                break
        run.send_signal(signal.SIGINT)  # what Ctrl-C sends
        rest = run.communicate(timeout=30)[0]
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert run.returncode == 130, rest
    assert "Traceback" not in rest
    # robot node stopped, its shared memory removed (what is left is in use by a live process: this one)
    assert ros2_robots.stale_fastdds_files(before) == set()
    # the journal is intact: the same command resumes (here without ROS: the sim robots finish the build)
    from bimrobot.cli import main

    assert main(["rcan", "run", "--experiment", "2", "-q", "--state-db", str(db)]) == 0
