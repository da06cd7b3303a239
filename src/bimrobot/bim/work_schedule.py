"""Read IFC work schedules (IfcWorkSchedule / IfcTask / IfcRelSequence) into plain Python rows.

The rows carry no ifcopenshell objects, so the rest of bimrobot never imports ifcopenshell: the lbd
part turns them into a :class:`bimrobot.lbd.schedule.Schedule`. Dates stay ISO 8601 strings as in
the file (calendar time, no time zone).
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

from bimrobot.errors import InputError

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TaskRow:
    """One IfcTask.

    ``start``/``finish``: ISO date-times (ScheduleStart/ScheduleFinish, else EarlyStart/EarlyFinish,
    else ActualStart/ActualFinish), or None. ``predecessors``: GlobalIds of the tasks that must finish
    first (FINISH_START IfcRelSequence). ``outputs``: GlobalIds of the products the task is assigned to
    (IfcRelAssignsToProduct, e.g. the wall it builds); ``inputs``: products it operates on
    (IfcRelAssignsToProcess); ``resources``: names of the resources assigned to it (a robot, a crew).
    ``parent``: GlobalId of the summary task it is nested in; ``is_summary``: it has nested tasks.
    ``storey``: GlobalId of the storey containing its first output, if any.
    """

    global_id: str
    name: str
    identification: str | None
    predefined_type: str
    start: str | None
    finish: str | None
    predecessors: tuple[str, ...]
    outputs: tuple[str, ...]
    inputs: tuple[str, ...]
    resources: tuple[str, ...]
    parent: str | None
    is_summary: bool
    storey: str | None
    work_schedule: str | None


def _times(task) -> tuple[str | None, str | None]:
    """(start, finish): each the first of the Schedule, Early, Actual value that is set."""
    time = task.TaskTime
    if time is None:
        return None, None

    def first(*attributes: str) -> str | None:
        return next((value for a in attributes if (value := getattr(time, a, None))), None)

    return (
        first("ScheduleStart", "EarlyStart", "ActualStart"),
        first("ScheduleFinish", "EarlyFinish", "ActualFinish"),
    )


def _predecessors(task) -> tuple[str, ...]:
    found = []
    for rel in task.IsSuccessorFrom or ():
        kind = rel.SequenceType or "NOTDEFINED"
        if kind == "FINISH_START":
            found.append(rel.RelatingProcess.GlobalId)
        else:
            log.warning(
                "IfcRelSequence %s (%s) from %s to %s is not FINISH_START: not used as a predecessor",
                rel.GlobalId, kind, rel.RelatingProcess.GlobalId, task.GlobalId,
            )  # fmt: skip
    return tuple(found)


def _storey_of(product) -> str | None:
    import ifcopenshell.util.element

    if product.is_a("IfcBuildingStorey"):
        return product.GlobalId
    container = ifcopenshell.util.element.get_container(product)
    return container.GlobalId if container is not None and container.is_a("IfcBuildingStorey") else None


def read_work_schedule(path: str | os.PathLike) -> list[TaskRow]:
    """Every IfcTask of the file, parents before children, in file order otherwise.

    Raises :class:`InputError` when the file cannot be opened as IFC.
    """
    import ifcopenshell
    import ifcopenshell.util.sequence as sequence

    path = Path(path)
    if not path.is_file():
        raise InputError(f"the IFC file {path} does not exist")
    try:
        ifc = ifcopenshell.open(str(path))
    except Exception as exc:  # ifcopenshell raises several types for unreadable files
        raise InputError(f"cannot read {path} as IFC: {exc}") from None
    rows = []
    for task in ifc.by_type("IfcTask"):
        outputs = sorted(sequence.get_task_outputs(task), key=lambda p: p.id())
        parent = sequence.get_parent_task(task)
        schedule = sequence.get_task_work_schedule(task)
        start, finish = _times(task)
        rows.append(
            TaskRow(
                global_id=task.GlobalId,
                name=task.Name or "",
                identification=task.Identification,
                predefined_type=task.PredefinedType or "NOTDEFINED",
                start=start,
                finish=finish,
                predecessors=_predecessors(task),
                outputs=tuple(p.GlobalId for p in outputs),
                inputs=tuple(sorted(p.GlobalId for p in sequence.get_task_inputs(task))),
                resources=tuple(sorted(r.Name or r.GlobalId for r in sequence.get_task_resources(task))),
                parent=parent.GlobalId if parent is not None else None,
                is_summary=bool(sequence.get_nested_tasks(task)),
                storey=_storey_of(outputs[0]) if outputs else None,
                work_schedule=schedule.GlobalId if schedule is not None else None,
            )
        )
    return rows
