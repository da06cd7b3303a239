"""The ``mujoco`` backend: the six activities executed physically in MuJoCo (bimrobot.physics).

Each robot of the fleet becomes a mobile manipulator of the family of
:mod:`bimrobot.physics.robot` (``ur5`` for payload <= 5 kg and reach <= 0.85 m, else ``heavy``; its
base ``footprint_m`` when the table gives one) at its home, or beside it when a robot listed before it
starts there (:func:`starts_apart`). Components are boxes:

- given by ``shapes`` or :func:`experiment_shapes` (the thesis' experiments): upright, centred on the
  activity's target, entering the scene when an activity first names it, as before;
- else of the plan's ``size_m``, placed by :mod:`bimrobot.physics.placement` (lying on the yard
  centred on the pick-up target; installed by the IFC origin: upright column, horizontal beam
  between the members it spans, flat footing). Given the ``plan`` (``run_plan`` passes it), every
  one starts in the scene: on the yard, or in place when no activity lifts it.

Under a box above the ground stands a support (a pedestal; a prop under a beam's middle third); one
below the ground gets a pit with a support at its floor. Components collide with the ground, the
supports and the robots, not with each other (the connections are not modelled). Robots collide
with each other, and each robot's paths and stands keep clear of the others as they stand (the
site's obstacles); a component one holds passes through the others, as through components.

- *move to component*, *transport*: the base drives along a collision-free path on an occupancy grid
  of the scene (supports and components on the ground, grown by half the base width and a clearance;
  pyastar2d's A*), turning and driving straight per leg; with a component held, in the carry posture.
- *position for picking up*: the base turns to face the component (backing away first when its
  corners would sweep into something), the arm moves through a pre-grasp 0.10 m above to the grasp
  pose (mink inverse kinematics, quintic joint-space interpolation, torque-limited servos).
- *pick up*: the gripper closes and a weld holds the component when the tool centre point is within
  5 mm and 2 degrees of the grasp pose; then it lifts 0.10 m. A component heavier than the arm's
  torque limits allow makes the lift fail (the arm sags): the activity fails naming its weight and
  the robot's rated payload, and the gripper lets go.
- *position for installing*: the held component goes through a point 0.10 m above its target to the
  target itself (its pose in the gripper, as gripped, taken into account).
- *install*: the gripper opens, the arm retracts; after 2 s the component's position error (mm) and
  angle error (degrees) to its target are measured, and it must not move more than 1 mm in 2 s more.
  Over :data:`POSITION_TOLERANCE_M` / :data:`ANGLE_TOLERANCE_DEG` the activity fails.

Turns: the robots share one physical world, so activities are executed one at a time. When the
coordinator runs in this process (``run_plan`` attaches it, :meth:`MujocoBackend.coordinator_settled`),
the next activity is chosen only once the coordinator has handled every result and every node it
has sent has arrived here, and it is the one ready first in simulated time (ties: activity id, then
attempt): a run is the same, activity for activity, whatever the threads' timing. An activity whose
way is blocked by other robots' work gives up its turn and is tried again after another activity has
finished (at most :data:`BLOCKED_WAITS` times); when every activity here is so blocked and nothing
else is coming, the first of them fails at once, with the reason it was last blocked. Before it gives
up its turn, the robots standing idle near it or its work (in no chain of activities: they have
placed their last component, or have had none yet) drive back to where they started, and it tries
once more (``made way (...)`` in its result). An activity that frees its robot ends with the robot's
empty arm taken back from its work and tucked (``its arm was left out: ...`` when it could not be). Without a
coordinator (tests, executors in another process) activities run in the order they arrive, and a
blocked one waits real seconds (:data:`BLOCKED_WAIT_S`, :data:`IDLE_WAIT_S`) for other work.

Times in results are simulated seconds. Every body's pose is recorded at 20 Hz (simulated time) and
written on close to ``<state db>.trajectory.csv`` beside the run's state database (or
``trajectory_path``): ``time_s, body, x, y, z, qw, qx, qy, qz``, the rows of the bodies that moved
(:func:`trajectory_rows`: a body's pose at any recorded time is its last row at or before it). The
physical world is not persisted: a resumed run starts the scene anew (completed goals are still
answered from memory within a run).
"""

from __future__ import annotations

import csv
import math
import threading
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from bimrobot.coordination.fleet import Fleet
from bimrobot.rcan.activities import ActivityKind, RcanActivity
from bimrobot.rcan.backends.interfaces import ActivityResult, DispatchingBackend
from bimrobot.rcan.node import RcanNode

POSITION_TOLERANCE_M = 0.010
ANGLE_TOLERANCE_DEG = 1.0
SETTLE_S = 2.0
LIFT_M = 0.10
RESEAT_TRIES = 2  # a held component seated off its place is lifted and set down again at most this often
RESEAT_LIFT_M = 0.02
SUPPORT_MIN_Z_M = 0.01
MAKE_WAY_M = 8.0  # idle robots this near a blocked robot or its target drive back to their start
BLOCKED_WAITS = 20  # a robot that finds its way blocked waits for up to this many other activities ...
BLOCKED_WAIT_S = 120.0  # ... each within this many real seconds, before its activity fails
IDLE_WAIT_S = 3.0  # when every activity under way is waiting so, a new one may still be dispatched within
    # this many real seconds (the coordinator reacts to the last result); if none is, nothing can clear the
    # way and the activity fails at once instead of waiting out BLOCKED_WAIT_S

class _Ticket:
    """An activity queued for its turn: ``key`` (ready time s, activity id, attempt) orders turns;
    ``blocked_at``: :attr:`_Turns.finished` when its way was last found blocked; ``tries``: how often;
    ``blocked``: why, the last time."""

    def __init__(self, key: tuple[float, str, int]):
        self.key = key
        self.blocked_at: int | None = None
        self.tries = 0
        self.blocked = ""


