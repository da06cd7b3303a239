"""The ``sim`` backend: built-in kinematic robots that take travel and handling time.

Each robot has a mobile base (moves at ``speed_m_s`` in the xy plane), a manipulator (reaches
``reach_m`` horizontally from the base, moves the gripper at ``arm_speed_m_s``) and a gripper (takes
``handling_s[activity]`` to pick up or install). Robots check what a real robot would refuse: a target
out of the arm's reach, a pick-up without the gripper at the grasp pose, a component heavier than the
payload, transporting a component it does not hold, touching a component another robot holds. A
transport whose node releases the robot sets the component down at the drop-off point (the transport's
goal) and lets go; a later pick-up there takes it again. Any activity can also fail at random with
``failure_probability``; the draw is seeded by ``(seed, activity id, attempt)`` so a resumed run sees
the same failures as an uninterrupted one.

Time: every robot keeps its own clock in simulated seconds; an activity starts at
``max(robot clock, ready_at_s)`` (its predecessors' finish and its planned start). How long it takes is
the one time model's (:mod:`bimrobot.sco.timing`), the same as `simulate`'s: a drive (move to component,
transport) takes the distance between the points the robot works at (the activity's ``work_point``; the
base stands beside them) over its speed, a transport that sets the component down adds the unload time,
a pick-up from the yard the load time, a positioning the time per node, an install the time per
assembly point; arm motions take their distance over the arm's speed (nothing for a fleet robot, whose
handling times include them). Nothing here depends on the wall clock or on the order in which threads
run, so the same plan gives the same times. ``time_scale`` real seconds are slept per simulated second
(0: no sleeping, the default; 1: real time).

The world (robot poses, components, executed goals) lives in SQLite, in memory by default or in the
run's state database, so it survives a crash like a real site does. Executed goals are recorded in the
same transaction as their effect, keyed by activity id: a goal sent twice runs once, and a goal
whose activity already succeeded (any attempt) is refused with the earlier result.
"""

from __future__ import annotations

import json
import threading
import time
import zlib
from pathlib import Path

import numpy as np

from bimrobot.coordination.fleet import Fleet, RobotSpec
from bimrobot.rcan.activities import ActivityKind, Pose
from bimrobot.rcan.backends.interfaces import ActivityResult, DispatchingBackend
from bimrobot.rcan.node import RcanNode
from bimrobot.rcan.state_manager import connect_state_db, write_lock
from bimrobot.sco import timing
from bimrobot.tasks import Task

GRASP_TOLERANCE_M = 0.05
ARM_STOW_HEIGHT_M = 0.5

SCHEMA = """
CREATE TABLE IF NOT EXISTS sim_robot (
    name TEXT PRIMARY KEY, x REAL, y REAL, z REAL, arm TEXT, holding TEXT, clock_s REAL);
CREATE TABLE IF NOT EXISTS sim_component (global_id TEXT PRIMARY KEY, x REAL, y REAL, z REAL, holder TEXT);
CREATE TABLE IF NOT EXISTS sim_execution (
    activity_id TEXT, attempt INTEGER, robot TEXT, success INTEGER, message TEXT,
    started_s REAL, finished_s REAL);
CREATE INDEX IF NOT EXISTS sim_execution_goal ON sim_execution (activity_id, attempt);
CREATE TABLE IF NOT EXISTS sim_work_point (name TEXT PRIMARY KEY, x REAL, y REAL);
"""


