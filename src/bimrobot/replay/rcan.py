"""What an RCAN run adds to a replay: its activities and, from the mujoco backend, the recorded bodies.

An RCAN run folder is what ``bimrobot rcan run --report R --state-db D`` writes, or a build's
``rcan/``: ``report.json`` (status, done activities, each activity's robot, the final component
states), the state database (each activity's component, kind, status and the simulated seconds it
started and finished) and, from ``--backend mujoco``, ``<state db>.trajectory.csv``: the pose of every MuJoCo
body at 20 Hz of simulated time, rows of the bodies that moved only (a body holds its last row's pose;
``time_s, body, x, y, z, qw, qx, qy, qz``; metres, world frame = the
model frame of the RCAN goals; a body is a component, named by its GlobalId, or a robot's link,
``<robot>/<link>``). Times are the backend's simulated seconds: with the mujoco backend the trajectory
and the activities' finishes are on the same clock.
"""

from __future__ import annotations

import json
import sqlite3
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bimrobot.core.errors import InputError
from bimrobot.core.frames import matrix_of_quat_wxyz, transform

TRAJECTORY_SUFFIX = ".trajectory.csv"
TRAJECTORY_COLUMNS = ("time_s", "body", "x", "y", "z", "qw", "qx", "qy", "qz")


@dataclass
class BodyTrack:
    """One body's recorded poses: ``times`` (n,) s, ``xyz`` (n, 3) m, ``quat_wxyz`` (n, 4) unit quaternions."""

    times: np.ndarray
    xyz: np.ndarray
    quat_wxyz: np.ndarray

    def pose(self, index: int = -1) -> np.ndarray:
        """The 4x4 pose of sample ``index`` (default: the last)."""
        return transform(matrix_of_quat_wxyz(self.quat_wxyz[index]), self.xyz[index])


@dataclass
class RcanActivity:
    """An activity of the run: ``kind`` the snake_case RCAN activity (``pick_up``); ``status`` done,
    escalated, pending...; ``start_s`` / ``finish_s`` simulated seconds, None when not recorded."""

    activity_id: str
    component_id: str
    kind: str
    robot: str
    status: str
    start_s: float | None
    finish_s: float | None
    message: str = ""

    @property
    def label(self) -> str:
        return f"{self.activity_id} {self.kind.replace('_', ' ').capitalize()} {self.component_id}"


@dataclass
class RcanRun:
    """An RCAN run folder read for the replay (see the module docstring)."""

    folder: Path
    report: dict
    activities: list[RcanActivity]
    #: body name -> its recorded poses; empty without a trajectory CSV
    bodies: dict[str, BodyTrack] = field(default_factory=dict)
    trajectory: Path | None = None

    @property
    def done(self) -> list[RcanActivity]:
        return [a for a in self.activities if a.status == "done"]

    @property
    def component_states(self) -> dict[str, str]:
        return dict(self.report.get("component_states") or {})

    def robot_links(self) -> dict[str, list[str]]:
        """Robot -> the names of its bodies (``<robot>/<link>``), in the recorded order."""
        robots: dict[str, list[str]] = {}
        for body in self.bodies:
            if "/" in body:
                robots.setdefault(body.split("/", 1)[0], []).append(body)
        return robots


def is_rcan_folder(folder: Path) -> bool:
    """Whether ``folder`` holds an RCAN run's report.json (its ``done`` list and ``component_states``)."""
    report = folder / "report.json"
    if not report.is_file():
        return False
    try:
        data = json.loads(report.read_text())
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and "done" in data and "component_states" in data


def state_db_of(folder: Path) -> Path | None:
    """The RCAN state database in ``folder``: the one a trajectory CSV is named after, else ``state.db``."""
    for csv_file in sorted(folder.glob("*" + TRAJECTORY_SUFFIX)):
        db = csv_file.with_name(csv_file.name[: -len(TRAJECTORY_SUFFIX)])
        if db.is_file():
            return db
    return folder / "state.db" if (folder / "state.db").is_file() else None


