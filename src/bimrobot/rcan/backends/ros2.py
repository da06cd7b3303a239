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
#: The feedback phase of the robot node's heartbeat (sent every 0.5 s while a goal runs).
HEARTBEAT = "alive"
HEARTBEAT_S = 0.5


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
    """Executor backend over ROS 2 actions (see the module docstring). Thread-safe: RCAN's executor
    calls :meth:`execute` from its worker threads while a background thread spins the node.

    ROS 2 gives no callback when an action server dies, so each goal is watched:

    - a *deadline* from the activity's expected duration: ``deadline_min_s + deadline_factor x expected
      robot seconds x time_scale`` (``time_scale``: real seconds per robot second of the robots;
      expected: travel at the robot's speeds from where this backend last sent it, or its gripper's
      handling time, from the capability table); a goal past it is cancelled and fails;
      ``result_timeout_s`` replaces the rule by one fixed deadline;
    - *liveness*: the robot's server must be visible in the ROS graph and send feedback at least every
      ``liveness_s`` seconds while it works (the shipped robot node sends a heartbeat every 0.5 s; a
      real robot's server does the same, as Nav2's bond does with 4 s). A silent server is taken for
      dead: the result says ``robot_lost`` and RCAN gives the activity to another capable robot.
    """

    name = "ros2"

    def __init__(self, capabilities: CapabilityTable, server_timeout_s: float = 10.0,
                 result_timeout_s: float | None = None, deadline_factor: float = 3.0, deadline_min_s: float = 30.0,
                 time_scale: float = 1.0, liveness_s: float = 4.0):
        rclpy, self._action = load_ros2()
        from rclpy.action import ActionClient
        from rclpy.executors import MultiThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        self._rclpy = rclpy
        self._context = rclpy.Context()
        # no rclpy signal handlers: Ctrl-C stays Python's KeyboardInterrupt and stops the run cleanly
        rclpy.init(context=self._context, signal_handler_options=SignalHandlerOptions.NO)
        self._node = rclpy.create_node(f"rcan_executor_{os.getpid()}", context=self._context)
        self._clients = {}
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._ActionClient = ActionClient
        self.capabilities = capabilities
        self.server_timeout_s, self.result_timeout_s = server_timeout_s, result_timeout_s
        self.deadline_factor, self.deadline_min_s = deadline_factor, deadline_min_s
        self.time_scale, self.liveness_s = time_scale, liveness_s
        self._base = {name: robot.home for name, robot in capabilities.robots.items()}  # last base goal sent
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

    def expected_s(self, node: RcanNode) -> float:
        """The robot seconds ``node``'s activity should take (0 for a robot not in the table)."""
        spec = self.capabilities.robots.get(node.robot)
        if spec is None:
            return 0.0
        if node.kind in (ActivityKind.MOVE_TO_COMPONENT, ActivityKind.TRANSPORT):
            return self._base.get(node.robot, spec.home).distance_xy(node.target) / spec.speed_m_s
        if node.kind in (ActivityKind.POSITION_FOR_PICKING_UP, ActivityKind.POSITION_FOR_INSTALLING):
            return (2 * spec.reach_m + 1.0) / spec.arm_speed_m_s  # at most across the reach and up from stowed
        return spec.handling_s.get(node.kind.value, 0.0)

    def deadline_s(self, node: RcanNode) -> float:
        """Real seconds ``node``'s goal may take before it is cancelled (see the class docstring)."""
        if self.result_timeout_s is not None:
            return self.result_timeout_s
        return self.deadline_min_s + self.deadline_factor * self.expected_s(node) * self.time_scale

    def _run(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        client = self._client(node.robot, node.kind)
        failed = lambda message, lost=False: ActivityResult(  # noqa: E731
            node.activity_id, attempt, node.robot, False, message, robot_lost=lost)
        if not client.wait_for_server(timeout_sec=self.server_timeout_s):
            return failed(f"no ROS 2 action server {action_name(node.robot, node.kind)} within "
                          f"{self.server_timeout_s:g} s", lost=True)
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
        heard = [time.monotonic()]

        def on_feedback(message) -> None:
            heard[0] = time.monotonic()
            if feedback and message.feedback.phase != HEARTBEAT:
                feedback(float(message.feedback.progress), message.feedback.phase)

        goal_handle = self._wait(client.send_goal_async(goal, feedback_callback=on_feedback), self.server_timeout_s)
        if goal_handle is None:
            return failed(f"robot {node.robot} did not answer the {node.kind.label.lower()} goal within "
                          f"{self.server_timeout_s:g} s", lost=True)
        if not goal_handle.accepted:
            return failed(f"robot {node.robot} rejected the {node.kind.label.lower()} goal")
        future, deadline = goal_handle.get_result_async(), self.deadline_s(node)
        started = heard[0] = time.monotonic()
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        while not done.wait(0.2):
            now = time.monotonic()
            if self._closed.is_set():
                return failed("the run stopped before the robot's result came")
            if now - heard[0] > self.liveness_s:  # (the ROS graph lags: a dead server stays listed for ~20 s)
                return failed(f"robot {node.robot} stopped answering: no feedback for {now - heard[0]:.1f} s "
                              f"(liveness {self.liveness_s:g} s) during {node.kind.label.lower()}", lost=True)
            if now - started > deadline:
                with contextlib.suppress(Exception):
                    goal_handle.cancel_goal_async()
                return failed(f"no result from robot {node.robot} within its {deadline:.0f} s deadline "
                              f"(expected {self.expected_s(node):.0f} robot s); the goal was cancelled")
        r = future.result().result
        if r.success and node.kind in (ActivityKind.MOVE_TO_COMPONENT, ActivityKind.TRANSPORT):
            self._base[node.robot] = node.target
        return ActivityResult(node.activity_id, attempt, node.robot, bool(r.success), r.message, r.started_s, r.finished_s)

    def _wait(self, future, timeout_s: float):
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        deadline = time.monotonic() + timeout_s
        while not done.wait(0.2):
            if self._closed.is_set() or time.monotonic() > deadline:
                return None
        return future.result()

    move_to_component = _run
    position_for_picking_up = _run
    pick_up = _run
    transport = _run
    position_for_installing = _run
    install = _run

    def stop(self) -> None:
        self._closed.set()  # goals still waited for end now, so no thread outlives the run

    def close(self) -> None:
        self._closed.set()
        with contextlib.suppress(Exception):
            self._executor.shutdown(timeout_sec=2)
            self._node.destroy_node()
            self._rclpy.shutdown(context=self._context)
        self._spinner.join(timeout=5)


# ----------------------------------------------------------------------------------------- robot node


def serve_robot_node(capabilities: CapabilityTable, time_scale: float = 0.0, failure_probability: float = 0.0,
                     seed: int = 0, db_path: str = ":memory:", ready: threading.Event | None = None,
                     stop: threading.Event | None = None, robots: list[str] | None = None) -> int:
    """Serve ``/bimrobot/<robot>/<activity>`` for every robot of ``capabilities`` (or only ``robots``)
    until SIGINT/SIGTERM (or ``stop``); activities execute on kinematic robots with feedback (progress,
    phase, and a heartbeat every 0.5 s while working). A goal whose activity id the robots already
    completed is not executed again: its earlier result is returned.
    """
    rclpy, action = load_ros2()
    from rclpy.action import ActionServer
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.executors import MultiThreadedExecutor

    from bimrobot.rcan.activities import Pose, RcanActivity
    from bimrobot.rcan.backends.sim import KinematicSite

    site = KinematicSite(capabilities, db_path, time_scale, failure_probability, seed)
    context = rclpy.Context()
    from rclpy.signals import SignalHandlerOptions

    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)  # SIGINT/SIGTERM: handled below
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
                with contextlib.suppress(Exception):  # the goal may be gone (cancelled, client closed)
                    goal_handle.publish_feedback(message)

            working = threading.Event()

            def heartbeat() -> None:  # liveness for the client while the robot works
                while not working.wait(HEARTBEAT_S):
                    publish_feedback(0.5, HEARTBEAT)

            beat = threading.Thread(target=heartbeat, daemon=True)
            beat.start()
            try:
                outcome = site.execute(rcan_node, int(g.attempt), float(g.ready_at_s), publish_feedback)
            finally:
                working.set()
                beat.join()
            goal_handle.succeed()  # the action completed; success/failure of the activity is in the result
            result = action.Result()
            result.success, result.message = outcome.success, outcome.message
            result.started_s, result.finished_s = outcome.started_s, outcome.finished_s
            return result

        return execute

    servers = [
        ActionServer(node, action, action_name(robot, kind), make_callback(robot, kind), callback_group=group)
        for robot, spec in capabilities.robots.items() for kind in ActivityKind
        if spec.can(kind) and (robots is None or robot in robots)
    ]
    executor = MultiThreadedExecutor(num_threads=4, context=context)
    executor.add_node(node)
    stop = stop or threading.Event()
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: stop.set())
    print(f"bimrobot robot node: {len(servers)} ConstructionActivity action servers for "
          f"{', '.join(robots or capabilities.robots)}", flush=True)
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