class _Turns:
    """Which queued activity acts next in the one physical world (module docstring, Turns)."""

    def __init__(self):
        self._condition = threading.Condition()
        self.coordinated = False  # a coordinator in this process reports when it has settled
        self._handled = 0  # results the coordinator has handled
        self._in_flight: int | None = None  # nodes it waits for (None: it has not reported yet)
        self.finished = 0  # activities finished here, their results given back: what a blocked one waits for
        self._queued: list[_Ticket] = []
        self._acting: _Ticket | None = None
        self._stopped = False

    def attach(self) -> None:
        with self._condition:
            self.coordinated = True

    def settled(self, handled: int, in_flight: int) -> None:
        with self._condition:
            self._handled, self._in_flight = handled, in_flight
            self._condition.notify_all()

    def stop(self) -> None:
        with self._condition:
            self._stopped = True
            self._condition.notify_all()

    @contextmanager
    def queued(self, key: tuple[float, str, int]):
        """Queue an activity for the time it is executed (its result given back at the end)."""
        ticket = _Ticket(key)
        with self._condition:
            self._queued.append(ticket)
            self._condition.notify_all()
        try:
            yield ticket
        finally:
            with self._condition:
                self._queued.remove(ticket)
                self.finished += 1
                self._condition.notify_all()

    def wait_for_turn(self, ticket: _Ticket, max_tries: int) -> bool:
        """Wait until ``ticket`` acts; whether it should give up instead: it was blocked ``max_tries``
        times, or its turn came although nothing finished since it was blocked (nothing can change)."""
        with self._condition:
            self._condition.wait_for(lambda: self._stopped or self._next() is ticket)
            if self._stopped:
                raise RuntimeError("the run is ending; the activity was not executed")
            self._acting = ticket
            return ticket.tries >= max_tries or ticket.blocked_at == self.finished

    def end_turn(self, ticket: _Ticket, blocked: str | None) -> None:
        """``ticket``'s turn is over; ``blocked``: why its way was blocked, or None (it is finished)."""
        with self._condition:
            self._acting = None
            if blocked is not None:
                ticket.blocked_at, ticket.tries, ticket.blocked = self.finished, ticket.tries + 1, blocked
            self._condition.notify_all()

    def _next(self) -> _Ticket | None:
        """The ticket whose turn it is, or None while one acts or the coordinator has not settled (a
        result not yet handled, a node sent that has not arrived). The earliest of those not blocked
        since the last activity finished; when all are, the earliest of all (to give up)."""
        if self._acting is not None or not self._queued or self._in_flight is None:
            return None
        if self._handled < self.finished or len(self._queued) < self._in_flight:
            return None
        free = [t for t in self._queued if t.blocked_at is None or t.blocked_at < self.finished]
        return min(free or self._queued, key=lambda t: t.key)


TRAJECTORY_POSITION_M = 1e-4  # a body moved when it is this far (m) ...
TRAJECTORY_QUATERNION = 1e-4  # ... or its unit quaternion this far (about 0.01 degrees) from its last written pose


def trajectory_rows(frames: list):
    """The rows of the trajectory file: (time s, body names, poses x y z qw qx qy qz) per recorded
    frame, only of the bodies that moved. A group of bodies (a robot's links, or one component) is
    written at a frame when one of its bodies moved (:data:`TRAJECTORY_POSITION_M`,
    :data:`TRAJECTORY_QUATERNION`) since the group was last written, together with the frame before
    when that was not written (so a track interpolates exactly where the motion starts); every body
    at the first and the last frame, and whenever the scene's bodies change (a support appears). A
    frame run's 4,477 s wrote every body at 20 Hz before: 726 MB."""
    for start, stop in _same_bodies(frames):
        names = np.array(frames[start][1], dtype=object)
        groups = np.unique([n.split("/", 1)[0] for n in names], return_inverse=True)[1]
        last = frames[start][2]
        yield frames[start][0], list(names), last
        written_at = np.full(groups.max() + 1, start)  # each group's last written frame
        for k in range(start + 1, stop):
            time_s, _, poses = frames[k]
            moved_body = ((np.abs(poses[:, :3] - last[:, :3]) > TRAJECTORY_POSITION_M).any(axis=1)
                          | (np.abs(poses[:, 3:] - last[:, 3:]) > TRAJECTORY_QUATERNION).any(axis=1))
            moved = np.zeros(len(written_at), dtype=bool)
            moved[groups[moved_body]] = True
            if k == len(frames) - 1:
                moved[:] = True
            held = moved & (written_at < k - 1)  # groups that start moving: their pose a frame before, too
            if held.any():
                rows = held[groups]
                yield frames[k - 1][0], list(names[rows]), frames[k - 1][2][rows]
            if moved.any():
                rows = moved[groups]
                yield time_s, list(names[rows]), poses[rows]
                last = np.where(rows[:, None], poses, last)
                written_at[moved] = k


def _same_bodies(frames: list):
    """(start, stop) index ranges of consecutive frames that record the same bodies."""
    start = 0
    for k in range(1, len(frames) + 1):
        if k == len(frames) or (frames[k][1] is not frames[start][1] and frames[k][1] != frames[start][1]):
            yield start, k
            start = k


START_GAP_M = 0.2  # between the chassis of robots that start at one home
START_STEP_M = 0.25


def starts_apart(robots: dict[str, tuple[tuple[float, float], tuple[float, float]]], work_xy,
                 obstacles: list[tuple[tuple[float, float], tuple[float, float]]] = ()) -> dict[str, tuple[float, float]]:
    """Where each robot starts (x, y m): its home, unless a robot listed before it starts there or one
    of ``obstacles`` lies there (their boxes, the chassis facing +x, would come within
    :data:`START_GAP_M`): then the first spot clear of them on the line from the work's centre
    ``work_xy`` through the home, further out in steps of :data:`START_STEP_M`. (A site may have fewer
    homes than robots: fleet 2's six robots share four; and the yard's rows may cover a home.)
    ``robots``: name -> (home (x, y) m, footprint (length, width) m); ``obstacles``: (centre (x, y) m,
    axis-aligned size (x, y) m) of what lies on the ground, e.g. the components on the yard."""
    placed: list[tuple[np.ndarray, tuple[float, float]]] = [(np.asarray(c, float), size) for c, size in obstacles]
    starts = {}
    for name, (home, footprint) in robots.items():
        spot = np.asarray(home, float)
        outward = spot - np.asarray(work_xy, float)
        outward = outward / np.linalg.norm(outward) if np.linalg.norm(outward) > 1e-9 else np.array([1.0, 0.0])

        def taken(p):
            return any(abs(p[0] - q[0]) < (footprint[0] + f[0]) / 2 + START_GAP_M
                       and abs(p[1] - q[1]) < (footprint[1] + f[1]) / 2 + START_GAP_M for q, f in placed)

        while taken(spot):
            spot = spot + START_STEP_M * outward
        placed.append((spot, footprint))
        starts[name] = (float(spot[0]), float(spot[1]))
    return starts


def starting_activities(plan, shapes: dict) -> dict[str, RcanActivity | None]:
    """Component -> the activity that says where it starts: its first *position for picking up* (it
    lies on the yard at that target), or its first *position for installing* when no activity lifts
    it (it is in place, a footing), or None when a transport comes first (not on the yard as far as
    the plan says). Components of ``shapes`` or without a size or weight are left out."""
    first: dict[str, RcanActivity | None] = {}
    lifted = {a.component_id for a in plan if a.lifts}
    for activity in plan:
        gid = activity.component_id
        if gid in first or gid in shapes or activity.size_m is None or activity.weight_kg is None:
            continue
        if activity.kind is ActivityKind.TRANSPORT:
            first[gid] = None
        elif activity.kind is ActivityKind.POSITION_FOR_PICKING_UP and gid in lifted:
            first[gid] = activity
        elif activity.kind is ActivityKind.POSITION_FOR_INSTALLING and gid not in lifted:
            first[gid] = activity
    return first


def yard_footprints(plan, shapes: dict) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """(centre (x, y) m, axis-aligned size (x, y) m) of every component that starts lying on the yard
    (:func:`starting_activities`), as the scene lays it (:func:`bimrobot.physics.placement.lying_pose`)."""
    from bimrobot.physics.placement import body_size, yaw_frame

    footprints = []
    for activity in starting_activities(plan, shapes).values():
        if activity is None or activity.kind is not ActivityKind.POSITION_FOR_PICKING_UP:
            continue
        t = activity.target
        size = np.abs(yaw_frame(t.yaw)) @ np.array(body_size(sorted(activity.size_m)))
        footprints.append(((t.x, t.y), (float(size[0]), float(size[1]))))
    return footprints


