"""IFC work schedules (IfcWorkSchedule / IfcTask / IfcRelSequence) in and out.

In: :func:`read_work_schedule` gives plain Python rows that carry no ifcopenshell objects, so the rest
of bimrobot never imports ifcopenshell: the lbd part turns them into a
:class:`bimrobot.schedule.csv.Schedule`. Dates stay ISO 8601 strings as in the file (calendar time, no
time zone).

Out: :func:`scheduled_model` / :func:`write_work_schedule` put a simulated schedule into a copy of the
model (summary tasks per storey and assembly unit, an IfcWorkCalendar, times in working time,
outputs on the parts with a body); :func:`write_schedule_export` writes it for Microsoft Project or
Primavera P6 through IfcOpenShell's ifc4d. :func:`working_datetime` is the working-time arithmetic.
"""

from __future__ import annotations

import datetime as dt
import logging
import os
from dataclasses import dataclass
from pathlib import Path

from bimrobot.core.errors import InputError
from bimrobot.schedule.exports import SCHEDULE_EXPORTS, schedule_export_kind, write_schedule_export
from bimrobot.schedule.task_rows import TaskRow, read_work_schedule
from bimrobot.site.working_time import (
    WEEKDAY_NAMES,
    WorkCalendar,
    work_calendar_from,
    working_datetime,
    working_days,
    working_seconds,
)

# Reading (task_rows.py), working time (bimrobot.site.working_time: the site's calendar) and the
# Microsoft Project / P6 export (exports.py) have their own modules (issue 37); callers import these names from here, as before.
__all__ = [
    "scheduled_model", "write_work_schedule", "write_scheduled_ifc", "check_ifc_out", "migrated_to_ifc4",
    "ScheduleFigures", "DURATION_TYPE", "SCHEDULE_EXPORTS", "schedule_export_kind", "write_schedule_export",
    "TaskRow", "read_work_schedule", "WEEKDAY_NAMES", "WorkCalendar", "work_calendar_from", "working_datetime",
    "working_days", "working_seconds",
]

log = logging.getLogger(__name__)


# ------------------------------------------------------------------------------------------- writing

#: IfcTaskTime.DurationType of written tasks: durations count working time of the IfcWorkCalendar.
DURATION_TYPE = "WORKTIME"


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


def check_ifc_out(path: str | os.PathLike, option: str = "--ifc-out") -> None:
    """Refuse an ``--ifc-out`` name that does not end in .ifc (before anything is written)."""
    if Path(path).suffix.lower() != ".ifc":
        raise InputError(f"{option} {path}: the scheduled copy is written as .ifc (STEP), give a name ending in .ifc")



@dataclass(frozen=True)
class ScheduleFigures:
    """What a scheduled copy holds: ``activities`` (leaf IfcTasks), storey and assembly-unit summary
    tasks, the calendar, the first start and last finish (site wall-clock time) and the calendar's
    working days from the first to the last day."""

    activities: int
    storeys: int
    units: int
    calendar: WorkCalendar
    start: dt.datetime
    finish: dt.datetime
    working_days: int

    @property
    def tasks(self) -> int:
        """Every IfcTask written: activities and summary tasks."""
        return self.activities + self.storeys + self.units

    def describe(self) -> str:
        """One line for the command's output."""
        units = f" and {self.units} assembly unit{'s' if self.units != 1 else ''}" if self.units else ""
        storeys = f"{self.storeys} storey{'s' if self.storeys != 1 else ''}"
        return (f"{self.tasks} IfcTasks ({self.activities} activities nested in {storeys}{units}), "
                f"calendar {self.calendar}: {self.start:%Y-%m-%d %H:%M} to {self.finish:%Y-%m-%d %H:%M}, "
                f"{self.working_days} working day{'s' if self.working_days != 1 else ''}")


def write_work_schedule(ifc_in: str | os.PathLike, schedule, ifc_out: str | os.PathLike, *, epoch: str | None = None,
                        calendar: WorkCalendar | None = None, name: str = "bimrobot simulated build",
                        option: str = "--ifc-out") -> Path:
    """Write a COPY of ``ifc_in`` with ``schedule`` as an IfcWorkSchedule (see :func:`scheduled_model`),
    through :func:`bimrobot.core.io.atomic_output_file` (the input is never overwritten; the header's
    FILE_DESCRIPTION carries ``io.SIGNATURE``). Returns ``ifc_out``."""
    from bimrobot.core import io

    ifc_in, ifc_out = Path(ifc_in), Path(ifc_out)
    check_ifc_out(ifc_out, option)
    io.check_output(ifc_out, folder=False, inputs=[ifc_in], option=option)
    ifc, _ = scheduled_model(ifc_in, schedule, epoch=epoch, calendar=calendar, name=name)
    write_scheduled_ifc(ifc, ifc_out, inputs=[ifc_in], option=option)
    return ifc_out


