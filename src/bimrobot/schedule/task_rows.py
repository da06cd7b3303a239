"""IfcTasks in: :func:`read_work_schedule` gives plain Python rows (:class:`TaskRow`) that carry no
ifcopenshell objects, and :func:`schedule_from_task_rows` turns rows (from an IFC file or Microsoft
Project XML) into a :class:`~bimrobot.schedule.schedule.Schedule`. Dates stay ISO 8601 strings as in the
file (calendar time, no time zone) until they become seconds from the earliest start.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from bimrobot.core.errors import InputError
from bimrobot.core.tasks import Activity, Task
from bimrobot.bim import components
from bimrobot.bim.components import is_component
from bimrobot.core.config import MAX_SECONDS
from bimrobot.schedule.limits import limit, too_many
from bimrobot.schedule.schedule import Schedule, find_cycle

if TYPE_CHECKING:  # pragma: no cover
    from bimrobot.bim.model import BuildingModel

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TaskRow:
    """One IfcTask.

    ``start``/``finish``: ISO date-times (ScheduleStart/ScheduleFinish, else EarlyStart/EarlyFinish,
    else ActualStart/ActualFinish), or None. ``predecessors``: GlobalIds of the tasks that must finish
    first (FINISH_START IfcRelSequence). ``outputs``: GlobalIds of the products the task is assigned to
    (IfcRelAssignsToProduct, e.g. the wall it builds), in file order with an assembly before its parts;
    ``inputs``: products it operates on (IfcRelAssignsToProcess); ``resources``: names of the resources
    assigned to it (a robot, a crew). ``parent``: GlobalId of the summary task it is nested in;
    ``is_summary``: it has nested tasks. ``storey``: GlobalId of the storey containing its first output,
    if any.
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


def _wholes_first(products) -> list:
    """Products by file order, each part after the whole it belongs to when both are outputs (the
    assembly a task lifts before the parts that give it a body)."""
    import ifcopenshell.util.element

    products = set(products)

    def is_part(product) -> bool:  # of a whole among the outputs, at any level
        whole = ifcopenshell.util.element.get_aggregate(product)
        while whole is not None and whole not in products:
            whole = ifcopenshell.util.element.get_aggregate(whole)
        return whole is not None

    return sorted(products, key=lambda p: (is_part(p), p.id()))


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
        outputs = _wholes_first(sequence.get_task_outputs(task))
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


def load_schedule_ifc(path: str | os.PathLike, model: BuildingModel | None = None) -> Schedule:
    """Read the IfcWorkSchedule(s) of an IFC file into a :class:`Schedule`.

    Leaf IfcTasks become ``activities``, summary tasks (with nested tasks) ``phases``. Activity ids are
    the tasks' GlobalIds; times are seconds from the earliest scheduled start (``Schedule.epoch``);
    FINISH_START IfcRelSequences become predecessors (other sequence types are logged and skipped).
    ``global_id`` is the product the task outputs (IfcRelAssignsToProduct); ``robot`` the first
    resource assigned to it; ``activity`` comes from the PredefinedType (LOGISTIC: transport,
    INSTALLATION: position, CONSTRUCTION: assemble) and is ``assemble`` for an untyped task that
    outputs a product. With ``model``, ``target`` is the product's placement origin (m).
    """
    rows = read_work_schedule(path)
    if not rows:
        raise InputError(f"{path} has no IfcTask to read as a schedule")
    return schedule_from_task_rows(rows, Path(path), model)


def schedule_from_task_rows(rows: list, source: Path | None, model: BuildingModel | None = None) -> Schedule:
    """Build a :class:`Schedule` from :class:`TaskRow` rows."""
    from datetime import datetime

    starts = [r.start for r in rows if r.start]
    epoch = min(datetime.fromisoformat(s) for s in starts) if starts else None

    def seconds(iso: str | None, fallback: float) -> float:
        if not iso or epoch is None:
            return fallback
        return (datetime.fromisoformat(iso) - epoch).total_seconds()

    known_storeys = {s.global_id for s in model.storeys} if model is not None else set()
    leaves, phases = [], []
    per_component: dict[str, int] = {}
    most_each = limit("per_component")
    for row in rows:
        start = seconds(row.start, 0.0)
        finish = seconds(row.finish, start)
        if not (0 <= start <= MAX_SECONDS and 0 <= finish <= MAX_SECONDS):
            raise InputError(f"{source}: task {row.global_id} ends {max(start, finish):.3g} s after the earliest start, "
                             f"more than the {MAX_SECONDS:g} s (31 years) a schedule may span")
        output = row.outputs[0] if row.outputs else None
        if output and not row.is_summary:
            count = per_component[output] = per_component.get(output, 0) + 1
            if count > most_each:
                raise too_many(f"{source}: task {row.global_id}", f"component {output!r} has", "per_component")
        if model is not None and output and not is_component(model, output) and output not in known_storeys:
            log.warning("IfcTask %s outputs %s, which is not an element of the model: left unlinked", row.global_id, output)
            output = None
        kind = Task.from_ifc_task_type(row.predefined_type) or (Task.ASSEMBLE if output else "")
        target = None
        storey = row.storey
        if model is not None and is_component(model, output):
            target = tuple(float(v) for v in components.position(model, output))
            storey = components.storey_id(model, output) or storey
        activity = Activity(
            id=row.global_id,
            name=row.name or row.global_id,
            activity=kind,
            global_id=output,
            robot=row.resources[0] if row.resources else None,
            start=start,
            finish=max(start, finish),
            predecessors=tuple(row.predecessors),
            target=target,  # type: ignore[arg-type]
            storey=storey,
            predefined_type=row.predefined_type,
            parent=row.parent,
        )
        (phases if row.is_summary else leaves).append(activity)
    leaves.sort(key=lambda a: (a.start, a.id))
    schedule = Schedule(leaves, phases=phases, source=source, epoch=epoch.isoformat() if epoch else None)
    cycle = find_cycle({a.id: a.predecessors for a in [*phases, *leaves]})
    if cycle:
        raise InputError(f"{source}: the IfcRelSequence relations form a cycle {' -> '.join(cycle)}")
    return schedule