def chassis_overlaps(frames: list, footprints: dict[str, tuple[float, float]]) -> dict[str, float]:
    """Simulated seconds during which two robots' chassis (boxes of their footprints, length x width m,
    centred on the base) overlap in plan view, per pair ("A & B", only pairs that did), counted over
    the recorded ``frames`` (time s, body names, poses x y z qw qx qy qz) at :data:`RECORD_HZ`."""
    import shapely
    from bimrobot.physics.site import RECORD_HZ

    if not frames or len(footprints) < 2:
        return {}
    robots = [r for r in footprints if f"{r}/base" in frames[0][1]]
    poses = []  # (frames, robots, 7): each robot's base, where the scene's bodies changed too
    for start, stop in _same_bodies(frames):
        rows = [frames[start][1].index(f"{r}/base") for r in robots]
        poses.extend(pose[rows] for _, _, pose in frames[start:stop])
    poses = np.stack(poses)
    yaw = 2 * np.arctan2(poses[:, :, 6], poses[:, :, 3])  # the base turns about z only
    chassis = {}
    for k, robot in enumerate(robots):
        length, width = footprints[robot]
        corners = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [length / 2, width / 2]
        c, s = np.cos(yaw[:, k])[:, None], np.sin(yaw[:, k])[:, None]
        x = poses[:, k, 0:1] + c * corners[:, 0] - s * corners[:, 1]
        y = poses[:, k, 1:2] + s * corners[:, 0] + c * corners[:, 1]
        chassis[robot] = shapely.polygons(np.stack([x, y], axis=2))
    overlaps = {}
    for i, a in enumerate(robots):
        for b in robots[i + 1:]:
            frames_overlapping = int(np.count_nonzero(shapely.area(shapely.intersection(chassis[a], chassis[b])) > 1e-6))
            if frames_overlapping:
                overlaps[f"{a} & {b}"] = round(frames_overlapping / RECORD_HZ, 2)
    return overlaps


def experiment_shapes() -> dict[str, tuple[float, float, float]]:
    """Shapes of the components of the thesis' experiments (the RCAN plan gives weight and section
    only): GlobalId -> (width, depth, length) m, from their IFC models (bimrobot.bim.examples)."""
    from bimrobot.bim.examples import RCAN_EXPERIMENTS

    return {entry[1]: (entry[3][0], entry[3][1], entry[4]) for entry in RCAN_EXPERIMENTS.values()}