def write_scheduled_ifc(ifc, ifc_out: Path, *, inputs, option: str = "--ifc-out") -> Path:
    """Write the in-memory copy made by :func:`scheduled_model` to ``ifc_out`` (output policy, signature)."""
    from bimrobot.core import io

    description = [d for d in (ifc.header.file_description.description or ()) if io.SIGNATURE not in d]
    ifc.header.file_description.description = tuple(description + [io.signature("IFC with the simulated work schedule")])
    with io.atomic_output_file(ifc_out, inputs=inputs, option=option) as tmp:
        ifc.write(str(tmp), format=".ifc")
    return Path(ifc_out)


def scheduled_model(ifc_in: str | os.PathLike, schedule, *, epoch: str | None = None,
                    calendar: WorkCalendar | None = None, name: str = "bimrobot simulated build", parsed=None):
    """``(ifc, figures)``: an in-memory copy of ``ifc_in`` with ``schedule`` as an IfcWorkSchedule (a Bonsai
    user sees the build in 4D) and its :class:`ScheduleFigures`.

    ``schedule``: a :class:`bimrobot.schedule.csv.Schedule` (or its activities), times in seconds of
    work from the start of the build. Written with ``ifcopenshell.api.sequence``:

    * one summary IfcTask per storey (Identification ``S1``, ``S2`` ... in order of their first work),
      and under it one per assembly unit (``S1.U1`` ...: the IfcElementAssembly an activity acts on,
      or the one its element is a part of), nested with IfcRelNests; the activities below them;
    * one IfcTask per activity (Identification = activity id, PredefinedType = LOGISTIC /
      INSTALLATION / CONSTRUCTION), an IfcRelSequence FINISH_START per predecessor, its robot as an
      IfcConstructionEquipmentResource (IfcRelAssignsToProcess), and as outputs
      (IfcRelAssignsToProduct) the element or assembly it acts on and every part of it with a body;
    * an IfcWorkCalendar (``calendar``, default Monday-Friday 07:00-16:00: a weekly IfcRecurrencePattern
      with one IfcTimePeriod) assigned to the top-level tasks, which the nested ones inherit;
    * IfcTaskTimes in working time (DurationType WORKTIME): the simulated seconds of work are laid onto
      the calendar's working hours (:func:`working_datetime`); a schedule read in calendar time (it has
      its own ``epoch``: Microsoft Project, an IFC) keeps its date-times; ScheduleDuration counts working days as
      IfcOpenShell, Bonsai and ifc4d do (P1D = one working day of the calendar, 9 h by default; to the
      second of that scale, i.e. within 0.2 s of work, as IfcOpenShell reads no fraction of a second);
      dates and times to the second. The times are set on the IfcTaskTime directly because ``edit_task_time``
      snaps them to whole days.

    ``epoch``: ISO date-time of t = 0 s; default the schedule's own (``Schedule.epoch``), else today at
    08:00; outside working time the work starts at the next working period. An IFC2X3 model is
    migrated to IFC4 (IFC2X3 has no IfcTaskTime).

    ``parsed``: ``ifc_in`` already parsed (``bimrobot build`` parses its model once); the schedule is
    written into that file itself (an IFC2X3 one into its IFC4 copy), so give one nothing reads afterwards.
    None parses ``ifc_in`` here.
    """
    import ifcopenshell.api.sequence as sequence

    calendar = calendar or WorkCalendar()
    ifc_in = Path(ifc_in)
    activities = sorted(schedule, key=lambda a: (a.start, a.id))
    if not activities:
        raise InputError(f"the schedule for {ifc_in} has no activity to write into the model")
    origin = _origin(epoch or getattr(schedule, "epoch", None))
    ifc = _ifc4(_open(ifc_in) if parsed is None else parsed, ifc_in)
    clock = _Clock(calendar, origin, calendar_time=bool(getattr(schedule, "epoch", None)))
    spans = {a.id: clock.span(a.start, a.finish) for a in activities}
    first, last = min(s for s, _ in spans.values()), max(f for _, f in spans.values())
    first_new_id = ifc.get_max_id() + 1
    work_schedule = sequence.add_work_schedule(ifc, name=name, predefined_type="PLANNED", start_time=first)
    work_schedule.Identification = "BIMROBOT"
    groups = _Groups(ifc, work_schedule)
    _add_tasks(ifc, groups, activities, clock, spans)
    _assign_calendar(ifc, calendar, groups.roots)
    _stable_global_ids(ifc, first_new_id, seed=f"{_model_key(ifc, ifc_in)}/{name}")
    if groups.unassigned:
        log.warning("%d of %d activities act on no product of %s: their tasks are not assigned to a product",
                    groups.unassigned, len(activities), ifc_in)
    figures = ScheduleFigures(activities=len(activities), storeys=groups.storey_count, units=groups.unit_count,
                              calendar=calendar, start=first, finish=last,
                              working_days=working_days(calendar, first.date(), last.date()))
    return ifc, figures


