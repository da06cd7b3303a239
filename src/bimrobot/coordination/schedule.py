"""The simulation's activities as the schedule CSV (docs/conventions.md).

The CSV has one reader and writer, :mod:`bimrobot.schedule.csv`; this module hands it the completed
activities of a simulation (times rounded to milliseconds, targets to 0.1 mm, so that the file reads
well and Duration is Finish - Start as written) and gives the rows back as plain dicts for reports.
Times are seconds from the start of the build, targets metres in the model's world frame.
"""

from __future__ import annotations

from pathlib import Path

from bimrobot.schedule.csv import COLUMNS, PREDEFINED_TYPE, is_schedule_csv
from bimrobot.core.tasks import Activity
from bimrobot.schedule.csv import load_schedule_csv as _load_schedule
from bimrobot.schedule.csv import write_schedule_csv as _write_schedule
from bimrobot.core.tasks import Task

__all__ = ["COLUMNS", "PREDEFINED_TYPE", "is_schedule_csv", "load_schedule_csv", "schedule_activities",
           "schedule_rows", "write_schedule_csv"]


def schedule_activities(activities) -> list[Activity]:
    """The completed simulation activities (not aborted) as schedule :class:`Activity` rows, by start time."""
    rows = []
    for a in sorted((a for a in activities if not a.aborted), key=lambda a: (a.start, a.id)):
        rows.append(Activity(
            id=a.id, name=a.name, activity=a.activity, global_id=a.global_id, robot=a.robot,
            start=round(a.start, 3), finish=round(a.finish, 3), predecessors=tuple(a.predecessors),
            target=tuple(round(float(v), 4) for v in a.target), storey=a.storey,
            predefined_type=Task(a.activity).ifc_task_type,
            work_from=a.work_from, work_to=a.work_to, nodes=a.nodes, points=a.points,
        ))  # fmt: skip
    return rows


def write_schedule_csv(activities, path: str | Path, inputs=(), option: str = "-o") -> Path:
    """Write the simulation's schedule atomically under the output policy (:mod:`bimrobot.core.io`): an
    existing file is replaced only when it is a schedule CSV (:func:`is_schedule_csv`); returns the path."""
    return _write_schedule(schedule_activities(activities), path, inputs=inputs, option=option)


def _row(a: Activity) -> dict:
    x, y, z = a.target if a.target is not None else (None, None, None)
    return {
        "Identification": a.id, "Name": a.name, "PredefinedType": a.predefined_type, "Activity": a.activity,
        "GlobalId": a.global_id, "Robot": a.robot or "", "Start": a.start, "Finish": a.finish,
        "Duration": a.duration, "Predecessors": list(a.predecessors), "TargetX": x, "TargetY": y, "TargetZ": z,
        "Storey": a.storey or "",
        "FromX": a.work_from[0] if a.work_from else None, "FromY": a.work_from[1] if a.work_from else None,
        "FromZ": a.work_from[2] if a.work_from else None, "ToX": a.work_to[0] if a.work_to else None,
        "ToY": a.work_to[1] if a.work_to else None, "ToZ": a.work_to[2] if a.work_to else None,
        "Nodes": a.nodes, "Points": a.points,
    }  # fmt: skip


def schedule_rows(activities) -> list[dict]:
    """Rows (dicts keyed by :data:`COLUMNS`, numbers as floats, Predecessors as a list) of the completed
    simulation activities, by start time."""
    return [_row(a) for a in schedule_activities(activities)]


def load_schedule_csv(path: str | Path) -> list[dict]:
    """Read a schedule CSV back as rows (see :func:`schedule_rows`), validated by
    :func:`bimrobot.schedule.csv.load_schedule_csv` (InputError naming the file, line and column)."""
    return [_row(a) for a in _load_schedule(path)]