class MujocoBackend(DispatchingBackend):
    """Executor backend on a MuJoCo scene (see the module docstring)."""

    name = "mujoco"

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

    # --- the interface -----------------------------------------------------------------------------
    def execute(self, node: RcanNode, attempt: int = 1, ready_at_s: float = 0.0, feedback=None) -> ActivityResult:
        if self._turns.coordinated:
            return self._execute_in_turn(node, attempt, ready_at_s, feedback)
        with self._count_lock:
            self._under_way += 1
        try:
            with self._lock:  # one physical world: robots act one after the other in simulated time
                return self._execute(node, attempt, ready_at_s, feedback)
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

    def _execute(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """One activity, blocked ways waited out in real seconds (no coordinator attached)."""
        done = self._known_result(node, attempt)
        if done:
            return done
        started = self._begin(node, ready_at_s, feedback)
        for waited in range(BLOCKED_WAITS + 1):
            message, success, blocked = self._attempt(node)
            if not blocked:
                break
            if waited == BLOCKED_WAITS or not self._wait_for_other_work():
                if waited:
                    message += f" (still so after {waited} other activities)"
                break
        self._changed.notify_all()
        return self._finish(node, attempt, started, message, success, feedback)

    def _execute_in_turn(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
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
                        message, success, was_blocked = self._attempt(node)
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

    def _attempt(self, node: RcanNode) -> tuple[str, bool, bool]:
        """Try the activity (message, success, blocked by other robots' work); when its way is
        blocked, once more after the idle robots near its work have made way (:meth:`_send_idle_robots_back`)."""
        from bimrobot.physics.site import Blocked, MotionFailed

        self.engaged[node.robot] = node.component_id
        made_way = ""
        for _ in range(2):
            try:
                done = made_way + self._put_away_other(node) + getattr(self, "_" + node.kind.value)(node)
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
        resting = (site._ready_posture_cached(robot), site._stowed_posture(robot))
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

    def _run(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self.execute(node, attempt, ready_at_s, feedback)


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

    # --- activities --------------------------------------------------------------------------------
    def _move_to_component(self, node: RcanNode) -> str:
        goal = np.array([node.target.x, node.target.y])
        distance = self.site.drive(node.robot, goal)
        short = float(np.linalg.norm(self.site.base_xy_yaw(node.robot)[:2] - goal))
        note = f" (stopped {short:.2f} m short: the base does not fit at the stand-off point)" if short > 0.05 else ""
        return f"{node.kind.label} {node.component_id}: drove {distance:.2f} m{note}"

    def _position_for_picking_up(self, node: RcanNode) -> str:
        from bimrobot.physics.placement import lying_pose

        site, robot, gid = self.site, node.robot, node.component_id
        legacy = gid in self.shapes
        if gid not in site.components:
            if legacy:
                shape = self._shape(node)
                site.make_room(robot, (node.target.x, node.target.y), self._support_half(shape))
                self._spawn(node, self._placement(node, shape), "stand")
            else:  # it lies as on the yard, centred on the target (see bimrobot.physics.placement)
                target = node.target
                self._spawn_box(node.activity, lying_pose(self._size(node.activity), (target.x, target.y, target.z), target.yaw), "stand")
        grasp = site.grasp_pose(gid)
        if not legacy:  # (the stand's reach is checked: boxed in on the yard, it may stand further out)
            site.approach(robot, grasp[:2, 3], reach=[self._above(grasp), grasp])
        site.face(robot, site.body_pose(gid)[:2, 3] if legacy else grasp[:2, 3])
        grasp = site.grasp_pose(gid)  # where it is now: driving up to it may have nudged it
        # (of the arm's solutions, one touching nothing: reaching over a neighbour on the yard, the
        # nearest one had a transport's upper arm on it)
        site.move_tcp_through(robot, [self._above(grasp), grasp], avoid_contacts=True)
        grasp = site.grasp_pose(gid)
        if np.linalg.norm(site.tcp_pose(robot)[:3, 3] - grasp[:3, 3]) > 0.002:  # it moved as the arm came: once more
            site.move_tcp_through(robot, [grasp])
        return f"{node.kind.label} {gid}: gripper at the grasp pose"

    def _pick_up(self, node: RcanNode) -> str:
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if gid not in site.components:
            raise MotionFailed(f"{gid} is not in the scene: position for picking up comes first")
        site.close_gripper(robot, gid)
        try:
            site.move_arm(robot, site.solve(robot, self._above(site.tcp_pose(robot))))
        except MotionFailed as failure:
            site.open_gripper(robot)
            site.step(1.0)
            mass = site.components[gid].mass
            payload = self.capabilities.by_name[robot].payload_kg
            raise MotionFailed(f"{gid} weighs {mass:.1f} kg: the arm of {robot} (rated payload {payload:.1f} kg, "
                               f"{self.families[robot].family} model) cannot lift it: {failure}") from None
        return f"{node.kind.label} {gid}: held and lifted {LIFT_M:.2f} m"

    def _transport(self, node: RcanNode) -> str:
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if site.robots[robot].holding != gid:
            down = self._set_down_near(gid, (node.target.x, node.target.y)) if node.activity.releases_robot else None
            if down is None:
                raise MotionFailed(f"robot {robot} does not hold {gid} to transport it")
            site.move_arm(robot, site._ready_posture_cached(robot))  # what the attempt before did not finish
            return f"{node.kind.label} {gid}: set down at ({down[0]:.2f}, {down[1]:.2f}) by the attempt before"
        legacy = gid in self.shapes
        if legacy:
            site.move_arm(robot, site._ready_posture_cached(robot))
        else:
            self._to_carry(robot)
        distance = site.drive(robot, (node.target.x, node.target.y))
        if not node.activity.releases_robot:
            return f"{node.kind.label} {gid}: carried {distance:.2f} m"
        if legacy:  # set it down in front of the base and let go
            self._set_down(robot, gid)
            return f"{node.kind.label} {gid}: carried {distance:.2f} m"
        spot = self._lay_down(robot, gid, (node.target.x, node.target.y))
        return f"{node.kind.label} {gid}: carried {distance:.2f} m, set down at ({spot[0]:.2f}, {spot[1]:.2f})"

    def _set_down_near(self, gid: str, near, within_m: float = 4.0):
        """Where (xy) ``gid`` lies on the ground within ``within_m`` of ``near``, held by no robot (an
        attempt of a transport set it down and then failed, e.g. its arm's retreat), or None."""
        site = self.site
        if gid not in site.components or any(r.holding == gid for r in site.robots.values()):
            return None
        centre, half = site.component_box(gid)
        on_ground = centre[2] - half[2] < site.ground_z + 0.02
        return centre[:2] if on_ground and np.linalg.norm(centre[:2] - np.asarray(near, float)) <= within_m else None

    def _to_carry(self, robot: str) -> None:
        """The held component to the carry posture over the base: pulled in level to the arm's
        working distance when it was picked up further out (below the carry height), then straight up, the tool down (a long
        member would otherwise dip its ends into the ground), then across the base."""
        from bimrobot.physics import motion

        site = self.site
        carry = site.carry_posture(robot)
        goal = site._tcp_of(robot, carry)
        here = site.tcp_pose(robot)
        arm = site.arm_base_pose(robot)[:2, 3]
        out = here[:2, 3] - arm
        if np.linalg.norm(out) > site.working_distance(robot) and here[2, 3] < goal[2]:
            # (picked from a stand beyond the working distance, a 290 kg column could not be lifted
            # straight up there: the arm's branch ended at the edge of its workspace; one held high
            # already, by an install that stopped, is not pulled in up there, out of reach)
            here[:2, 3] = arm + out * site.working_distance(robot) / np.linalg.norm(out)
            site.move_tcp_through(robot, [here])
        up = site.tcp_pose(robot)
        up[2, 3] = max(up[2, 3], goal[2])
        site.move_tcp_through(robot, [up])
        # then over and turned in steps (30 degrees, 0.3 m at most), the tool kept pointing down: one
        # joint-space move would tilt the member on its way
        start_yaw = math.atan2(up[1, 0], up[0, 0])
        ik = site.robots[robot].ik
        data = site.mj.MjData(ik.model)
        data.qpos[:6] = carry
        site.mj.mj_kinematics(ik.model, data)
        end = site.arm_base_pose(robot)[:3, :3] @ data.site("tcp").xmat.reshape(3, 3)
        turn = math.remainder(math.atan2(end[1, 0], end[0, 0]) - start_yaw, 2 * math.pi)
        count = max(1, math.ceil(max(abs(turn) / math.radians(30), np.linalg.norm(goal - up[:3, 3]) / 0.3)))
        poses = [motion.pose(motion.tool_down(start_yaw + turn * k / count), up[:3, 3] + (goal - up[:3, 3]) * k / count)
                 for k in range(1, count + 1)]
        site.move_tcp_through(robot, poses)
        site.move_arm(robot, carry)

    def _lay_down(self, robot: str, gid: str, near) -> np.ndarray:
        """Set the held component down lying on the ground at the free spot nearest ``near`` where
        the largest robot of the fleet can stand beside it to pick it up again, and let go."""
        from bimrobot.physics.placement import lying_pose

        site = self.site
        spot, yaw = self._free_spot(robot, gid, np.asarray(near, float))
        size = self._size_of(gid)
        half = (np.abs(lying_pose(size, (0, 0, 0), yaw)[:3, :3]) @ np.array(site.components[gid].size) / 2)[:2]
        site.approach(robot, spot, low_keep_out=[(spot, half)])
        tcp = site.tcp_pose(robot)
        grip = site.held_in_tcp(robot)
        best = None
        for turn in (0.0, math.pi):  # the box is the same turned half a turn: the smaller wrist turn
            body = lying_pose(size, (spot[0], spot[1], site.ground_z + size[0] / 2 + 0.002), yaw + turn)
            goal = body @ np.linalg.inv(grip)
            change = abs(math.remainder(math.atan2(goal[1, 0], goal[0, 0]) - math.atan2(tcp[1, 0], tcp[0, 0]), 2 * math.pi))
            if best is None or change < best[0]:
                best = (change, goal)
        site.move_tcp_through(robot, self._carry_waypoints(robot, gid, best[1]))
        self._release(robot)
        return spot

    def _free_spot(self, robot: str, gid: str, near: np.ndarray) -> tuple[np.ndarray, float]:
        """(centre xy, yaw) of a spot on the ground for the component lying (0.3 m clear of every
        obstacle and of every other robot as it stands: a component let go on an arm at work would
        push it away) beside which the largest robot of the fleet finds a free stand within reach;
        the nearest to ``near`` of rings 1 m apart."""
        from bimrobot.physics.site import Blocked

        site = self.site
        length, width, _ = site.components[gid].size
        big = max(site.robots, key=lambda name: math.hypot(*site.robots[name].model.footprint))
        model = site.robots[big].model
        reach = site.working_distance(big) + model.arm_mount[0]
        low, tall = site.obstacles(big, split=True)
        tall = tall + [(b.centre[:2], b.half_xy) for b in self.installed.values()]
        others = [site.robot_extent(name) for name in site.robots if name != robot]
        boxes = low + tall + others
        for ring in range(8):
            count = 1 if ring == 0 else 8 * ring
            for k in range(count):
                angle = 2 * math.pi * k / count
                centre = near + ring * np.array([math.cos(angle), math.sin(angle)])
                for yaw in (0.0, math.pi / 2):
                    along = np.array([math.cos(yaw), math.sin(yaw)])
                    half = np.abs(np.array([[along[0], -along[1]], [along[1], along[0]]])) @ np.array([length, width]) / 2
                    if site._blocked(centre, boxes, 0.0) or any(
                            np.all(np.abs(centre - c) < h + half + 0.3) for c, h in boxes):
                        continue
                    across = np.array([-along[1], along[0]])
                    mine = low + [(centre, half)]
                    if any(site._clear(big, centre + side * reach * across, mine, tall) for side in (1, -1)):
                        return centre, yaw
        raise Blocked(f"no free spot near ({near[0]:.2f}, {near[1]:.2f}) to set {gid} down where a robot can reach it")

    def _set_down(self, robot: str, gid: str) -> None:
        site = self.site
        tcp = site.tcp_pose(robot)
        below = tcp.copy()
        grip = site.held_in_tcp(robot)
        below[2, 3] += site.ground_z + 0.002 - (tcp @ grip)[2, 3]
        site.move_arm(robot, site.solve(robot, below), check_contacts=False)
        site.open_gripper(robot)
        site.move_arm(robot, site._ready_posture_cached(robot))

    def _position_for_installing(self, node: RcanNode) -> str:
        from bimrobot.physics.site import Blocked, MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if gid in self.shapes:
            return self._position_for_installing_as_given(node)
        if gid not in site.components:
            if node.activity.lifts:
                raise MotionFailed(f"{gid} is not in the scene: it was never picked up")
            self._spawn_in_place(node.activity)  # in place already (a footing): it enters the scene where it is installed
        if site.robots[robot].holding != gid:  # work on a component in place (a further connection)
            # a stand from which the arm reaches its work touching nothing on the way (a stand taken
            # unchecked, beside another robot, had the gripper meet the next member at the joint);
            # when the check finds none, the nearest free stand, unchecked (the check is strict: the
            # work point moves with the stand, and the move may still go another way round)
            def work_from(xy, yaw):
                return self._clear_work_poses(robot, gid, (np.asarray(xy, float), float(yaw)))

            wrist = self._wrist_point(robot, self._work_poses(robot, gid)[-1])
            try:
                site.approach(robot, wrist, reach=work_from)
            except Blocked:
                site.approach(robot, wrist)
            site.move_tcp_through(robot, self._clear_work_poses(robot, gid), avoid_contacts=True)
            return f"{node.kind.label} {gid}: gripper at its work point"
        box = self._installed_box(node.activity)
        self._check_support_place(gid, box, robot)
        if np.abs(site.arm_q(robot) - site.carry_posture(robot)).max() > 0.05:
            self._to_carry(robot)  # it may drive and turn to its stand now
        # stand where the arm's wrist (behind the tool centre point, along the tool) works comfortably
        # its installed turn about its axis is chosen once, here: the stands are sought around the
        # wrist point it gives, and checked with it (chosen again at the stand, it differed, and
        # columns failed 125-148 mm out of reach on the way)
        target, goal = self._install_pose(robot, gid, box)
        def path_from(xy, yaw):  # every tool pose of the move onto the seat, the robot at that stand
            tcp = site.moved_to(robot, xy, yaw) @ site.commanded_tcp_pose(robot)
            return site.tcp_path(robot, tcp, self._carry_waypoints(robot, gid, goal, tcp))

        site.approach(robot, self._wrist_point(robot, goal), keep_out=[(box.centre[:2], box.half_xy)], reach=path_from)
        goal = self._tcp_goal(robot, target)  # as it is held now
        # (from where the arm settles, as the stand's reach was checked)
        waypoints = self._carry_waypoints(robot, gid, goal, site.commanded_tcp_pose(robot))
        # (to the arm solutions touching nothing, as the stand's reach was checked)
        site.move_tcp_through(robot, waypoints[:-1], avoid_contacts=True)
        # its seat appears once it is held above it: carried low at the robot's front, a beam is
        # where its prop stands, and the prop appeared around the arm holding it
        self._support_for(gid, box, robot)
        site.move_tcp_through(robot, waypoints[-1:], onto_seat=True, avoid_contacts=True)
        self.targets[gid], self.installed[gid] = target, box
        again = self._seat_at_place(robot, gid)
        if node.activity.releases_robot:  # PositionFixed: let go, the assembly robots fix it
            self._release(robot)
        return f"{node.kind.label} {gid}: at its target ({box.kind}){self._set_down_again(again)}"

    def _position_for_installing_as_given(self, node: RcanNode) -> str:
        """The thesis' experiments: the component's shape is given and it stands upright on its target."""
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if gid not in site.components:
            raise MotionFailed(f"{gid} is not in the scene: it was never picked up")
        shape = site.components[gid].size
        target = self._placement(node, shape)
        site.make_room(robot, target[:2, 3], self._support_half(shape))
        if abs(target[2, 3] - site.ground_z) > SUPPORT_MIN_Z_M and not self._support_at(target):
            if target[2, 3] < site.ground_z:
                site.add_pit(target[:2, 3], self._support_half(shape))
            self._add_support(gid, target, "support")
        site.face(robot, target[:2, 3])
        holding = site.robots[robot].holding == gid
        if holding:  # the tcp goes where the component's origin lands on the target, as gripped
            grip = site.held_in_tcp(robot)
            goal = target @ np.linalg.inv(grip)
            goal[2, 3] += 0.001  # released 1 mm above its seat
        else:  # work on a component in place (a further connection): reach its grasp pose
            goal = site.grasp_pose(gid)
        site.move_tcp_through(robot, [self._above(goal), goal])
        self.targets[gid] = target
        if holding and node.activity.releases_robot:
            self._release(robot)
        return f"{node.kind.label} {gid}: at its target"

    def _install(self, node: RcanNode) -> str:
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if gid not in site.components:
            if node.activity.lifts or gid in self.shapes:
                raise MotionFailed(f"{gid} is not in the scene: it was never picked up")
            self._spawn_in_place(node.activity)
        holder = next((name for name, state in site.robots.items() if state.holding == gid), None)
        if holder == robot:
            self._release(robot)
        if gid in self.shapes and gid not in self.targets:
            self.targets[gid] = self._placement(node, site.components[gid].size)
        if gid not in self.targets:  # no activity of this run put it at its installed pose: nothing to measure against
            where = site.body_pose(gid)[:3, 3]
            raise MotionFailed(f"{gid} was not placed at its installed pose by any activity of this run (it lies at "
                               f"({where[0]:.2f}, {where[1]:.2f}, {where[2]:.2f})): it cannot be installed there")
        # another robot holds it on its seat while this one fixes it: it sets it down again if it sits off its place
        again = self._seat_at_place(holder, gid) if holder not in (None, robot) else 0
        site.step(SETTLE_S)
        before = self._centre(gid, site.body_pose(gid))
        site.step(SETTLE_S)
        error_m, error_deg = self._placement_error(gid)
        drift_m = float(np.linalg.norm(self._centre(gid, site.body_pose(gid)) - before))
        self.placements[gid] = (error_m, error_deg)
        measured = (f"placement error {error_m * 1000:.1f} mm, {error_deg:.2f} degrees; moved {drift_m * 1000:.2f} mm "
                    f"in {SETTLE_S:g} s{self._set_down_again(again, holder)}")
        if error_m > POSITION_TOLERANCE_M or error_deg > ANGLE_TOLERANCE_DEG or drift_m > 1e-3:
            raise MotionFailed(f"{gid} does not rest at its BIM pose: {measured} (tolerance "
                               f"{POSITION_TOLERANCE_M * 1000:.0f} mm, {ANGLE_TOLERANCE_DEG:g} degree, 1 mm)")
        return f"{node.kind.label} {gid}: {measured}"

    def _centre(self, gid: str, pose: np.ndarray) -> np.ndarray:
        """World position (m) of the middle of the component's box when its body is at ``pose`` (4x4)."""
        return (pose @ np.array([0.0, 0.0, self.site.components[gid].size[2] / 2, 1.0]))[:3]

    def _placement_error(self, gid: str) -> tuple[float, float]:
        """(distance in m between the middle of the component's box where it is and at its installed
        pose, angle in degrees between the two poses)."""
        from bimrobot.physics.placement import box_angle

        pose, target = self.site.body_pose(gid), self.targets[gid]
        return (float(np.linalg.norm(self._centre(gid, pose) - self._centre(gid, target))),
                math.degrees(box_angle(pose[:3, :3], target[:3, :3])))

    def _seat_at_place(self, robot: str, gid: str) -> int:
        """While the component ``robot`` holds on its seat is off its installed pose by more than the
        tolerance, lift it RESEAT_LIFT_M and set it down again at that pose (at most RESEAT_TRIES
        times); returns how often it did. Set down while the arm still lagged behind its path, a
        290 kg column sat 13 mm off its place and friction kept it there."""
        site = self.site
        for again in range(RESEAT_TRIES + 1):
            error_m, error_deg = self._placement_error(gid)
            if again == RESEAT_TRIES or (error_m <= POSITION_TOLERANCE_M and error_deg <= ANGLE_TOLERANCE_DEG):
                return again
            goal = self._tcp_goal(robot, self.targets[gid])
            lifted, over = site.tcp_pose(robot), goal.copy()
            lifted[2, 3] += RESEAT_LIFT_M
            over[2, 3] += RESEAT_LIFT_M
            site.move_tcp_through(robot, [lifted, over])
            site.move_tcp_through(robot, [goal], onto_seat=True)
        return RESEAT_TRIES

    @staticmethod
    def _set_down_again(times: int, robot: str | None = None) -> str:
        """The note of :meth:`_seat_at_place`'s work for an activity's message ("" when none)."""
        if not times:
            return ""
        return f" (set down again {times} time{'s' if times > 1 else ''}{f' by {robot}' if robot else ''})"

    # --- placing components ------------------------------------------------------------------------
    def _size(self, activity) -> tuple[float, float, float]:
        from bimrobot.physics.site import MotionFailed

        if activity.size_m is None:
            raise MotionFailed(f"the shape of {activity.component_id} is unknown to the mujoco backend (the plan gives "
                               f"no size; it knows {', '.join(self.shapes)}): give it with shapes={{GlobalId: (w, d, h)}}")
        return tuple(float(v) for v in activity.size_m)

    def _installed_box(self, activity):
        from bimrobot.physics.placement import installed_box

        others = [box for gid, box in self.installed.items() if gid != activity.component_id]
        target = activity.target
        return installed_box(self._size(activity), (target.x, target.y, target.z), target.yaw, others)

    def _spawn_box(self, activity, placement: np.ndarray, support: str):
        """Put the component's box (body size (L, b, a)) at ``placement``, on a support when it is
        above the ground and in a pit when below."""
        from bimrobot.physics.placement import body_size
        from bimrobot.physics.site import Component, MotionFailed

        if activity.weight_kg is None:
            raise MotionFailed(f"the weight of {activity.component_id} is unknown: the scene cannot simulate it")
        size = body_size(self._size(activity))
        half = (np.abs(placement[:3, :3]) @ np.array(size) / 2)[:2] + 0.01
        centre = (placement @ np.array([0.0, 0.0, size[2] / 2, 1.0]))[:3]
        # its lowest point, whichever way it is turned (an upright member's body z is horizontal)
        bottom = float(centre[2] - (np.abs(placement[:3, :3]) @ np.array(size) / 2)[2])
        self._support_under(activity.component_id, centre[:2], bottom, half, support)
        self.site.add_component(Component(activity.component_id, size, float(activity.weight_kg)), placement)

    def _support_under(self, gid: str, centre_xy, bottom_z: float, half_xy, kind: str, robot: str | None = None,
                       prop: bool = False) -> None:
        """A support under ``gid`` from the ground (or a pit's floor) up to ``bottom_z`` (m); robots
        make way for it first, unless it is a ``prop`` (see MujocoSite.add_support: they pass through)."""
        site = self.site
        if abs(bottom_z - site.ground_z) <= SUPPORT_MIN_Z_M:
            return
        if not prop:
            self._make_way(gid, centre_xy, half_xy, bottom_z, robot)
        if bottom_z < site.ground_z:
            site.add_pit(centre_xy, half_xy)
        site.add_support(f"{kind}/{gid}/{len(site.supports) + len(site.props)}", centre_xy, bottom_z, half_xy, prop)

    def _make_way(self, gid: str, centre_xy, half_xy, top_z: float, robot: str | None) -> None:
        """Before a support appears at ``centre_xy`` (a box of ``half_xy``, m, up to ``top_z``), every
        robot whose chassis stands on it or within the clearance drives aside, and every empty arm
        that reaches into it is stowed: ``robot`` (the one at work, in its carry posture) and any
        other waiting between activities (an arm is left where its last activity ended). Blocked
        when another one holds a component or has its gripper at one: its own work comes first."""
        from bimrobot.physics.site import Blocked, MotionFailed

        site = self.site
        box = (np.asarray(centre_xy, float)[:2], np.asarray(half_xy, float))
        for name, arm_in in self._in_the_way(box, top_z):
            self._raise_if_busy(name, gid, robot)
            try:
                if arm_in:
                    site.stow_arm(name)
                site.make_room(name, box[0], box[1])
            except MotionFailed as failure:
                raise Blocked(f"{name} stands where the support of {gid} goes and cannot move aside: {failure}") from None

    def _in_the_way(self, box, top_z: float) -> list[tuple[str, bool]]:
        """(robot, whether it is by its empty arm) for each robot whose chassis stands on ``box``
        (centre xy, half size xy; m) or within the clearance, or whose empty arm reaches into it
        below ``top_z``."""
        site, out = self.site, []
        for name in site.robots:
            x, y, yaw = site.base_xy_yaw(name)
            arm_in = not site.robots[name].holding and site.arm_within(name, box[0], box[1], top_z)
            if arm_in or not site._footprint_clear(name, (x, y), yaw, [box]):
                out.append((name, arm_in))
        return out

    def _raise_if_busy(self, name: str, gid: str, robot: str | None) -> None:
        """Blocked when robot ``name``, in the way of the support of ``gid``, is not ``robot`` and
        holds a component or has its gripper at one."""
        from bimrobot.physics.site import Blocked

        busy = name != robot and (self.site.robots[name].holding or self.at_work.get(name))
        if busy:
            raise Blocked(f"{name} stands where the support of {gid} goes, at work on {busy}")

    def _support_geometry(self, box) -> tuple[np.ndarray, np.ndarray, bool]:
        """(centre xy, half size xy, whether a prop) of the support an installed box rests on: a
        pedestal under an upright or flat one, a prop under the middle third (at most 1 m) of a
        horizontal member (the connections it hangs from in the building are not modelled)."""
        if box.kind == "horizontal":
            local = np.array([min(box.extents[0] / 6, 0.5), box.extents[1] / 2 + 0.01, 0.0])
            return box.centre[:2], (np.abs(box.frame) @ local)[:2], True
        return box.centre[:2], box.half_xy + 0.01, False

    def _support_for(self, gid: str, box, robot: str) -> None:
        """The support an installed box rests on (:meth:`_support_geometry`), robots making way."""
        centre, half, prop = self._support_geometry(box)
        self._support_under(gid, centre, box.bottom_z, half, "support", robot, prop=prop)

    def _check_support_place(self, gid: str, box, robot: str) -> None:
        """Blocked, before the robot lifts ``gid`` towards its seat, when another robot at work stands
        where its support will appear (found only once the component was held high, the robot was
        left holding a 4 m column up there, and every try after failed from that posture)."""
        centre, half, prop = self._support_geometry(box)
        if prop or abs(box.bottom_z - self.site.ground_z) <= SUPPORT_MIN_Z_M:
            return
        for name, _ in self._in_the_way((centre, half), box.bottom_z):
            self._raise_if_busy(name, gid, robot)

    def _spawn_in_place(self, activity) -> None:
        from bimrobot.physics.placement import body_pose, body_rotations

        box = self._installed_box(activity)
        placement = body_pose(self._size(activity), box, body_rotations(self._size(activity), box)[0])
        self._spawn_box(activity, placement, "support")
        self.targets[activity.component_id], self.installed[activity.component_id] = placement, box

    def _spawn_plan(self, plan) -> None:
        """Put every component of ``plan`` (RCAN activities) where it starts: on the yard (lying, at the
        target of its first *position for picking up*) or, when no activity lifts it, in place (a
        footing). Components without a size or a weight stay out (their activities fail saying so)."""
        from bimrobot.physics.placement import lying_pose

        for activity in starting_activities(plan, self.shapes).values():
            if activity is None:
                continue
            if activity.kind is ActivityKind.POSITION_FOR_PICKING_UP:
                t = activity.target
                self._spawn_box(activity, lying_pose(self._size(activity), (t.x, t.y, t.z), t.yaw), "stand")
            else:
                self._spawn_in_place(activity)

    def _install_pose(self, robot: str, gid: str, box) -> tuple[np.ndarray, np.ndarray]:
        """(component pose, tcp goal) on ``box``: of the rotations that fit the box, the one whose tool
        points down, else away from the robot (its side towards the robot is where it is held)."""
        from bimrobot.physics.placement import body_pose, body_rotations

        site = self.site
        grip = site.held_in_tcp(robot)
        arm = site.arm_base_pose(robot)[:2, 3]
        toward = box.centre[:2] - arm
        toward /= max(float(np.linalg.norm(toward)), 1e-9)
        size = self._size_of(gid)
        best = None
        for rotation in body_rotations(size, box):
            target = body_pose(size, box, rotation)
            goal = target @ np.linalg.inv(grip)
            tool = goal[:3, 2]
            score = 2.0 * -tool[2] + float(tool[:2] @ toward)
            if best is None or score > best[0]:
                best = (score, target, goal)
        return best[1], self._tcp_goal(robot, best[1])

    def _tcp_goal(self, robot: str, target: np.ndarray) -> np.ndarray:
        """The tool pose (4x4, world) that puts the held component at ``target``, as it is held now,
        1 mm above its seat (where it is released)."""
        goal = target @ np.linalg.inv(self.site.held_in_tcp(robot))
        goal[2, 3] += 0.001
        return goal

    def _wrist_point(self, robot: str, goal: np.ndarray) -> np.ndarray:
        """Where the arm's wrist is (xy, m) when its tool centre point is at ``goal``."""
        from bimrobot.physics.robot import GRIPPER_LENGTH_M

        model = self.families[robot]
        return (goal[:3, 3] - goal[:3, 2] * (model.dh[5][1] + GRIPPER_LENGTH_M * model.scale))[:2]

    def _size_of(self, gid: str) -> tuple[float, float, float]:
        length, b, a = self.site.components[gid].size
        return (a, b, length)

    def _carry_waypoints(self, robot: str, gid: str, goal: np.ndarray, tcp: np.ndarray | None = None) -> list[np.ndarray]:
        """Tool poses from where the held component is (the tool at ``tcp``, default where it is) to
        ``goal``: up to a height where it can turn
        to its installed orientation clear of the ground, turn, up to the goal's height (and
        :data:`LIFT_M`), over the goal, down onto it. It turns low and rises turned: a beam held from
        above rolls onto its side, and the tool, then level, keeps the wrist at the tool's height (held
        tool-down at a beam's height, the wrist would be a metre above the tool, beyond the arm)."""
        site = self.site
        tcp = site.tcp_pose(robot) if tcp is None else tcp
        grip = site.held_in_tcp(robot)
        size = np.array(site.components[gid].size)
        corners = np.array([[x, y, z, 1.0] for x in (-size[0] / 2, size[0] / 2) for y in (-size[1] / 2, size[1] / 2)
                            for z in (0.0, size[2])])

        def lowest_below_tcp(pose: np.ndarray) -> float:
            return float(((pose @ grip) @ corners.T)[2].min() - pose[2, 3])

        clear = site.ground_z + 0.2
        low = max(tcp[2, 3], clear - lowest_below_tcp(goal), clear - lowest_below_tcp(tcp))
        safe = max(low, goal[2, 3] + LIFT_M)
        up = tcp.copy()
        up[2, 3] = low
        turned = goal.copy()
        turned[:3, 3] = up[:3, 3]
        raised = turned.copy()
        raised[2, 3] = safe
        over = goal.copy()
        over[2, 3] = safe
        above = self._above(goal)
        waypoints = []
        for pose in (up, turned, raised, over, above, goal):
            last = waypoints[-1] if waypoints else tcp
            if np.linalg.norm(pose[:3, 3] - last[:3, 3]) > 1e-3 or np.abs(pose[:3, :3] - last[:3, :3]).max() > 1e-3:
                waypoints.append(pose)
        return waypoints

    def _clear_work_poses(self, robot: str, gid: str, stand=None) -> list[np.ndarray]:
        """The work poses (:meth:`_work_poses`) turned about the tool's axis by the first multiple of
        45 degrees at which the arm reaches both without touching anything (a 4 m arm's wrist is
        half a metre wide: turned one way it lies against the column standing on the footing it
        works on); the unturned ones when no turn is clear (the move then fails saying what it hit).
        ``stand``: (xy, yaw) of the base to find them for (m, rad), instead of where it stands."""
        from bimrobot.physics import motion
        from bimrobot.physics.site import MotionFailed

        site = self.site
        arm_base = None if stand is None else site.moved_to(robot, *stand) @ site.arm_base_pose(robot)
        poses = self._work_poses(robot, gid, arm_base)
        for k in (0, 1, -1, 2, -2, 3, -3, 4):
            turned = [pose @ motion.planar(0.0, 0.0, k * math.pi / 4) for pose in poses]  # about the tool's z
            try:
                if not any(site.arm_contacts_at(robot, site.solve(robot, pose, True, arm_base, stand), stand=stand)
                           for pose in turned):
                    return turned
            except MotionFailed:
                if stand is not None:  # out of reach there: a turn about the tool's axis will not reach
                    return poses  # either (a stand is checked for many stands: each try costs ~20 IK solves)
                continue
        return poses

    def _work_poses(self, robot: str, gid: str, arm_base: np.ndarray | None = None) -> list[np.ndarray]:
        """Where the tool works on a component in place (its connection nodes are not in the plan): at
        the point of its surface nearest the arm's shoulder, 5 cm off it, the tool pointing at it (down
        onto a top face, level onto a side of a tall one), and 0.10 m back from there first.
        ``arm_base``: the arm's base (4x4, world) to find them for, instead of where it is."""
        from bimrobot.physics import motion

        site = self.site
        arm_base = site.arm_base_pose(robot) if arm_base is None else arm_base
        pose = site.body_pose(gid)
        size = np.array(site.components[gid].size)
        corners = np.array([[x, y, z, 1.0] for x in (-size[0] / 2, size[0] / 2) for y in (-size[1] / 2, size[1] / 2)
                            for z in (0.0, size[2])])
        world = (pose @ corners.T)[:3].T
        low, high = world.min(axis=0), world.max(axis=0)
        model = self.families[robot]
        shoulder = arm_base[:3, 3] + np.array([0.0, 0.0, model.dh[0][1]])
        point = np.clip(shoulder, low + 0.05, np.maximum(high - 0.05, low + 0.05))
        if shoulder[2] >= high[2]:  # onto its top face
            yaw = math.atan2(point[1] - shoulder[1], point[0] - shoulder[0])
            goal = motion.pose(motion.tool_down(yaw), (point[0], point[1], high[2] + 0.05))
        else:  # level onto the side facing the arm
            side = np.clip(shoulder[:2], low[:2], high[:2])
            toward = side - shoulder[:2]
            toward = toward / max(float(np.linalg.norm(toward)), 1e-9)
            z_axis = np.array([toward[0], toward[1], 0.0])
            x_axis = np.array([0.0, 0.0, -1.0])
            goal = motion.pose(np.column_stack([x_axis, np.cross(z_axis, x_axis), z_axis]),
                               (side[0] - 0.05 * toward[0], side[1] - 0.05 * toward[1], point[2]))
        back = goal.copy()
        back[:3, 3] -= goal[:3, 2] * LIFT_M
        return [back, goal]

    # --- helpers -----------------------------------------------------------------------------------
    @staticmethod
    def _above(pose: np.ndarray) -> np.ndarray:
        """``pose`` (4x4, world) raised by LIFT_M: where the tool comes down from onto a grasp."""
        above = pose.copy()
        above[2, 3] += LIFT_M
        return above

    def _release(self, robot: str) -> None:
        """Let go of the held component and take the arm back from it (:meth:`_retreat`)."""
        self.site.open_gripper(robot)
        self._retreat(robot)

    def _retreat(self, robot: str) -> None:
        """Take an empty arm back from where its tool works: along the tool's axis (the way it came
        in), for the heavy variant straight back over the base, then to the ready posture."""
        from bimrobot.physics.site import MotionFailed

        site = self.site
        away = site.tcp_pose(robot)  # back out along the tool's axis (up, for a tool pointing down)
        away[:3, 3] -= away[:3, 2] * LIFT_M * max(1.0, self.families[robot].scale / 2)
        try:
            site.move_arm(robot, site.solve(robot, away), check_contacts=False)
        except MotionFailed:  # the component is down already: the arm goes to its ready posture below
            pass
        if self.families[robot].family == "heavy":  # then straight back over the base, as it is turned:
            back = away.copy()  # a joint-space swing of a metres-long arm would sweep through what it placed
            back[:3, 3] = site._tcp_of(robot, site._ready_posture_cached(robot))
            try:
                site.move_arm(robot, site.solve(robot, back))
            except MotionFailed:  # not reachable turned so: to the ready posture directly
                pass
        site.move_arm(robot, site._ready_posture_cached(robot))

    def _shape(self, node: RcanNode) -> tuple[float, float, float]:
        from bimrobot.physics.site import MotionFailed

        shape = self.shapes.get(node.component_id) or node.activity.size_m  # (w, d, length), as planned
        if shape is None:
            raise MotionFailed(f"the shape of {node.component_id} is unknown to the mujoco backend (it knows "
                               f"{', '.join(self.shapes)}): give it with shapes={{GlobalId: (w, d, h)}}")
        return shape

    def _placement(self, node: RcanNode, shape) -> np.ndarray:
        """The component's origin (bottom face centre) when its centre is at the node's target (4x4)."""
        from bimrobot.physics.motion import planar

        return planar(node.target.x, node.target.y, node.target.yaw, node.target.z - shape[2] / 2)

    @staticmethod
    def _support_half(shape) -> tuple[float, float]:
        return (max(shape[0], shape[1]) / 2 + 0.01,) * 2

    def _spawn(self, node: RcanNode, placement: np.ndarray, support: str) -> None:
        from bimrobot.physics.site import Component, MotionFailed

        if node.activity.weight_kg is None:
            raise MotionFailed(f"the weight of {node.component_id} is unknown: the scene cannot simulate it")
        shape = self._shape(node)
        if abs(placement[2, 3] - self.site.ground_z) > SUPPORT_MIN_Z_M:
            if placement[2, 3] < self.site.ground_z:
                self.site.add_pit(placement[:2, 3], self._support_half(shape))
            self._add_support(node.component_id, placement, support, shape)
        self.site.add_component(Component(node.component_id, shape, float(node.activity.weight_kg)), placement)

    def _add_support(self, gid: str, placement: np.ndarray, kind: str, shape=None) -> None:
        half = self._support_half(shape or self.site.components[gid].size)
        self.site.add_support(f"{kind}/{gid}/{len(self.site.supports)}", placement[:2, 3], placement[2, 3], half)

    def _support_at(self, placement: np.ndarray) -> bool:
        return any(np.all(np.abs(placement[:2, 3] - c[:2]) <= h[:2]) and abs(c[2] + h[2] - placement[2, 3]) < 1e-3
                   for c, h in self.site.supports)

    def write_trajectory(self, path: Path) -> Path:
        """The recorded body poses as CSV (time_s, body, x, y, z, qw, qx, qy, qz), through bimrobot.io:
        see :func:`trajectory_rows` for which frames of which bodies are written."""
        from bimrobot import io

        with io.atomic_output_file(path, option="trajectory") as tmp:
            with open(tmp, "w", newline="", encoding="utf-8") as handle:
                handle.write(f"# {io.signature('rcan mujoco trajectory')}\n")
                writer = csv.writer(handle)
                writer.writerow(["time_s", "body", "x", "y", "z", "qw", "qx", "qy", "qz"])
                for time_s, names, poses in trajectory_rows(self.site.frames):
                    writer.writerows([f"{time_s:.3f}", name, *(f"{v:.6f}" for v in row)] for name, row in zip(names, poses))
        return path