def _ifc4(ifc, source: Path):
    """``ifc`` itself, or its IFC4 copy when it is IFC2X3 (which has no IfcTaskTime)."""
    return migrated_to_ifc4(ifc, source) if ifc.schema == "IFC2X3" else ifc


def _add_tasks(ifc, groups: "_Groups", activities: list, clock: "_Clock", spans: dict) -> None:
    """One IfcTask per activity (in its storey and unit summary tasks), its FINISH_START sequences, then the
    times of every task (``spans``: activity id -> (start, finish) date-times)."""
    import ifcopenshell.api.sequence as sequence

    tasks = {a.id: groups.add_activity(a) for a in activities}
    for a in activities:
        for predecessor in a.predecessors:
            if predecessor in tasks:
                sequence.assign_sequence(ifc, relating_process=tasks[predecessor], related_process=tasks[a.id])
    # Times last: assign_sequence cascades existing task times over the calendar in whole days.
    for a in activities:
        _set_times(ifc, tasks[a.id], clock, *spans[a.id])
    for summary, members in groups.summaries():
        _set_times(ifc, summary, clock, min(spans[m][0] for m in members), max(spans[m][1] for m in members))


def _model_key(ifc, source: Path) -> str:
    """What identifies the source model: its IfcProject's GlobalId, else its file name."""
    project = next(iter(ifc.by_type("IfcProject")), None)
    return project.GlobalId if project is not None and project.GlobalId else source.name


def _stable_global_ids(ifc, first_id: int, seed: str) -> None:
    """Give every rooted entity made from entity id ``first_id`` on (the work schedule, its tasks, sequences,
    calendar, assignments, nests) a GlobalId derived from ``seed`` and its class and rank among the new
    entities of that class (UUID 5, compressed as IFC writes it), instead of IfcOpenShell's random ones.
    The schedule is written in a fixed order (activities by start, then id), so the same model and
    schedule get the same GlobalIds on every run: two builds write the same file."""
    import uuid

    import ifcopenshell.guid

    ranks: dict[str, int] = {}
    for step_id in range(first_id, ifc.get_max_id() + 1):
        try:
            entity = ifc.by_id(step_id)
        except RuntimeError:  # an id the api used and removed
            continue
        if not entity.is_a("IfcRoot"):
            continue
        kind = entity.is_a()
        ranks[kind] = ranks.get(kind, 0) + 1
        key = uuid.uuid5(uuid.NAMESPACE_URL, f"bimrobot:work-schedule/{seed}/{kind}/{ranks[kind]}")
        entity.GlobalId = ifcopenshell.guid.compress(key.hex)
        _sorted_sets(entity)
    for declares in ifc.by_type("IfcRelDeclares"):  # the project's, which the work schedule and calendar join
        _sorted_sets(declares)


#: Relationships whose related objects are an unordered SET, which IfcOpenShell's api fills in an order
#: that varies from run to run (IfcRelNests' are an ordered LIST, kept as made).
_SET_RELATIONS = {"IfcRelDeclares": "RelatedDefinitions", "IfcRelAssignsToControl": "RelatedObjects",
                  "IfcRelAssignsToProcess": "RelatedObjects", "IfcRelAssignsToProduct": "RelatedObjects",
                  "IfcRelAssignsToResource": "RelatedObjects"}


def _sorted_sets(entity) -> None:
    """A relationship's SET of related objects in entity-id order (the same bytes every run)."""
    attribute = _SET_RELATIONS.get(entity.is_a())
    if attribute and getattr(entity, attribute):
        setattr(entity, attribute, sorted(getattr(entity, attribute), key=lambda e: e.id()))


