"""The ``ros2`` backend: one rclpy action client per robot and activity on RCAN's own
``bimrobot_interfaces/action/ConstructionActivity``, plus the ROS 2 robot node the project ships.

Action names: ``/bimrobot/<robot>/<activity>`` (e.g. ``/bimrobot/husky_ur5/pick_up``), so each of the
six activity features of a robot is its own action server, as in the thesis where each RCAN node drives
its own ROS script. A real robot serves the same actions; :func:`serve_robot_node` serves them for every
robot in the capability table on kinematic robots (:class:`~bimrobot.rcan.backends.sim.KinematicSite`),
for tests and demos.

Finding ROS 2: the pinned ``ros-jazzy-*`` wheels in the venv plus the action package that
``scripts/setup-ros2.sh`` builds into ``<venv>/ros2_ws/install`` (or ``$BIMROBOT_ROS2_INSTALL``); with a
sourced ROS 2 install and the package built in your workspace, that is used as is.
Only this module imports ROS.
"""

from __future__ import annotations

import contextlib
import ctypes
import glob
import logging
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from bimrobot.errors import MissingExtraError
from bimrobot.rcan.activities import ActivityKind
from bimrobot.rcan.backends.interfaces import ActivityResult, ExecutorBackend
from bimrobot.rcan.generation import CapabilityTable
from bimrobot.rcan.node import RcanNode

log = logging.getLogger(__name__)

SETUP_HINT = "run scripts/setup-ros2.sh .venv (ROS 2 Jazzy wheels + the bimrobot_interfaces action package)"
_LIBRARY_ORDER = ("generator_c", "typesupport_c", "typesupport_introspection_c", "typesupport_fastrtps_c",
                  "typesupport_cpp", "typesupport_introspection_cpp", "typesupport_fastrtps_cpp", "generator_py")
_loaded = False


def interfaces_install() -> Path:
    """Where the built bimrobot_interfaces package lives (``$BIMROBOT_ROS2_INSTALL`` or the venv's)."""
    return Path(os.environ.get("BIMROBOT_ROS2_INSTALL", Path(sys.prefix) / "ros2_ws" / "install"))


def load_ros2():
    """Import rclpy and the ConstructionActivity action; MissingExtraError with the fix when absent."""
    global _loaded
    install = interfaces_install()
    if not _loaded and (install / "lib").is_dir():
        site = next(iter(glob.glob(str(install / "lib" / "python3*" / "site-packages"))), None)
        if site and site not in sys.path:
            sys.path.insert(0, site)
        os.environ["AMENT_PREFIX_PATH"] = os.pathsep.join(
            [str(install), os.environ.get("AMENT_PREFIX_PATH", sys.prefix)])
        os.environ["LD_LIBRARY_PATH"] = os.pathsep.join([str(install / "lib"), os.environ.get("LD_LIBRARY_PATH", "")])
        # The loader read LD_LIBRARY_PATH at process start: load the package's libraries explicitly.
        for suffix in _LIBRARY_ORDER:
            library = install / "lib" / f"libbimrobot_interfaces__rosidl_{suffix}.so"
            if library.exists():
                ctypes.CDLL(str(library), mode=ctypes.RTLD_GLOBAL)
        _loaded = True
    try:
        import rclpy
        from bimrobot_interfaces.action import ConstructionActivity
    except ImportError as exc:
        raise MissingExtraError(f"the ros2 backend needs ROS 2 and RCAN's action package ({exc}): {SETUP_HINT}") from None
    return rclpy, ConstructionActivity


def ros2_available() -> tuple[bool, str]:
    """(True, "") when the ros2 backend can run here, else (False, why)."""
    try:
        load_ros2()
    except MissingExtraError as exc:
        return False, str(exc)
    return True, ""


def action_name(robot: str, kind: ActivityKind | str) -> str:
    return f"/bimrobot/{robot}/{ActivityKind(kind).value}"