#: Shared-memory files of Fast DDS in /dev/shm: Fast DDS 2.x (Jazzy's wheels) names its segments,
#: ports and their semaphores ``fastrtps_*`` / ``sem.fastrtps_*``; Fast DDS 3 uses ``fastdds_*``.
SHM_PATTERNS = ("fastrtps_*", "sem.fastrtps_*", "fastdds_*", "sem.fastdds_*")


def _fastdds_files() -> set[str]:
    return {path for pattern in SHM_PATTERNS for path in glob.glob(f"/dev/shm/{pattern}")}


def _shm_in_use(ignore_pid: int | None = None) -> set[str]:
    """/dev/shm files a live process (other than ``ignore_pid``) has mapped or open."""
    used = set()
    for proc in glob.glob("/proc/[0-9]*"):
        if ignore_pid is not None and proc == f"/proc/{ignore_pid}":
            continue
        with contextlib.suppress(OSError):
            with open(f"{proc}/maps", encoding="utf-8", errors="replace") as maps:
                used.update(line.split(None, 5)[5].strip() for line in maps if "/dev/shm/" in line)
        with contextlib.suppress(OSError):
            for fd in os.listdir(f"{proc}/fd"):
                with contextlib.suppress(OSError):
                    target = os.readlink(f"{proc}/fd/{fd}")
                    if target.startswith("/dev/shm/"):
                        used.add(target)
    return {path.removesuffix(" (deleted)") for path in used}