class _Clock:
    """Date-times of a schedule's seconds: seconds of work laid onto the calendar's working hours (a
    simulated schedule), or, for a schedule read in calendar time (``calendar_time``: it has its own
    epoch, e.g. from Microsoft Project or an IFC), the date-times as they were."""

    def __init__(self, calendar: WorkCalendar, origin: dt.datetime, calendar_time: bool):
        self.calendar, self.origin, self.calendar_time = calendar, origin, calendar_time

    def span(self, start_s: float, finish_s: float) -> tuple[dt.datetime, dt.datetime]:
        """(start, finish) to the second; finish >= start."""
        if self.calendar_time:
            start, finish = (self.origin + dt.timedelta(seconds=t) for t in (start_s, finish_s))
        else:
            start = working_datetime(self.calendar, self.origin, start_s)
            finish = working_datetime(self.calendar, self.origin, finish_s, finish=True)
        start = _rounded(start)
        return start, max(start, _rounded(finish))

    def worked(self, start: dt.datetime, finish: dt.datetime) -> float:
        """Working seconds of the calendar from ``start`` to ``finish``."""
        return working_seconds(self.calendar, start, finish)


def _origin(text: str | None) -> dt.datetime:
    try:
        return dt.datetime.fromisoformat(text) if text else dt.datetime.combine(dt.date.today(), dt.time(8))
    except ValueError:
        raise InputError(f"the schedule start {text!r} is not an ISO date-time such as 2026-03-02T08:00") from None


def _rounded(when: dt.datetime) -> dt.datetime:
    """``when`` to the nearest second."""
    return (when + dt.timedelta(microseconds=500_000)).replace(microsecond=0)


def _set_times(ifc, task, clock: _Clock, start: dt.datetime, finish: dt.datetime) -> None:
    """The task's IfcTaskTime from ``start`` to ``finish``, its duration in working days of the calendar."""
    import ifcopenshell.api.sequence as sequence
    from ifcopenshell.util.date import datetime2ifc

    time = sequence.add_task_time(ifc, task=task)
    time.DurationType = DURATION_TYPE
    time.ScheduleStart = datetime2ifc(start, "IfcDateTime")
    time.ScheduleFinish = datetime2ifc(finish, "IfcDateTime")
    days = dt.timedelta(seconds=round(clock.worked(start, finish) / clock.calendar.day_s * 86400))  # P1D = 1 day
    time.ScheduleDuration = datetime2ifc(days, "IfcDuration")


def _assign_calendar(ifc, calendar: WorkCalendar, roots: list) -> None:
    """An IfcWorkCalendar with one weekly working time, assigned to the top-level tasks."""
    import ifcopenshell.api.control
    import ifcopenshell.api.sequence as sequence

    work_calendar = sequence.add_work_calendar(ifc, name=f"Site working time: {calendar}")
    work_time = sequence.add_work_time(ifc, work_calendar=work_calendar, time_type="WorkingTimes")
    work_time.Name = str(calendar)
    pattern = sequence.assign_recurrence_pattern(ifc, parent=work_time, recurrence_type="WEEKLY")
    sequence.edit_recurrence_pattern(ifc, recurrence_pattern=pattern, attributes={"WeekdayComponent": list(calendar.weekdays)})
    sequence.add_time_period(ifc, recurrence_pattern=pattern, start_time=calendar.start_time, end_time=calendar.end_time)
    ifcopenshell.api.control.assign_control(ifc, relating_control=work_calendar, related_objects=roots)