class KinematicSite:
    """The simulated site: robots and components with persistent state (SQLite, metres, seconds)."""

    def __init__(
        self,
        capabilities: Fleet,
        db_path: str | Path = ":memory:",
        time_scale: float = 0.0,
        failure_probability: float = 0.0,
        seed: int = 0,
    ):
        self.capabilities = capabilities
        self.time_scale = float(time_scale)
        self.failure_probability = float(failure_probability)
        self.seed = int(seed)
        self._lock = threading.Lock()
        self._db = connect_state_db(db_path, schema=SCHEMA)  # the run's state database, or its own; never a foreign file
        self._write_lock = write_lock(db_path)
        for robot in capabilities.robots:
            h = Pose(*robot.home_m)  # the model frame (:func:`bimrobot.rcan.fleet.place_fleet`)
            self._db.execute(
                "INSERT OR IGNORE INTO sim_robot VALUES (?, ?, ?, ?, NULL, NULL, 0.0)", (robot.name, h.x, h.y, h.z)
            )
            self._db.execute("INSERT OR IGNORE INTO sim_work_point VALUES (?, ?, ?)", (robot.name, h.x, h.y))

    # --- queries -----------------------------------------------------------------------------------
    def robot_state(self, name: str) -> dict:
        """Base pose, arm target (None when stowed), held component and clock (s) of robot ``name``."""
        row = self._db.execute("SELECT x, y, z, arm, holding, clock_s FROM sim_robot WHERE name=?", (name,)).fetchone()
        if row is None:
            raise KeyError(f"robot {name!r} is not on this site")
        arm = Pose(*json.loads(row[3])) if row[3] else None
        work = self._db.execute("SELECT x, y FROM sim_work_point WHERE name=?", (name,)).fetchone()
        work_point = Pose(work[0], work[1], 0.0) if work else Pose(row[0], row[1], row[2])
        return {"base": Pose(row[0], row[1], row[2]), "arm": arm, "holding": row[4], "clock_s": row[5],
                "work_point": work_point}

    def component_position(self, global_id: str) -> tuple[float, float, float] | None:
        row = self._db.execute("SELECT x, y, z FROM sim_component WHERE global_id=?", (global_id,)).fetchone()
        return tuple(row) if row else None

    def executions(self) -> list[tuple[str, int, bool]]:
        """Every goal the robots executed: (activity id, attempt, success), in execution order."""
        with self._lock:
            rows = self._db.execute("SELECT activity_id, attempt, success FROM sim_execution ORDER BY rowid").fetchall()
        return [(a, n, bool(s)) for a, n, s in rows]

    # --- execution ---------------------------------------------------------------------------------
    def execute(self, node: RcanNode, attempt: int, ready_at_s: float = 0.0, feedback=None) -> ActivityResult:
        """Execute one goal; a goal already executed returns its recorded result (no second run)."""
        with self._lock:
            recorded = self._recorded(node.activity_id, attempt)
        if recorded:
            return recorded
        spec = self.capabilities.by_name.get(node.robot)
        if spec is None:
            raise KeyError(f"robot {node.robot!r} is not in {self.capabilities.source}")
        with self._lock:
            state = self.robot_state(node.robot)
        start = max(state["clock_s"], ready_at_s)
        duration, error, effect = self._plan(spec, state, node)
        if error is None and self._random_failure(node.activity_id, attempt):
            error = f"{node.kind.label} failed (simulated fault, p={self.failure_probability:g})"
        if feedback:
            feedback(0.0, f"{node.kind.label}: started")
        if self.time_scale > 0 and duration > 0:
            time.sleep(duration * self.time_scale)
        if feedback:
            feedback(1.0, f"{node.kind.label}: finished")
        result = ActivityResult(
            node.activity_id, attempt, node.robot, error is None,
            error or f"{node.kind.label} of {node.component_id} done", start, start + duration,
        )
        return self._commit(node, result, effect if error is None else {})

    def _recorded(self, activity_id: str, attempt: int) -> ActivityResult | None:
        """The result of a goal already executed: the same (activity id, attempt), or any successful
        attempt of the activity (a goal id is completed once; its result is reported as this attempt's)."""
        row = self._db.execute(
            "SELECT robot, success, message, started_s, finished_s FROM sim_execution "
            "WHERE activity_id=? AND (attempt=? OR success=1) ORDER BY success DESC LIMIT 1",
            (activity_id, attempt),
        ).fetchone()
        if row is None:
            return None
        return ActivityResult(activity_id, attempt, row[0], bool(row[1]), row[2], row[3], row[4])

    def _random_failure(self, activity_id: str, attempt: int) -> bool:
        if self.failure_probability <= 0:
            return False
        rng = np.random.default_rng([self.seed, zlib.crc32(activity_id.encode()), attempt])
        return bool(rng.random() < self.failure_probability)

    def _plan(self, spec: RobotSpec, state: dict, node: RcanNode) -> tuple[float, str | None, dict]:
        """(duration s, error or None, state changes) of ``node`` on robot ``spec`` in ``state``."""
        kind, target, base = node.kind, node.target, state["base"]
        if not spec.performs(kind):
            return 0.0, f"robot {spec.name} cannot {kind.label.lower()} (its rcan_activities in the fleet)", {}
        if state["holding"] and state["holding"] != node.component_id:
            # RCAN released this robot from a component it still holds (its activity was escalated):
            # the robot sets that component down where its gripper is; it waits there for a technician
            duration, error, effect = self._plan(spec, {**state, "holding": None}, node)
            effect = {**effect, "set_down": (state["holding"], state["arm"] or base)}
            return duration, error, effect
        times, activity = spec.times, node.activity
        if kind in (ActivityKind.MOVE_TO_COMPONENT, ActivityKind.TRANSPORT):
            if kind is ActivityKind.TRANSPORT and state["holding"] != node.component_id:
                return 0.0, f"robot {spec.name} does not hold {node.component_id} to transport it", {}
            work_point = activity.work_point or target
            effect = {"base": Pose(target.x, target.y, base.z), "arm": None, "work_point": work_point}
            duration = timing.travel_s(times, state["work_point"].distance_xy(work_point))
            if kind is ActivityKind.TRANSPORT and activity.releases_robot:
                # sets the component down at the drop-off point (the stand pose) and lets go of it
                effect.update(holding=None, component=(target, None))
                if activity.task is Task.TRANSPORT:
                    duration += times.unload_s
            return duration, None, effect
        if kind in (ActivityKind.POSITION_FOR_PICKING_UP, ActivityKind.POSITION_FOR_INSTALLING):
            reach = base.distance_xy(target)
            if reach > spec.reach_m + 1e-9:
                return 0.0, (
                    f"target ({target.x:.2f}, {target.y:.2f}, {target.z:.2f}) is {reach:.2f} m from the base of "
                    f"{spec.name}, beyond its {spec.reach_m:.2f} m reach: transport the component first"
                ), {}
            if kind is ActivityKind.POSITION_FOR_INSTALLING and self._held_by_other(node.component_id, spec.name):
                return 0.0, f"{node.component_id} is held by another robot", {}
            arm_from = state["arm"] or Pose(base.x, base.y, base.z + ARM_STOW_HEIGHT_M)
            effect = {"arm": target}
            if state["holding"] == node.component_id:
                # the held component comes along; a positioning that frees the robot leaves it fixed there
                released = kind is ActivityKind.POSITION_FOR_INSTALLING and node.activity.releases_robot
                effect["component"] = (target, None if released else spec.name)
                if released:
                    effect["holding"] = None
            duration = timing.arm_s(times, arm_from.distance(target))
            if kind is ActivityKind.POSITION_FOR_INSTALLING and activity.task is Task.POSITION:
                duration += timing.position_s(times, activity.nodes or 1)
            return duration, None, effect
        arm = state["arm"]
        if arm is None or arm.distance(target) > GRASP_TOLERANCE_M:
            return 0.0, f"gripper of {spec.name} is not at the {kind.label.lower()} pose of {node.component_id}", {}
        if kind is ActivityKind.PICK_UP:
            if state["holding"]:
                return 0.0, f"robot {spec.name} already holds {state['holding']}", {}
            if self._held_by_other(node.component_id, spec.name):
                return 0.0, f"{node.component_id} is held by another robot", {}
            if not spec.can_grip(node.activity.section_m):
                w, d = node.activity.section_m
                return 0.0, f"the {w:.3f} x {d:.3f} m section of {node.component_id} does not fit the gripper of {spec.name}", {}
            if node.activity.weight_kg is not None and node.activity.weight_kg > spec.payload_kg:
                return 0.0, f"{node.component_id} weighs {node.activity.weight_kg:.1f} kg, over the {spec.payload_kg:.1f} kg payload of {spec.name}", {}
            handling = times.load_s if activity.loads else 0.0  # a re-grip is part of the positioning
            return handling, None, {"holding": node.component_id, "component": (target, spec.name)}
        # install: place the held component, or fix a component already in place (a further connection)
        if state["holding"] != node.component_id and self._held_by_other(node.component_id, spec.name):
            return 0.0, f"{node.component_id} is held by another robot", {}
        effect = {"arm": None, "component": (target, None)}
        if state["holding"] == node.component_id:
            effect["holding"] = None
        # the install of a positioning row lets go of the component: its positioning took the time
        handling = 0.0 if activity.task is Task.POSITION else timing.assemble_s(times, activity.points)
        return handling, None, effect

    def _held_by_other(self, component_id: str, robot: str) -> bool:
        with self._lock:
            row = self._db.execute("SELECT holder FROM sim_component WHERE global_id=?", (component_id,)).fetchone()
        return bool(row and row[0] and row[0] != robot)

    def _commit(self, node: RcanNode, result: ActivityResult, effect: dict) -> ActivityResult:
        """Record the goal and apply its effect in one transaction (a crash keeps both or neither).
        When another executor (a process sharing this site) recorded the same goal meanwhile, nothing
        is applied and its result is returned: the goal is executed once."""
        with self._lock, self._write_lock:  # the journal's writers of the same file in this process too
            db = self._db
            db.execute("BEGIN IMMEDIATE")
            try:
                recorded = self._recorded(result.activity_id, result.attempt)
                if recorded:
                    db.execute("ROLLBACK")
                    return recorded
                db.execute(
                    "INSERT INTO sim_execution VALUES (?, ?, ?, ?, ?, ?, ?)",
                    (result.activity_id, result.attempt, result.robot, int(result.success), result.message,
                     result.started_s, result.finished_s),
                )
                columns = {"clock_s": result.finished_s}  # the robot's new state, in one statement
                if "base" in effect:
                    b = effect["base"]
                    columns.update(x=b.x, y=b.y, z=b.z)
                if "arm" in effect:
                    arm = effect["arm"]
                    columns["arm"] = json.dumps([arm.x, arm.y, arm.z, arm.yaw]) if arm else None
                if "set_down" in effect:
                    held, pose = effect["set_down"]
                    db.execute("INSERT OR REPLACE INTO sim_component VALUES (?, ?, ?, ?, NULL)",
                               (held, pose.x, pose.y, pose.z))
                    columns["holding"] = None
                if "holding" in effect:
                    columns["holding"] = effect["holding"]
                if "work_point" in effect:
                    w = effect["work_point"]
                    db.execute("INSERT OR REPLACE INTO sim_work_point VALUES (?, ?, ?)", (node.robot, w.x, w.y))
                db.execute(f"UPDATE sim_robot SET {', '.join(f'{c}=?' for c in columns)} WHERE name=?",
                           (*columns.values(), node.robot))
                if "component" in effect:
                    pose, holder = effect["component"]
                    db.execute(
                        "INSERT OR REPLACE INTO sim_component VALUES (?, ?, ?, ?, ?)",
                        (node.component_id, pose.x, pose.y, pose.z, holder),
                    )
                db.execute("COMMIT")
            except BaseException:
                db.execute("ROLLBACK")
                raise
        return result

    def close(self) -> None:
        self._db.close()


class SimBackend(DispatchingBackend):
    """Executor backend on the built-in :class:`KinematicSite` (see the module docstring)."""

    name = "sim"

    def __init__(self, capabilities: Fleet, db_path: str | Path = ":memory:", time_scale: float = 0.0,
                 failure_probability: float = 0.0, seed: int = 0):
        self.site = KinematicSite(capabilities, db_path, time_scale, failure_probability, seed)

    def _run(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self.site.execute(node, attempt, ready_at_s, feedback)


    def close(self) -> None:
        self.site.close()