def _quaternion_yaw(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


class Ros2Backend(ExecutorBackend):
    """Executor backend over ROS 2 actions (see the module docstring). Thread-safe: RCAN's executors
    call :meth:`execute` from one thread per robot while a background thread spins the node.
    """

    name = "ros2"

    def __init__(self, capabilities: CapabilityTable, server_timeout_s: float = 30.0, result_timeout_s: float = 600.0):
        rclpy, self._action = load_ros2()
        from rclpy.action import ActionClient
        from rclpy.executors import MultiThreadedExecutor

        self._rclpy = rclpy
        self._context = rclpy.Context()
        rclpy.init(context=self._context)
        self._node = rclpy.create_node(f"rcan_executor_{os.getpid()}", context=self._context)
        self._clients = {}
        self._lock = threading.Lock()
        self._ActionClient = ActionClient
        self.server_timeout_s, self.result_timeout_s = server_timeout_s, result_timeout_s
        self._executor = MultiThreadedExecutor(num_threads=2, context=self._context)
        self._executor.add_node(self._node)
        self._spinner = threading.Thread(target=self._spin, name="rcan-ros2-spin", daemon=True)
        self._spinner.start()

    def _spin(self) -> None:
        with contextlib.suppress(Exception):  # the context shuts down on close()
            self._executor.spin()

    def _client(self, robot: str, kind: ActivityKind):
        key = (robot, kind)
        with self._lock:
            if key not in self._clients:
                self._clients[key] = self._ActionClient(self._node, self._action, action_name(robot, kind))
            return self._clients[key]

    def _run(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        client = self._client(node.robot, node.kind)
        failed = lambda message: ActivityResult(node.activity_id, attempt, node.robot, False, message)  # noqa: E731
        if not client.wait_for_server(timeout_sec=self.server_timeout_s):
            return failed(f"no ROS 2 action server {action_name(node.robot, node.kind)} within {self.server_timeout_s:g} s")
        goal = self._action.Goal()
        goal.activity_id, goal.attempt, goal.component_id = node.activity_id, attempt, node.component_id
        goal.activity, goal.robot = node.kind.value, node.robot
        t = node.target
        goal.target_pose.position.x, goal.target_pose.position.y, goal.target_pose.position.z = t.x, t.y, t.z
        (goal.target_pose.orientation.x, goal.target_pose.orientation.y,
         goal.target_pose.orientation.z, goal.target_pose.orientation.w) = _quaternion_yaw(t.yaw)
        weight = node.activity.weight_kg
        goal.weight_kg = math.nan if weight is None else float(weight)  # NaN: unknown (a float field)
        goal.ready_at_s = float(ready_at_s)
        goal.release_after = bool(node.activity.releases_robot)
        on_feedback = (lambda message: feedback(float(message.feedback.progress), message.feedback.phase)) if feedback else None
        goal_handle = self._wait(client.send_goal_async(goal, feedback_callback=on_feedback), self.server_timeout_s)
        if goal_handle is None or not goal_handle.accepted:
            return failed(f"robot {node.robot} rejected the {node.kind.label.lower()} goal")
        response = self._wait(goal_handle.get_result_async(), self.result_timeout_s)
        if response is None:
            return failed(f"no result from robot {node.robot} within {self.result_timeout_s:g} s")
        r = response.result
        return ActivityResult(node.activity_id, attempt, node.robot, bool(r.success), r.message, r.started_s, r.finished_s)

    @staticmethod
    def _wait(future, timeout_s: float):
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout_s):
            return None
        return future.result()

    move_to_component = _run
    position_for_picking_up = _run
    pick_up = _run
    transport = _run
    position_for_installing = _run
    install = _run

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._executor.shutdown(timeout_sec=2)
            self._node.destroy_node()
            self._rclpy.shutdown(context=self._context)
        self._spinner.join(timeout=5)


# ----------------------------------------------------------------------------------------- robot node


def serve_robot_node(capabilities: CapabilityTable, time_scale: float = 0.0, failure_probability: float = 0.0,
                     seed: int = 0, db_path: str = ":memory:", ready: threading.Event | None = None,
                     stop: threading.Event | None = None) -> int:
    """Serve ``/bimrobot/<robot>/<activity>`` for every robot of ``capabilities`` until SIGINT/SIGTERM
    (or ``stop``); activities execute on kinematic robots with feedback (progress, phase).
    """
    rclpy, action = load_ros2()
    from rclpy.action import ActionServer
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.executors import MultiThreadedExecutor

    from bimrobot.rcan.activities import Pose, RcanActivity
    from bimrobot.rcan.backends.sim import KinematicSite

    site = KinematicSite(capabilities, db_path, time_scale, failure_probability, seed)
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("bimrobot_robots", context=context)
    group = ReentrantCallbackGroup()

    def make_callback(robot: str, kind: ActivityKind):
        def execute(goal_handle):
            g = goal_handle.request
            q = g.target_pose.orientation
            yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2))
            p = g.target_pose.position
            activity = RcanActivity(g.activity_id, g.component_id, kind, Pose(p.x, p.y, p.z, yaw),
                                    None if math.isnan(g.weight_kg) else g.weight_kg,
                                    frees_robot=bool(g.release_after))
            rcan_node = RcanNode(f"rcan/{g.activity_id}", activity, robot, "ros2")

            def publish_feedback(progress: float, phase: str) -> None:
                message = action.Feedback()
                message.progress, message.phase = float(progress), phase
                goal_handle.publish_feedback(message)

            outcome = site.execute(rcan_node, int(g.attempt), float(g.ready_at_s), publish_feedback)
            goal_handle.succeed()  # the action completed; success/failure of the activity is in the result
            result = action.Result()
            result.success, result.message = outcome.success, outcome.message
            result.started_s, result.finished_s = outcome.started_s, outcome.finished_s
            return result

        return execute

    servers = [
        ActionServer(node, action, action_name(robot, kind), make_callback(robot, kind), callback_group=group)
        for robot, spec in capabilities.robots.items() for kind in ActivityKind if spec.can(kind)
    ]
    executor = MultiThreadedExecutor(num_threads=4, context=context)
    executor.add_node(node)
    stop = stop or threading.Event()
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: stop.set())
    print(f"bimrobot robot node: {len(servers)} ConstructionActivity action servers for "
          f"{', '.join(capabilities.robots)}", flush=True)
    if ready:
        ready.set()
    try:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.1)
    finally:
        for server in servers:
            server.destroy()
        executor.shutdown(timeout_sec=2)
        node.destroy_node()
        rclpy.shutdown(context=context)
        site.close()
    return 0


