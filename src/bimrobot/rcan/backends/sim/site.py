"""The ``sim`` backend's site: kinematic robots and components with persistent state (SQLite), and what
every activity feature shares: the goal journal (a goal runs once), the robot's clock, seeded failures,
the feedback and the one transaction that records a goal with its effect. What an activity takes and
does is its feature's *step* (:mod:`.drive`, :mod:`.arm`, :mod:`.gripper`); the package docstring says
what the robots do.
"""

from __future__ import annotations

import json
import threading
import time
import zlib
from pathlib import Path
from typing import Callable

import numpy as np

from bimrobot.site.fleet import Fleet, RobotSpec
from bimrobot.rcan.activities import Pose
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.node import RcanNode
from bimrobot.rcan.state_db import connect_state_db, write_lock

#: A feature's step: (site, robot spec, robot state (:meth:`KinematicSite.robot_state`), node) ->
#: (duration s, error or None, the robot's and the component's state changes)
Step = Callable[["KinematicSite", RobotSpec, dict, RcanNode], tuple[float, "str | None", dict]]

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
    def execute(self, node: RcanNode, attempt: int, ready_at_s: float, feedback, step: Step) -> ActivityResult:
        """Execute one goal with its feature's ``step``; a goal already executed returns its recorded
        result (no second run)."""
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
        duration, error, effect = self._plan(spec, state, node, step)
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

    def _plan(self, spec: RobotSpec, state: dict, node: RcanNode, step: Step) -> tuple[float, str | None, dict]:
        """(duration s, error or None, state changes) of ``node`` on robot ``spec`` in ``state``: what every
        activity checks first, then its feature's ``step``."""
        kind = node.kind
        if not spec.performs(kind):
            return 0.0, f"robot {spec.name} cannot {kind.label.lower()} (its rcan_activities in the fleet)", {}
        if state["holding"] and state["holding"] != node.component_id:
            # RCAN released this robot from a component it still holds (its activity was escalated):
            # the robot sets that component down where its gripper is; it waits there for a technician
            duration, error, effect = self._plan(spec, {**state, "holding": None}, node, step)
            effect = {**effect, "set_down": (state["holding"], state["arm"] or state["base"])}
            return duration, error, effect
        return step(self, spec, state, node)

    def held_by_other(self, component_id: str, robot: str) -> bool:
        """Whether a robot other than ``robot`` holds ``component_id``."""
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