def load_rcan_run(folder: Path) -> RcanRun:
    """Read an RCAN run folder (module docstring); InputError when its report or database is not RCAN's."""
    from bimrobot.rcan.state_db import is_state_db

    report_path = folder / "report.json"
    try:
        report = json.loads(report_path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{report_path}: cannot read it as JSON ({exc})") from None
    db = state_db_of(folder)
    if db is None:
        raise InputError(f"{folder}: an RCAN run folder needs its state database (state.db) beside report.json")
    if not is_state_db(db):
        raise InputError(f"{db} is not an RCAN state database")
    activities = read_activities(db, report)
    trajectory = db.with_name(db.name + TRAJECTORY_SUFFIX)
    if trajectory.is_file():
        return RcanRun(folder, report, activities, read_trajectory(trajectory), trajectory)
    return RcanRun(folder, report, activities)


def read_activities(db: Path, report: dict) -> list[RcanActivity]:
    """The run's activities from its state database (read only), with the robots of the report.

    The database keeps when each done activity started and finished (simulated seconds); a database
    written before RCAN recorded starts has no ``started_s`` column: the starts are unknown (None)."""
    robots = report.get("robots") or {}
    from contextlib import closing

    # A database closed cleanly has no -wal file: open it as immutable, which reads it without creating
    # -wal/-shm files beside it (a read-only connection in WAL mode leaves them behind). A -wal file
    # (a run that was killed) holds committed work: then read through it, read-only.
    wal = db.with_name(db.name + "-wal")
    mode = "mode=ro" if wal.exists() else "immutable=1"
    try:
        with closing(sqlite3.connect(f"file:{db.resolve()}?{mode}", uri=True)) as connection:
            columns = {row[1] for row in connection.execute("PRAGMA table_info(activity)")}
            start = "started_s" if "started_s" in columns else "NULL"
            rows = connection.execute(
                f"SELECT activity_id, component_id, kind, robot, status, {start}, finished_s, message "
                "FROM activity ORDER BY activity_id").fetchall()
    except sqlite3.Error as exc:
        raise InputError(f"{db}: cannot read the RCAN activities ({exc})") from None
    return [RcanActivity(a, c or "", k or "", robots.get(a) or r or "", s, t0, t1, m or "")
            for a, c, k, r, s, t0, t1, m in rows]


def read_trajectory(path: Path) -> dict[str, BodyTrack]:
    """The mujoco backend's trajectory CSV (module docstring) as body -> :class:`BodyTrack`."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    with path.open(encoding="utf-8", errors="replace") as handle:
        first = handle.readline()
    skip = 1 if first.startswith("#") else 0
    types = {name: pa.float64() for name in TRAJECTORY_COLUMNS}
    types["body"] = pa.string()
    try:
        table = pacsv.read_csv(path, read_options=pacsv.ReadOptions(skip_rows=skip),
                               convert_options=pacsv.ConvertOptions(column_types=types))
    except (pa.ArrowInvalid, OSError) as exc:
        raise InputError(f"{path}: not a trajectory CSV of the mujoco backend ({str(exc).splitlines()[0]})") from None
    if tuple(table.column_names) != TRAJECTORY_COLUMNS:
        raise InputError(f"{path}: expected the columns {', '.join(TRAJECTORY_COLUMNS)}, "
                         f"found {', '.join(table.column_names)}")
    values = np.column_stack([table[name].to_numpy() for name in TRAJECTORY_COLUMNS if name != "body"])
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if len(bad):
        raise InputError(f"{path}, line {bad[0] + 2 + skip}: a time or pose value is missing or not a finite number")
    names, which = np.unique(table["body"].to_numpy(zero_copy_only=False), return_inverse=True)
    tracks = {}
    for index, name in enumerate(names):
        rows = values[which == index]
        rows = rows[np.argsort(rows[:, 0], kind="stable")]
        tracks[str(name)] = BodyTrack(rows[:, 0], rows[:, 1:4], rows[:, 4:8])
    return tracks