def _fastdds_files() -> set[str]:
    return set(glob.glob("/dev/shm/fastdds_*")) | set(glob.glob("/dev/shm/sem.fastdds_*"))


@contextlib.contextmanager
def robot_node_process(capabilities_path: str | None = None, time_scale: float = 0.0, failure_probability: float = 0.0,
                       seed: int = 0, state_db: str = ":memory:", startup_timeout_s: float = 60.0):
    """Start the shipped robot node in a subprocess (same ROS_DOMAIN_ID and transports as this process),
    yield it, then stop it by PID and delete the /dev/shm/fastdds_* files created meanwhile.
    """
    before = _fastdds_files()
    command = [sys.executable, "-m", "bimrobot", "rcan", "robot-node", "--time-scale", str(time_scale),
               "--failure-probability", str(failure_probability), "--seed", str(seed), "--state-db", str(state_db)]
    if capabilities_path:
        command += ["--capabilities", str(capabilities_path)]
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
        cleanup_fastdds(before)


def cleanup_fastdds(before: set[str]) -> list[str]:
    """Delete the Fast DDS shared-memory files created since ``before`` (a killed process leaves them)."""
    removed = []
    for path in sorted(_fastdds_files() - before):
        with contextlib.suppress(OSError):
            os.unlink(path)
            removed.append(path)
    return removed