class _Groups:
    """The summary tasks of a work schedule (storey, assembly unit) and the activities nested in them."""

    def __init__(self, ifc, work_schedule):
        self.ifc, self.work_schedule = ifc, work_schedule
        self.roots: list = []  # top-level tasks, in order
        self.storeys: dict[str, object] = {}  # storey GlobalId (or "") -> summary task
        self.units: dict[str, object] = {}  # assembly GlobalId -> summary task
        self.members: dict[int, list[str]] = {}  # summary task id -> activity ids below it
        self.summary_tasks: dict[int, object] = {}
        self.robots: dict[str, object] = {}
        self.outputs: dict[str, list] = {}
        self.unassigned = 0

    @property
    def storey_count(self) -> int:
        return len(self.storeys)

    @property
    def unit_count(self) -> int:
        return len(self.units)

    def summaries(self):
        """(summary task, ids of the activities below it) for every summary task."""
        return [(self.summary_tasks[k], ids) for k, ids in self.members.items()]

    def add_activity(self, a):
        """The activity's IfcTask, nested under its storey and unit (made on first use), with outputs and robot."""
        import ifcopenshell.api.owner
        import ifcopenshell.api.resource
        import ifcopenshell.api.sequence as sequence
        import ifcopenshell.guid

        product = _by_guid(self.ifc, a.global_id)
        parents = self._parents(a, product)
        task = self._task(parents[-1] if parents else None, name=a.name, identification=a.id,
                          description=f"{a.activity} by {a.robot}" if a.robot else str(a.activity),
                          predefined_type=a.predefined_type or "NOTDEFINED")
        for parent in parents:
            self.members[parent.id()].append(a.id)
        if product is None:
            self.unassigned += 1
        for output in self._outputs(product):
            sequence.assign_product(self.ifc, relating_product=output, related_object=task)
        if a.robot:
            if a.robot not in self.robots:
                self.robots[a.robot] = ifcopenshell.api.resource.add_resource(
                    self.ifc, ifc_class="IfcConstructionEquipmentResource", name=a.robot)
            # What sequence.assign_process makes, without its search through every task the robot already
            # has (quadratic: 21 of 67 s on AC20-FZK-Haus's 1,145 activities); the task is new, so unassigned.
            self.ifc.create_entity("IfcRelAssignsToProcess", GlobalId=ifcopenshell.guid.new(),
                                   OwnerHistory=ifcopenshell.api.owner.create_owner_history(self.ifc),
                                   RelatedObjects=[self.robots[a.robot]], RelatingProcess=task)
        return task

    def _task(self, parent, identification: str, **attributes):
        import ifcopenshell.api.sequence as sequence

        if parent is None:
            task = sequence.add_task(self.ifc, work_schedule=self.work_schedule, **attributes)
            self.roots.append(task)
        else:
            task = sequence.add_task(self.ifc, parent_task=parent, **attributes)
        task.Identification = identification  # add_task numbers a nested task after its parent's instead
        return task

    def _summary(self, parent, name: str, identification: str, description: str):
        task = self._task(parent, name=name, identification=identification, description=description)
        self.members[task.id()] = []
        self.summary_tasks[task.id()] = task
        return task

    def _parents(self, a, product) -> list:
        """[storey summary, unit summary]: the summary tasks the activity is nested in (made on first use)."""
        storey = _by_guid(self.ifc, a.storey) if a.storey else None
        if storey is None or not storey.is_a("IfcBuildingStorey"):
            storey = _containing_storey(product)
        unit = _assembly_unit(product)
        parents = []
        if storey is not None:
            if storey.GlobalId not in self.storeys:
                self.storeys[storey.GlobalId] = self._summary(
                    None, storey.Name or storey.GlobalId, f"S{len(self.storeys) + 1}",
                    f"IfcBuildingStorey {storey.GlobalId}: the work on its elements")
            parents.append(self.storeys[storey.GlobalId])
        if unit is not None:
            if unit.GlobalId not in self.units:
                prefix = parents[0].Identification + "." if parents else ""
                count = sum(1 for u in self.units.values() if u.Identification.startswith(prefix)) + 1
                self.units[unit.GlobalId] = self._summary(
                    parents[0] if parents else None, unit.Name or unit.GlobalId, f"{prefix}U{count}",
                    f"{unit.is_a()} {unit.GlobalId}: the work on the unit and its parts")
            parents.append(self.units[unit.GlobalId])
        return parents

    def _outputs(self, product) -> list:
        """The product and every part of it (all levels) that has a body: what a 4D view shows."""
        if product is None:
            return []
        if product.GlobalId not in self.outputs:
            import ifcopenshell.util.element

            parts = [p for p in ifcopenshell.util.element.get_decomposition(product)
                     if p.is_a("IfcElement") and _has_body(p)] if product.is_a("IfcElement") else []
            self.outputs[product.GlobalId] = [product, *sorted(parts, key=lambda p: p.id())]
        return self.outputs[product.GlobalId]


def _has_body(product) -> bool:
    """Whether the product has a shape representation (a body a viewer can draw)."""
    return product.Representation is not None and bool(product.Representation.Representations)


def _assembly_unit(product):
    """The outermost assembly a product is or belongs to (an IfcElementAssembly, or an element with parts),
    or None: the unit that is lifted, also for an activity on one of its sub-assemblies or parts."""
    import ifcopenshell.util.element

    if product is None or not product.is_a("IfcElement"):
        return None
    unit = product if product.is_a("IfcElementAssembly") or product.IsDecomposedBy else None
    whole = ifcopenshell.util.element.get_aggregate(product)
    while whole is not None and whole.is_a("IfcElementAssembly"):
        unit, whole = whole, ifcopenshell.util.element.get_aggregate(whole)
    return unit


def _containing_storey(product):
    """The storey containing the product, or its whole (an assembly's part is in the storey through it)."""
    import ifcopenshell.util.element

    if product is not None and product.is_a("IfcBuildingStorey"):
        return product
    while product is not None:
        container = ifcopenshell.util.element.get_container(product)
        if container is not None:
            return container if container.is_a("IfcBuildingStorey") else None
        product = ifcopenshell.util.element.get_aggregate(product)
    return None


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
