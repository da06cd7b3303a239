"""The ``mujoco`` backend: the site, the turns, and the six activity features it implements
(:data:`FEATURES`, one module each: :mod:`.move`, :mod:`.pick`, :mod:`.transport`, :mod:`.position`,
:mod:`.install`), with the scene's components and supports (:mod:`.scene`).

``execute`` (:class:`~bimrobot.rcan.backends.interfaces.ExecutorBackend`'s) calls the feature of the
node's activity; each feature's method hands its physical work to :meth:`MujocoBackend.act`, which runs
it in its turn of the one physical world."""

from __future__ import annotations

import csv
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np

from bimrobot.site.fleet import Fleet
from bimrobot.core.tasks import ActivityKind
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.backends.interfaces import ExecutorBackend
from bimrobot.rcan.backends.mujoco import INFO
from bimrobot.rcan.backends.mujoco.common import MAKE_WAY_M, ArmWork
from bimrobot.rcan.backends.mujoco.install import Install
from bimrobot.rcan.backends.mujoco.layout import experiment_shapes, starts_apart, yard_footprints
from bimrobot.rcan.backends.mujoco.move import MoveToComponent
from bimrobot.rcan.backends.mujoco.pick import PickUp, PositionForPickingUp
from bimrobot.rcan.backends.mujoco.position import PositionForInstalling
from bimrobot.rcan.backends.mujoco.scene import SceneParts
from bimrobot.rcan.backends.mujoco.trajectory import chassis_overlaps, trajectory_rows
from bimrobot.rcan.backends.mujoco.transport import Transport
from bimrobot.rcan.backends.mujoco.turns import BLOCKED_WAIT_S, BLOCKED_WAITS, IDLE_WAIT_S, _Turns
from bimrobot.rcan.node import RcanNode

#: the activity features this backend implements: its feature classes, one module each (move.py, pick.py,
#: transport.py, position.py, install.py); each one's method does its activity's physical work in its turn
FEATURES = (MoveToComponent, PositionForPickingUp, PickUp, Transport, PositionForInstalling, Install)

#: what a feature hands to :meth:`MujocoBackend.act`: the activity's physical work on the site, which
#: returns the result's message and raises Blocked or MotionFailed (bimrobot.physics.site)
Work = Callable[[RcanNode], str]


