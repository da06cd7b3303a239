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


# ------------------------------------------------------------------------------------------- writing

#: IfcTaskTime.DurationType of written tasks: robots work around the clock, not on a work calendar.
DURATION_TYPE = "ELAPSEDTIME"


def migrated_to_ifc4(ifc, source: Path):
    """An IFC4 copy of an IFC2X3 model (IfcOpenShell's schema Migrator, entity by entity; GlobalIds kept).

    The Migrator prints each IFC2X3 attribute that has no IFC4 equivalent (e.g. a quantity's Formula);
    they are counted into one log line instead."""
    import contextlib
    import io as text_io

    import ifcopenshell
    import ifcopenshell.util.schema

    migrated = ifcopenshell.file(schema="IFC4")
    migrator = ifcopenshell.util.schema.Migrator()
    printed = text_io.StringIO()
    with contextlib.redirect_stdout(printed):
        for entity in ifc:
            migrator.migrate(entity, migrated)
    dropped = printed.getvalue().count("Unable to find equivalent attribute")
    log.warning("%s is IFC2X3, which has no IfcTaskTime: the copy with the work schedule is migrated to IFC4"
                "%s", source, f" ({dropped} attribute values without an IFC4 equivalent left out)" if dropped else "")
    return migrated


def write_work_schedule(ifc_in: str | os.PathLike, schedule, ifc_out: str | os.PathLike, *, epoch: str | None = None,
                        name: str = "bimrobot simulated build", option: str = "--ifc-out") -> Path:
    """Write a COPY of ``ifc_in`` with ``schedule`` as an IfcWorkSchedule (a Bonsai user sees the build in 4D).

    ``schedule``: a :class:`bimrobot.lbd.schedule.Schedule` (or its activities), times in seconds from
    the start of the build. One IfcTask per activity (Identification = activity id, PredefinedType =
    LOGISTIC / INSTALLATION / CONSTRUCTION), each with an IfcTaskTime (ScheduleStart, ScheduleFinish,
    ScheduleDuration, elapsed time), an IfcRelSequence FINISH_START per predecessor, an
    IfcRelAssignsToProduct to the element or assembly it acts on (when the file has that GlobalId), and
    its robot as an IfcConstructionEquipmentResource assigned to it (IfcRelAssignsToProcess). Made with
    ``ifcopenshell.api.sequence``; the times are set on the IfcTaskTime directly because
    ``edit_task_time`` snaps them to the working days of a calendar (9:00-17:00).

    ``epoch``: ISO date-time of t = 0 s; default the schedule's own (``Schedule.epoch``, from a
    calendar schedule), else today at 08:00. The output goes through
    :func:`bimrobot.io.atomic_output_file` (the input is never overwritten; the header's
    FILE_DESCRIPTION carries ``io.SIGNATURE``). Returns ``ifc_out``.
    """
    import datetime as dt

    import ifcopenshell
    import ifcopenshell.api.resource
    import ifcopenshell.api.sequence as sequence
    import ifcopenshell.util.date

    from bimrobot import io

    ifc_in, ifc_out = Path(ifc_in), Path(ifc_out)
    if ifc_out.suffix.lower() != ".ifc":
        raise InputError(f"{option} {ifc_out}: the scheduled copy is written as .ifc (STEP), give a name ending in .ifc")
    io.check_output(ifc_out, folder=False, inputs=[ifc_in], option=option)
    activities = list(schedule)
    if not activities:
        raise InputError(f"the schedule for {ifc_in} has no activity to write into {ifc_out}")
    origin_text = epoch or getattr(schedule, "epoch", None)
    try:
        origin = dt.datetime.fromisoformat(origin_text) if origin_text else dt.datetime.combine(dt.date.today(), dt.time(8))
    except ValueError:
        raise InputError(f"the schedule start {origin_text!r} is not an ISO date-time such as 2026-03-02T08:00") from None
    ifc = _open(ifc_in)
    if ifc.schema == "IFC2X3":  # no IfcTaskTime in IFC2X3: the copy is migrated to IFC4 first
        ifc = migrated_to_ifc4(ifc, ifc_in)
    work_schedule = sequence.add_work_schedule(ifc, name=name, predefined_type="PLANNED", start_time=origin)
    tasks, robots, unassigned = {}, {}, 0
    for a in activities:
        task = sequence.add_task(ifc, work_schedule=work_schedule, name=a.name, identification=a.id,
                                 description=f"{a.activity} by {a.robot}" if a.robot else a.activity,
                                 predefined_type=a.predefined_type or "NOTDEFINED")
        product = _by_guid(ifc, a.global_id)
        if product is not None:
            sequence.assign_product(ifc, relating_product=product, related_object=task)
        else:
            unassigned += 1
        if a.robot:
            if a.robot not in robots:
                robots[a.robot] = ifcopenshell.api.resource.add_resource(
                    ifc, ifc_class="IfcConstructionEquipmentResource", name=a.robot)
            sequence.assign_process(ifc, relating_process=task, related_object=robots[a.robot])
        tasks[a.id] = task
    for a in activities:
        for predecessor in a.predecessors:
            if predecessor in tasks:
                sequence.assign_sequence(ifc, relating_process=tasks[predecessor], related_process=tasks[a.id])
    # Times last: assign_sequence cascades existing task times over a working-day calendar.
    for a in activities:
        time = sequence.add_task_time(ifc, task=tasks[a.id])
        time.DurationType = DURATION_TYPE
        time.ScheduleStart = ifcopenshell.util.date.datetime2ifc(origin + dt.timedelta(seconds=a.start), "IfcDateTime")
        time.ScheduleFinish = ifcopenshell.util.date.datetime2ifc(origin + dt.timedelta(seconds=a.finish), "IfcDateTime")
        time.ScheduleDuration = ifcopenshell.util.date.datetime2ifc(dt.timedelta(seconds=a.finish - a.start), "IfcDuration")
    if unassigned:
        log.warning("%d of %d activities act on no product of %s: their tasks are not assigned to a product",
                    unassigned, len(activities), ifc_in)
    description = [d for d in (ifc.header.file_description.description or ()) if io.SIGNATURE not in d]
    ifc.header.file_description.description = tuple(description + [io.signature("IFC with the simulated work schedule")])
    with io.atomic_output_file(ifc_out, inputs=[ifc_in], option=option) as tmp:
        ifc.write(str(tmp), format=".ifc")
    return ifc_out


def _open(path: Path):
    import ifcopenshell

    if not path.is_file():
        raise InputError(f"the IFC file {path} does not exist")
    try:
        return ifcopenshell.open(str(path))
    except Exception as exc:  # ifcopenshell raises several types for unreadable files
        raise InputError(f"cannot read {path} as IFC: {exc}") from None


def _by_guid(ifc, global_id: str | None):
    if not global_id:
        return None
    try:
        return ifc.by_guid(global_id)
    except RuntimeError:  # not in this file (e.g. a generated frame's ids)
        return None