@contextlib.contextmanager
def robot_node_process(capabilities_path: str | None = None, time_scale: float = 0.0, failure_probability: float = 0.0,
                       seed: int = 0, state_db: str = ":memory:", startup_timeout_s: float = 60.0,
                       participants_closed: bool = False):
    """Start the shipped robot node in a subprocess (same ROS_DOMAIN_ID and transports as this process),
    yield it, then stop it by PID and delete the Fast DDS shared-memory files (``SHM_PATTERNS``)
    created meanwhile that no live process uses (``participants_closed``: not counting this one).
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
        # participants_closed: this process has no ROS 2 participant left (the run closed its backend)
        cleanup_fastdds(before, os.getpid() if participants_closed else None)


def stale_fastdds_files(before: set[str], ignore_pid: int | None = None) -> set[str]:
    """The Fast DDS shared-memory files created since ``before`` that no live process uses: a file another
    ROS 2 program maps is in use, and so is the semaphore (``sem.<name>_mutex``) of a port it maps.
    ``ignore_pid``: a process whose participants are all closed and whose mappings go with it."""
    candidates = _fastdds_files() - before
    if not candidates:
        return set()
    used = {path[len("/dev/shm/"):] for path in _shm_in_use(ignore_pid)}
    return {path for path in candidates
            if path[len("/dev/shm/"):] not in used
            and not (path.startswith("/dev/shm/sem.") and path[len("/dev/shm/sem."):].removesuffix("_mutex") in used)}


def cleanup_fastdds(before: set[str], ignore_pid: int | None = None) -> list[str]:
    """Delete the Fast DDS shared-memory files created since ``before`` that no live process uses (a
    killed process leaves them, and Fast DDS leaves its port segments); see ``stale_fastdds_files``."""
    removed = []
    for path in sorted(stale_fastdds_files(before, ignore_pid)):
        with contextlib.suppress(OSError):
            os.unlink(path)
            removed.append(path)
    return removed