class MujocoBackend(*FEATURES, SceneParts, ArmWork, ExecutorBackend):
    """Executor backend on a MuJoCo scene (see the package docstring): the six activity features, one
    module each (:data:`FEATURES`), on one site; declared by :data:`~bimrobot.rcan.backends.mujoco.INFO`."""

    name = "mujoco"
    info = INFO

    def __init__(self, capabilities: Fleet, db_path: str | Path = ":memory:",
                 trajectory_path: str | Path | None = None, shapes: dict | None = None, plan=None, **_options):
        from bimrobot.physics.robot import robot_model
        from bimrobot.physics.site import MujocoSite

        self.capabilities = capabilities
        self.shapes = {**experiment_shapes(), **(shapes or {})}
        robots = {}
        for spec in capabilities.robots:
            opening = spec.gripper_opening_m[1] if spec.gripper_opening_m else None
            model = robot_model(spec.name, spec.payload_kg, spec.reach_m, opening, spec.footprint_m)
            robots[spec.name] = (model, spec.speed_m_s, spec.arm_speed, spec.home_m[:2])
        targets = [(a.target.x, a.target.y) for a in plan or () if a.target is not None]
        starts = starts_apart({name: (r[3], r[0].footprint) for name, r in robots.items()},
                              np.mean(targets, axis=0) if targets else (0.0, 0.0), yard_footprints(plan or (), self.shapes))
        robots = {name: (*r[:3], starts[name]) for name, r in robots.items()}
        self.site = MujocoSite(robots)
        self.parks = {name: np.array(xy) for name, xy in starts.items()}  # where a robot goes to make way
        self.engaged: dict[str, str] = {}  # robot -> the component whose chain of activities it is in
        self.families = {name: value[0] for name, value in robots.items()}
        if trajectory_path is None and str(db_path) != ":memory:":
            trajectory_path = Path(db_path).with_name(Path(db_path).name + ".trajectory.csv")
        self.trajectory_path = None if trajectory_path is None else Path(trajectory_path)
        self.placements: dict[str, tuple[float, float]] = {}  # GlobalId -> (position error m, angle error deg)
        self.targets: dict[str, np.ndarray] = {}  # GlobalId -> its pose once installed (4x4, body frame)
        self.installed: dict = {}  # GlobalId -> its InstalledBox (bimrobot.physics.placement), once placed
        if plan:
            self._spawn_plan(plan)
        self._results: dict[tuple[str, int], ActivityResult] = {}
        self._turns = _Turns()
        self._lock = threading.Lock()
        self._changed = threading.Condition(self._lock)  # notified after every activity
        self._count_lock = threading.Lock()
        self._under_way = 0  # execute() calls in progress, those waiting for the world's lock included
        self._waiting = 0  # of those, the ones waiting for other robots' work to clear their way
        self.at_work: dict[str, str] = {}  # robot -> the component its gripper is at (grasp or work pose)

    def act(self, node: RcanNode, attempt: int, ready_at_s: float, feedback, work: Work) -> ActivityResult:
        """Do ``work`` for ``node``'s activity in the one physical world, not before ``ready_at_s``
        (simulated s): in its turn when a coordinator is attached, else under the world's lock;
        idempotent per (activity, attempt)."""
        if self._turns.coordinated:
            return self._execute_in_turn(node, attempt, ready_at_s, feedback, work)
        with self._count_lock:
            self._under_way += 1
        try:
            with self._lock:  # one physical world: robots act one after the other in simulated time
                return self._execute(node, attempt, ready_at_s, feedback, work)
        finally:
            with self._count_lock:
                self._under_way -= 1

    def attach_coordinator(self) -> None:
        """The coordinator runs in this process and will report :meth:`coordinator_settled` after each
        of its turns: activities run in turns (module docstring). Call before it sends a node."""
        self._turns.attach()

    def coordinator_settled(self, results_handled: int, in_flight: int) -> None:
        """The coordinator has handled ``results_handled`` results in all, sent every node it will
        send until the next result, and waits for ``in_flight`` of them."""
        self._turns.settled(results_handled, in_flight)

    def stop(self) -> None:
        self._turns.stop()

    def _execute(self, node: RcanNode, attempt: int, ready_at_s: float, feedback, work: Work) -> ActivityResult:
        """One activity, blocked ways waited out in real seconds (no coordinator attached)."""
        done = self._known_result(node, attempt)
        if done:
            return done
        started = self._begin(node, ready_at_s, feedback)
        for waited in range(BLOCKED_WAITS + 1):
            message, success, blocked = self._attempt(node, work)
            if not blocked:
                break
            if waited == BLOCKED_WAITS or not self._wait_for_other_work():
                if waited:
                    message += f" (still so after {waited} other activities)"
                break
        self._changed.notify_all()
        return self._finish(node, attempt, started, message, success, feedback)

    def _execute_in_turn(self, node: RcanNode, attempt: int, ready_at_s: float, feedback, work: Work) -> ActivityResult:
        """One activity, executed in its turns (module docstring)."""
        started = None
        with self._turns.queued((ready_at_s, node.activity_id, attempt)) as ticket:
            while True:
                give_up = self._turns.wait_for_turn(ticket, BLOCKED_WAITS + 1)
                blocked = None
                try:
                    with self._lock:
                        if give_up:  # blocked, and nothing can clear the way (or it was tried often enough)
                            tries = f" (tried {ticket.tries} times, other activities between)" if ticket.tries > 1 else ""
                            return self._finish(node, attempt, started, ticket.blocked + tries, False, feedback)
                        done = self._known_result(node, attempt)
                        if done:
                            return done
                        if started is None:
                            started = self._begin(node, ready_at_s, feedback)
                        message, success, was_blocked = self._attempt(node, work)
                        if not was_blocked:
                            return self._finish(node, attempt, started, message, success, feedback)
                        blocked = message
                finally:
                    self._turns.end_turn(ticket, blocked)

    def _known_result(self, node: RcanNode, attempt: int) -> ActivityResult | None:
        """The result already given for this attempt, or any success of the activity (a goal sent
        again after a broker restart)."""
        return self._results.get((node.activity_id, attempt)) or next(
            (r for (a, _), r in self._results.items() if a == node.activity_id and r.success), None)

    def _begin(self, node: RcanNode, ready_at_s: float, feedback) -> float:
        """Step the world to the activity's ready time (s) when it lies ahead; the start time (s)."""
        if ready_at_s > self.site.time_s:
            self.site.step(ready_at_s - self.site.time_s)
        if feedback:
            feedback(0.0, f"{node.kind.label}: started")
        return self.site.time_s

    def _attempt(self, node: RcanNode, work: Work) -> tuple[str, bool, bool]:
        """Try the activity's ``work`` (message, success, blocked by other robots' work); when its way is
        blocked, once more after the idle robots near its work have made way (:meth:`_send_idle_robots_back`)."""
        from bimrobot.physics.site import Blocked, MotionFailed

        self.engaged[node.robot] = node.component_id
        made_way = ""
        for _ in range(2):
            try:
                done = made_way + self._put_away_other(node) + work(node)
                return done + self._stow_when_freed(node), True, False
            except Blocked as failure:
                blocked = str(failure)
                if made_way:
                    break
                made_way = self._send_idle_robots_back(node)
                if not made_way:
                    break
            except MotionFailed as failure:
                return made_way + str(failure), False, False
        return made_way + blocked, False, True

    def _stow_when_freed(self, node: RcanNode) -> str:
        """When the activity frees its robot, its empty arm backs away from its work and is stowed
        as it drives (:meth:`MujocoSite.stow_arm`): an idle robot's arm left out at its last work
        point (a heavy arm reaches 4 m) stood in the way of other robots' work. What kept it out,
        as the end of the result's message, or ''."""
        from bimrobot.physics.site import MotionFailed

        site, robot = self.site, node.robot
        if not node.activity.releases_robot or site.robots[robot].holding:
            return ""
        q = site.arm_q(robot)
        resting = (site.ready_posture(robot), site.stowed_posture(robot))
        try:  # (an arm in the ready or the tucked posture is at no work: nothing to back off from)
            if min(np.abs(q - posture).max() for posture in resting) > 0.05:
                self._retreat(robot)
        except MotionFailed:
            pass  # stopped on the way back (a wrist against a column): stowing plans its way round
        try:
            site.stow_arm(robot)
        except MotionFailed as failure:
            return f"; its arm was left out: {failure}"
        return ""

    def _send_idle_robots_back(self, node: RcanNode) -> str:
        """Send the idle robots (in no chain of activities: :attr:`engaged`) standing within
        :data:`MAKE_WAY_M` of the node's robot or its target back to where they started, nearest to
        the target first (each on a planned path; one that cannot get there stays). What moved, as
        the start of a result's message, or ''."""
        from bimrobot.physics.site import MotionFailed

        site = self.site
        work = [site.base_xy_yaw(node.robot)[:2]]
        if node.target is not None:
            work.append(np.array([node.target.x, node.target.y]))
        idle = []
        for robot in site.robots:
            here = site.base_xy_yaw(robot)[:2]
            near = min(float(np.linalg.norm(here - w)) for w in work)
            if robot != node.robot and robot not in self.engaged and near < MAKE_WAY_M \
                    and np.linalg.norm(here - self.parks[robot]) > 0.1:
                idle.append((float(np.linalg.norm(here - work[-1])), robot))
        moved = []
        for _, robot in sorted(idle):
            try:
                distance = site.drive(robot, self.parks[robot])
            except MotionFailed:
                continue
            moved.append(f"{robot} drove {distance:.1f} m back to its start")
        return f"made way ({'; '.join(moved)}); " if moved else ""

    def _finish(self, node: RcanNode, attempt: int, started: float, message: str, success: bool,
                feedback) -> ActivityResult:
        self._note_at_work(node, success)
        self._note_engaged(node, success)
        if feedback:
            feedback(1.0, f"{node.kind.label}: finished")
        result = ActivityResult(node.activity_id, attempt, node.robot, success, message, started, self.site.time_s)
        self._results[(node.activity_id, attempt)] = result
        return result

    def _put_away_other(self, node: RcanNode) -> str:
        """A robot still holding another component (its activity on it failed for good, and RCAN gave
        the robot other work) first sets that one down on the ground nearby: it would otherwise carry
        it through its next work. What it did, as the start of the result's message, or ''."""
        robot, held = node.robot, self.site.robots[node.robot].holding
        if not held or held == node.component_id:
            return ""
        if held in self.shapes:
            self._set_down(robot, held)
            return f"first set down {held}, which it still held; "
        self._to_carry(robot)
        spot = self._lay_down(robot, held, self.site.base_xy_yaw(robot)[:2])
        return f"first set down {held}, which it still held, at ({spot[0]:.2f}, {spot[1]:.2f}); "

    def _wait_for_other_work(self) -> bool:
        """Wait (the world's lock released) until another activity has been executed; False when none
        was within the time allowed: :data:`BLOCKED_WAIT_S`, or :data:`IDLE_WAIT_S` when every activity
        under way is waiting too (nothing would change the world but a newly dispatched one)."""
        with self._count_lock:
            self._waiting += 1
            idle = self._waiting >= self._under_way
        try:
            return self._changed.wait(timeout=IDLE_WAIT_S if idle else BLOCKED_WAIT_S)
        finally:
            with self._count_lock:
                self._waiting -= 1

    def _note_engaged(self, node: RcanNode, success: bool) -> None:
        """Keep :attr:`engaged`: a robot is in a chain from its first activity on a component until
        the activity that releases it has succeeded (a failed one leaves it there: RCAN tries it again)."""
        if success and node.activity.releases_robot:
            self.engaged.pop(node.robot, None)

    def _note_at_work(self, node: RcanNode, success: bool) -> None:
        """Keep :attr:`at_work`: a robot's gripper is at a component from a successful *position for
        picking up* (or *position for installing* a component it does not hold, and did not just let
        go of) to the next *pick up* or *install*, or to a failure (RCAN positions it again)."""
        holding = self.site.robots[node.robot].holding
        if success and not holding and not node.activity.releases_robot and node.kind in (
                ActivityKind.POSITION_FOR_PICKING_UP, ActivityKind.POSITION_FOR_INSTALLING):
            self.at_work[node.robot] = node.component_id
        else:
            self.at_work.pop(node.robot, None)

    def summary(self) -> dict:
        """What the run measured: each installed component's placement error (position of its centre,
        mm; angle, degrees), the scene's simulated time (s), and for each pair of robots the simulated
        seconds their chassis overlapped in plan view (robots collide and plan round each other: this
        shows where that failed, or robots past the site's collision bits)."""
        footprints = {name: model.footprint for name, model in self.families.items()}
        return {"backend": self.name, "simulated_s": round(self.site.time_s, 3),
                "placement_error": {gid: {"position_mm": round(m * 1000, 2), "angle_deg": round(d, 3)}
                                    for gid, (m, d) in self.placements.items()},
                "robot_models": {name: model.family for name, model in self.families.items()},
                "chassis_overlap_s": chassis_overlaps(self.site.frames, footprints)}

    def close(self) -> None:
        if self.trajectory_path is not None and self.site.frames:
            self.write_trajectory(self.trajectory_path)

    def write_trajectory(self, path: Path) -> Path:
        """The recorded body poses as CSV (time_s, body, x, y, z, qw, qx, qy, qz), through bimrobot.core.io:
        see :func:`trajectory_rows` for which frames of which bodies are written."""
        from bimrobot.core import io

        with io.atomic_output_file(path, option="trajectory") as tmp:
            with open(tmp, "w", newline="", encoding="utf-8") as handle:
                handle.write(f"# {io.signature('rcan mujoco trajectory')}\n")
                writer = csv.writer(handle)
                writer.writerow(["time_s", "body", "x", "y", "z", "qw", "qx", "qy", "qz"])
                for time_s, names, poses in trajectory_rows(self.site.frames):
                    writer.writerows([f"{time_s:.3f}", name, *(f"{v:.6f}" for v in row)] for name, row in zip(names, poses))
        return path
