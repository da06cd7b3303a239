"""The client side of the ``ros2`` backend: :class:`Ros2Backend`, one rclpy node per backend with one
action client per (robot, activity) on RCAN's ``bimrobot_interfaces/action/ConstructionActivity``,
created on first use and kept for the run.
"""

from __future__ import annotations

import contextlib
import math
import os
import threading
import time

from bimrobot.site.fleet import Fleet
from bimrobot.core.frames import quat_xyzw_of_yaw
from bimrobot.rcan.activities import ActivityKind, Pose
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.backends.interfaces import ExecutorBackend
from bimrobot.rcan.backends.ros2 import INFO
from bimrobot.rcan.backends.ros2.environment import HEARTBEAT, action_name, load_ros2
from bimrobot.rcan.node import RcanNode


#: Seconds without an answer to a goal request before it is sent again (a server accepts a goal at once).
GOAL_RESEND_S = 2.0


class Ros2Backend(ExecutorBackend):
    """Executor backend over ROS 2 actions (see the module docstring). Thread-safe: RCAN's executor
    calls :meth:`execute` from its worker threads while a background thread spins the node.

    Its six features are the robot's: each is the robot's action server of that activity
    (``/bimrobot/<robot>/<activity>``), and :meth:`execute` sends the node's goal to it.

    ROS 2 gives no callback when an action server dies, so each goal is watched:

    - a *deadline* from the activity's expected duration: ``deadline_min_s + deadline_factor x expected
      robot seconds x time_scale`` (``time_scale``: real seconds per robot second of the robots;
      expected: travel at the robot's speeds from where this backend last sent it, or its gripper's
      handling time, from the fleet); a goal past it is cancelled and fails;
      ``result_timeout_s`` replaces the rule by one fixed deadline;
    - *liveness*: the robot's server must appear in the ROS graph within ``server_timeout_s`` (looked
      up once per action client), answer a goal request within it (the request is sent again every
      :data:`GOAL_RESEND_S`), and send feedback at least every ``liveness_s`` seconds while it works (the shipped robot node sends a heartbeat every 0.5 s; a
      real robot's server does the same, as Nav2's bond does with 4 s). A silent server is taken for
      dead: the result says ``robot_lost`` and RCAN gives the activity to another capable robot.
    """

    name = "ros2"
    info = INFO
    features = frozenset(ActivityKind)  # each one the robot's action server of that activity

    @classmethod
    def options_from(cls, args) -> dict:
        """The goals' deadlines and liveness; the robots' time scale: ``--time-scale`` for the shipped robot
        node this run starts, real time (1) for robots of your own."""
        spawned = getattr(args, "robot_node", "external") == "spawn" and not getattr(args, "no_local_executors", False)
        return {**super().options_from(args), "time_scale": args.time_scale if spawned else 1.0}

    @classmethod
    def around_run(cls, args, model_offset):
        """With ``--robot-node spawn`` (and local executors): the shipped ROS 2 robot node, started and stopped
        around the run, with the robots' homes where this run put them (``model_offset``, m)."""
        if args.robot_node != "spawn" or getattr(args, "no_local_executors", False):
            return contextlib.nullcontext()
        from bimrobot.rcan.backends.ros2.robot_node import robot_node_process

        load_ros2()  # fails early with the setup hint when ROS 2 is absent
        os.environ.setdefault("FASTDDS_BUILTIN_TRANSPORTS", "SHM")  # both processes are on this machine
        placement = [*(["--site", str(args.site)] if args.site else []), "--model-offset", *map(repr, model_offset)]
        return robot_node_process(args.capabilities, args.time_scale, args.failure_probability, args.seed,
                                  state_db=args.state_db, participants_closed=True,  # run_plan closes its backend first
                                  extra_args=placement)

    def __init__(self, capabilities: Fleet, server_timeout_s: float = 10.0,
                 result_timeout_s: float | None = None, deadline_factor: float = 3.0, deadline_min_s: float = 30.0,
                 time_scale: float = 1.0, liveness_s: float = 4.0):
        rclpy, self._action = load_ros2()
        from rclpy.action import ActionClient
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        self._rclpy = rclpy
        self._context = rclpy.Context()
        # no rclpy signal handlers: Ctrl-C stays Python's KeyboardInterrupt and stops the run cleanly
        rclpy.init(context=self._context, signal_handler_options=SignalHandlerOptions.NO)
        self._node = rclpy.create_node(f"rcan_executor_{os.getpid()}", context=self._context)
        self._clients = {}
        self._seen: set = set()  # (robot, activity) whose action server was found once
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._ActionClient = ActionClient
        self.capabilities = capabilities
        self.server_timeout_s, self.result_timeout_s = server_timeout_s, result_timeout_s
        self.deadline_factor, self.deadline_min_s = deadline_factor, deadline_min_s
        self.time_scale, self.liveness_s = time_scale, liveness_s
        self._base = {robot.name: Pose(*robot.home_m) for robot in capabilities.robots}  # last base goal sent
        # one thread spins every callback (goal responses, feedback, results: each is short); rclpy's
        # multi-threaded executor hands each callback to a thread pool, which made a round trip about
        # three times slower here (bench/rcan.py --references)
        self._executor = SingleThreadedExecutor(context=self._context)
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
        spec = self.capabilities.by_name.get(node.robot)
        if spec is None:
            return 0.0
        if node.kind in (ActivityKind.MOVE_TO_COMPONENT, ActivityKind.TRANSPORT):
            return self._base.get(node.robot, Pose(*spec.home_m)).distance_xy(node.target) / spec.speed_m_s
        if node.kind in (ActivityKind.POSITION_FOR_PICKING_UP, ActivityKind.POSITION_FOR_INSTALLING):
            return (2 * spec.reach_m + 1.0) / spec.arm_speed  # at most across the reach and up from stowed
        return spec.handling_s.get(node.kind.value, 0.0)

    def deadline_s(self, node: RcanNode) -> float:
        """Real seconds ``node``'s goal may take before it is cancelled (see the class docstring)."""
        if self.result_timeout_s is not None:
            return self.result_timeout_s
        return self.deadline_min_s + self.deadline_factor * self.expected_s(node) * self.time_scale

    def execute(self, node: RcanNode, attempt: int = 1, ready_at_s: float = 0.0, feedback=None) -> ActivityResult:
        """Send ``node``'s goal to its robot's action server of its activity and wait for the result,
        watched by the deadline and the liveness (class docstring)."""
        client = self._client(node.robot, node.kind)
        failed = lambda message, lost=False: ActivityResult(  # noqa: E731
            node.activity_id, attempt, node.robot, False, message, robot_lost=lost)
        key = (node.robot, node.kind)
        if key not in self._seen:  # once found, a server that dies is noticed by the goal's own timeouts
            if not client.wait_for_server(timeout_sec=self.server_timeout_s):
                return failed(f"no ROS 2 action server {action_name(node.robot, node.kind)} within "
                              f"{self.server_timeout_s:g} s", lost=True)
            self._seen.add(key)
        heard = [time.monotonic()]

        def on_feedback(message) -> None:
            heard[0] = time.monotonic()
            if feedback and message.feedback.phase != HEARTBEAT:
                feedback(float(message.feedback.progress), message.feedback.phase)

        goal_handle = self._send_goal(client, self._goal(node, attempt, ready_at_s), on_feedback)
        if goal_handle is None:
            return failed(f"robot {node.robot} did not answer the {node.kind.label.lower()} goal within "
                          f"{self.server_timeout_s:g} s", lost=True)
        if not goal_handle.accepted:
            return failed(f"robot {node.robot} rejected the {node.kind.label.lower()} goal")
        future = goal_handle.get_result_async()
        problem = self._watch(future, goal_handle, node, heard)
        if problem is not None:
            return failed(*problem)
        r = future.result().result
        if r.success and node.kind in (ActivityKind.MOVE_TO_COMPONENT, ActivityKind.TRANSPORT):
            self._base[node.robot] = node.target
        return ActivityResult(node.activity_id, attempt, node.robot, bool(r.success), r.message, r.started_s, r.finished_s)

    def _goal(self, node: RcanNode, attempt: int, ready_at_s: float):
        """The ``ConstructionActivity`` goal of ``node``: target pose (metres, yaw as a quaternion in ROS's
        x, y, z, w order), weight in kg (NaN: unknown), the robot time it may start at (s)."""
        goal = self._action.Goal()
        goal.activity_id, goal.attempt, goal.component_id = node.activity_id, attempt, node.component_id
        goal.activity, goal.robot = node.kind.value, node.robot
        t = node.target
        goal.target_pose.position.x, goal.target_pose.position.y, goal.target_pose.position.z = t.x, t.y, t.z
        (goal.target_pose.orientation.x, goal.target_pose.orientation.y,
         goal.target_pose.orientation.z, goal.target_pose.orientation.w) = quat_xyzw_of_yaw(t.yaw)
        weight = node.activity.weight_kg
        goal.weight_kg = math.nan if weight is None else float(weight)  # NaN: unknown (a float field)
        goal.ready_at_s = float(ready_at_s)
        goal.release_after = bool(node.activity.releases_robot)
        return goal

    def _send_goal(self, client, goal, on_feedback):
        """The goal handle the server answers with, or None when it does not answer within the server timeout."""
        goal_handle, answer_by = None, time.monotonic() + self.server_timeout_s
        while goal_handle is None and not self._closed.is_set() and time.monotonic() < answer_by:
            # DDS can lose a request (e.g. the first one just after discovery): the goal is sent again
            # after GOAL_RESEND_S without an answer; the robot runs an activity id once, so a copy is harmless
            wait_s = min(GOAL_RESEND_S, answer_by - time.monotonic())
            goal_handle = self._wait(client.send_goal_async(goal, feedback_callback=on_feedback), wait_s)
        return goal_handle

    def _watch(self, future, goal_handle, node: RcanNode, heard: list[float]) -> tuple[str, bool] | None:
        """Wait for the result ``future``; None when it came, else why the activity failed (message, robot
        lost): the run stopped, no feedback within the liveness, or the deadline passed (goal cancelled)."""
        deadline = self.deadline_s(node)
        started = heard[0] = time.monotonic()
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        while not done.wait(0.2):
            now = time.monotonic()
            if self._closed.is_set():
                return "the run stopped before the robot's result came", False
            if now - heard[0] > self.liveness_s:  # (the ROS graph lags: a dead server stays listed for ~20 s)
                return (f"robot {node.robot} stopped answering: no feedback for {now - heard[0]:.1f} s "
                        f"(liveness {self.liveness_s:g} s) during {node.kind.label.lower()}", True)
            if now - started > deadline:
                with contextlib.suppress(Exception):
                    goal_handle.cancel_goal_async()
                return (f"no result from robot {node.robot} within its {deadline:.0f} s deadline "
                        f"(expected {self.expected_s(node):.0f} robot s); the goal was cancelled", False)
        return None

    def _wait(self, future, timeout_s: float):
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        deadline = time.monotonic() + timeout_s
        while not done.wait(0.2):
            if self._closed.is_set() or time.monotonic() > deadline:
                return None
        return future.result()

    def stop(self) -> None:
        self._closed.set()  # goals still waited for end now, so no thread outlives the run

    def close(self) -> None:
        self._closed.set()
        with contextlib.suppress(Exception):
            self._executor.shutdown(timeout_sec=2)
            self._node.destroy_node()
            self._rclpy.shutdown(context=self._context)
        self._spinner.join(timeout=5)
