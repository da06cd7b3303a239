"""The robot side of the ``ros2`` backend: the ROS 2 robot node the project ships
(:func:`serve_robot_node`: the ``ConstructionActivity`` action servers of every robot, on kinematic
robots) and :func:`robot_node_process`, which runs it in a subprocess for a run, a test or a benchmark.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import subprocess
import sys
import threading
import time

from bimrobot.site.fleet import Fleet
from bimrobot.core.frames import yaw_of_quat_xyzw
from bimrobot.rcan.activities import ActivityKind
from bimrobot.rcan.backends.ros2.environment import (HEARTBEAT, HEARTBEAT_S, action_name, cleanup_fastdds,
                                                     fastdds_files, load_ros2)
from bimrobot.rcan.node import RcanNode


NODE_TRANSPORTS = "UDPv4"
"""The robot node's Fast DDS transports (``FASTDDS_BUILTIN_TRANSPORTS``, unless the environment sets it):
no shared memory, so a killed node leaves nothing in /dev/shm."""


class _Heartbeat:
    """One thread that sends the heartbeat feedback (phase :data:`HEARTBEAT`) of every goal being worked
    on, every :data:`HEARTBEAT_S` seconds (a thread per goal cost a thread start and join per activity)."""

    def __init__(self) -> None:
        self._beating: dict[object, object] = {}  # token -> publish_feedback(progress, phase) of a goal
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="robot-node-heartbeat", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(HEARTBEAT_S):
            with self._lock:
                beats = list(self._beating.values())
            for publish in beats:
                publish(0.5, HEARTBEAT)

    @contextlib.contextmanager
    def beating(self, publish_feedback):
        """While inside, the goal whose feedback ``publish_feedback`` sends gets heartbeats."""
        token = object()
        with self._lock:
            self._beating[token] = publish_feedback
        try:
            yield
        finally:
            with self._lock:
                del self._beating[token]

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)


def serve_robot_node(capabilities: Fleet, time_scale: float = 0.0, failure_probability: float = 0.0,
                     seed: int = 0, db_path: str = ":memory:", ready: threading.Event | None = None,
                     stop: threading.Event | None = None, robots: list[str] | None = None) -> int:
    """Serve ``/bimrobot/<robot>/<activity>`` for every robot of ``capabilities`` (or only ``robots``)
    until SIGINT/SIGTERM (or ``stop``); activities execute on kinematic robots with feedback (progress,
    phase, and a heartbeat every 0.5 s while working). A goal whose activity id the robots already
    completed is not executed again: its earlier result is returned.
    """
    # Fast DDS over UDP only: its shared-memory transport leaves fastrtps_port* files in /dev/shm when the
    # node is killed (SIGKILL), which nothing removes; a client on the default transports reaches it by UDP
    os.environ.setdefault("FASTDDS_BUILTIN_TRANSPORTS", NODE_TRANSPORTS)
    rclpy, action = load_ros2()
    from rclpy.action import ActionServer
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    from bimrobot.rcan.backends.sim import SimBackend

    robots_here = SimBackend(capabilities, db_path, time_scale, failure_probability, seed)  # the sim backend's features
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)  # SIGINT/SIGTERM: handled below
    node = rclpy.create_node("bimrobot_robots", context=context)
    group = ReentrantCallbackGroup()
    heart = _Heartbeat()
    servers = [
        ActionServer(node, action, action_name(robot, kind), _goal_callback(robots_here, heart, action, robot, kind),
                     callback_group=group)
        for robot, spec in capabilities.by_name.items() for kind in ActivityKind
        if spec.performs(kind) and (robots is None or robot in robots)
    ]
    executor = MultiThreadedExecutor(num_threads=4, context=context)
    executor.add_node(node)
    stop = stop or threading.Event()
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: stop.set())
    print(f"bimrobot robot node: {len(servers)} ConstructionActivity action servers for "
          f"{', '.join(robots or capabilities.names)}", flush=True)
    if ready:
        ready.set()
    try:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.1)
    finally:
        for server in servers:
            server.destroy()
        executor.shutdown(timeout_sec=2)
        heart.close()
        node.destroy_node()
        rclpy.shutdown(context=context)
        robots_here.close()
    return 0


def _goal_callback(robots_here, heart: _Heartbeat, action, robot: str, kind: ActivityKind):
    """The execute callback of the action server of ``robot``'s ``kind`` activities: the goal (pose in
    metres, yaw in radians, weight in kg, NaN: unknown) becomes an RCAN node that ``robots_here`` (the sim
    backend) executes, with heartbeats while it works; the action's result carries the activity's outcome."""
    from bimrobot.rcan.activities import Pose, RcanActivity

    def execute(goal_handle):
        g = goal_handle.request
        q = g.target_pose.orientation
        yaw = yaw_of_quat_xyzw(q.x, q.y, q.z, q.w)  # ROS's order
        p = g.target_pose.position
        activity = RcanActivity(g.activity_id, g.component_id, kind, Pose(p.x, p.y, p.z, yaw),
                                None if math.isnan(g.weight_kg) else g.weight_kg,
                                frees_robot=bool(g.release_after))
        rcan_node = RcanNode(f"rcan/{g.activity_id}", activity, robot, "ros2")

        def publish_feedback(progress: float, phase: str) -> None:
            message = action.Feedback()
            message.progress, message.phase = float(progress), phase
            with contextlib.suppress(Exception):  # the goal may be gone (cancelled, client closed)
                goal_handle.publish_feedback(message)

        with heart.beating(publish_feedback):  # liveness for the client while the robot works
            outcome = robots_here.execute(rcan_node, int(g.attempt), float(g.ready_at_s), publish_feedback)
        goal_handle.succeed()  # the action completed; success/failure of the activity is in the result
        result = action.Result()
        result.success, result.message = outcome.success, outcome.message
        result.started_s, result.finished_s = outcome.started_s, outcome.finished_s
        return result

    return execute


@contextlib.contextmanager
def robot_node_process(capabilities_path: str | None = None, time_scale: float = 0.0, failure_probability: float = 0.0,
                       seed: int = 0, state_db: str = ":memory:", startup_timeout_s: float = 60.0,
                       participants_closed: bool = False, extra_args: list[str] | None = None):
    """Start the shipped robot node in a subprocess (same ROS_DOMAIN_ID as this process; UDP, see
    :data:`NODE_TRANSPORTS`),
    yield it, then stop it by PID and delete the Fast DDS shared-memory files (``SHM_PATTERNS``)
    created meanwhile that no live process uses (``participants_closed``: not counting this one).
    """
    before = fastdds_files()
    command = [sys.executable, "-m", "bimrobot", "rcan", "robot-node", "--time-scale", str(time_scale),
               "--failure-probability", str(failure_probability), "--seed", str(seed), "--state-db", str(state_db)]
    if capabilities_path:
        command += ["--capabilities", str(capabilities_path)]
    command += extra_args or []  # e.g. --site and --model-offset: where a fleet's robots start
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + startup_timeout_s
        line = process.stdout.readline()
        while "action servers" not in line:
            if process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"the ROS 2 robot node did not start: {line}{process.stdout.read() if process.poll() is not None else ''}")
            line = process.stdout.readline()
        yield process
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGTERM)
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        if process.stdout:
            process.stdout.close()
        # participants_closed: this process has no ROS 2 participant left (the run closed its backend)
        cleanup_fastdds(before, os.getpid() if participants_closed else None)
