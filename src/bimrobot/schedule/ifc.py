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


# -------------------------------------------------------------------------------------- working time

WEEKDAY_NAMES = ("Monday", "Tuesday", "Wednesday", "Thursday", "Friday", "Saturday", "Sunday")


@dataclass(frozen=True)
class WorkCalendar:
    """When the site works: ``days`` (weekday names, Monday first) and one daily period ``hours`` =
    (start, end) as "HH:MM" (local wall-clock time, no time zone, start < end on the same day).

    The fields are the site file's ``work_calendar`` keys, in text, so that the calendar written into a
    report (``dataclasses.asdict``, JSON) reads back as a site file's. The default is Monday-Friday
    07:00-16:00 (9 h a day, 45 h a week)."""

    days: tuple[str, ...] = WEEKDAY_NAMES[:5]
    hours: tuple[str, str] = ("07:00", "16:00")

    @property
    def weekdays(self) -> tuple[int, ...]:
        """ISO weekday numbers of the working days (1 = Monday ... 7 = Sunday)."""
        return tuple(WEEKDAY_NAMES.index(day) + 1 for day in self.days)

    @property
    def start_time(self) -> dt.time:
        return dt.time.fromisoformat(self.hours[0])

    @property
    def end_time(self) -> dt.time:
        return dt.time.fromisoformat(self.hours[1])

    @property
    def day_s(self) -> float:
        """Working seconds of one working day."""
        return _seconds_of_day(self.end_time) - _seconds_of_day(self.start_time)

    @property
    def week_s(self) -> float:
        """Working seconds of one week."""
        return self.day_s * len(self.weekdays)

    def __str__(self) -> str:
        """E.g. ``Monday-Friday 07:00-16:00``: runs of consecutive days joined by a dash."""
        runs: list[list[int]] = []
        for day in sorted(self.weekdays):
            if runs and runs[-1][-1] == day - 1:
                runs[-1].append(day)
            else:
                runs.append([day])
        days = ", ".join(WEEKDAY_NAMES[r[0] - 1] + (f"-{WEEKDAY_NAMES[r[-1] - 1]}" if len(r) > 1 else "") for r in runs)
        return f"{days} {self.start_time:%H:%M}-{self.end_time:%H:%M}"


def _seconds_of_day(time: dt.time) -> float:
    return time.hour * 3600 + time.minute * 60 + time.second


def working_datetime(calendar: WorkCalendar, origin: dt.datetime, seconds: float, *, finish: bool = False) -> dt.datetime:
    """The date-time at which ``seconds`` of working time have passed since ``origin``.

    Work only runs in the calendar's working periods: the simulated seconds of a robot's work are laid
    onto working hours, so an hour of work that starts at 15:30 on a Friday ends at 07:30 on Monday
    (default calendar). An instant at the end of a working day is the end of that day when it is a
    ``finish`` and the start of the next working day otherwise. ``origin`` outside working time counts
    from the next working period. Pure arithmetic, no time zone (wall-clock time of the site).
    """
    monday = dt.datetime.combine(origin.date() - dt.timedelta(days=origin.weekday()), dt.time())
    worked = _worked_in_week(calendar, monday, origin) + seconds
    weeks, rest = divmod(worked, calendar.week_s)
    if finish and rest == 0 and weeks > 0:  # the end of the last working day of the week before
        weeks, rest = weeks - 1, calendar.week_s
    start_s = _seconds_of_day(calendar.start_time)
    for day in range(7):
        if day + 1 not in calendar.weekdays:
            continue
        if rest < calendar.day_s or (finish and rest <= calendar.day_s):
            return monday + dt.timedelta(weeks=weeks, days=day, seconds=start_s + rest)
        rest -= calendar.day_s
    return monday + dt.timedelta(weeks=weeks + 1)  # not reached: rest < week_s


def _worked_in_week(calendar: WorkCalendar, monday: dt.datetime, when: dt.datetime) -> float:
    """Working seconds from ``monday`` 00:00 to ``when`` (a date-time of that week)."""
    day = (when.date() - monday.date()).days
    worked = calendar.day_s * sum(1 for d in calendar.weekdays if d <= day)
    if day + 1 in calendar.weekdays:
        into = (when - dt.datetime.combine(when.date(), calendar.start_time)).total_seconds()
        worked += min(max(into, 0.0), calendar.day_s)
    return worked


def working_seconds(calendar: WorkCalendar, start: dt.datetime, finish: dt.datetime) -> float:
    """Working seconds of the calendar from ``start`` to ``finish`` (the inverse of :func:`working_datetime`;
    0 when ``finish`` is not after ``start``)."""
    if finish <= start:
        return 0.0
    monday = dt.datetime.combine(start.date() - dt.timedelta(days=start.weekday()), dt.time())
    later = dt.datetime.combine(finish.date() - dt.timedelta(days=finish.weekday()), dt.time())
    weeks = (later - monday).days // 7
    return weeks * calendar.week_s + _worked_in_week(calendar, later, finish) - _worked_in_week(calendar, monday, start)


def working_days(calendar: WorkCalendar, first: dt.date, last: dt.date) -> int:
    """Working days of the calendar from ``first`` to ``last``, both included."""
    weeks, extra = divmod((last - first).days + 1, 7)
    return weeks * len(calendar.weekdays) + sum(
        1 for d in range(extra) if (first + dt.timedelta(days=d)).isoweekday() in calendar.weekdays)


def work_calendar_from(value, source: str, line: str = "") -> WorkCalendar:
    """The site file's ``work_calendar`` value, e.g. ``{days: [Monday, ..., Friday], hours: ["07:00", "16:00"]}``.

    ``days``: weekday names (or their first three letters, any case); ``hours``: [start, end] as
    ``"HH:MM"`` (an unquoted 7:00 reads as YAML's 420 minutes and is taken so). Both keys are optional
    (default Monday-Friday, 07:00-16:00). ``source`` (the file) and ``line`` (`` line N`` of the key)
    name where in a refusal."""
    from bimrobot.core.config import check_keys, line_of

    if not isinstance(value, dict):
        raise InputError(f"{source}{line}: key 'work_calendar' must be a mapping with days and hours, "
                         "e.g. {days: [Monday, Tuesday, Wednesday, Thursday, Friday], hours: ['07:00', '16:00']}")
    check_keys(value, ("days", "hours"), source, "work_calendar")
    default = WorkCalendar()
    weekdays, (start, end) = default.weekdays, (default.start_time, default.end_time)
    if "days" in value:
        where = f"{source}{line_of(value, 'days')}: work_calendar: key 'days'"
        days = value["days"]
        if not isinstance(days, list) or not days:
            raise InputError(f"{where} must be a non-empty list of weekday names, e.g. [Monday, Tuesday]")
        weekdays = tuple(sorted({_weekday(day, where) for day in days}))
    if "hours" in value:
        where = f"{source}{line_of(value, 'hours')}: work_calendar: key 'hours'"
        hours = value["hours"]
        if not isinstance(hours, list) or len(hours) != 2:
            raise InputError(f"{where} must be [start, end], e.g. ['07:00', '16:00'], got {hours!r}")
        start, end = (_clock(h, where) for h in hours)
        if not start < end:
            raise InputError(f"{where}: the start {start:%H:%M} must be before the end {end:%H:%M} on the same day")
    return WorkCalendar(tuple(WEEKDAY_NAMES[d - 1] for d in weekdays), (f"{start:%H:%M}", f"{end:%H:%M}"))


def _weekday(name, where: str) -> int:
    text = str(name).strip().lower()
    for number, day in enumerate(WEEKDAY_NAMES, start=1):
        if len(text) >= 3 and day.lower().startswith(text):
            return number
    raise InputError(f"{where}: {name!r} is not a weekday (Monday ... Sunday, or Mon ... Sun)")


def _clock(value, where: str) -> dt.time:
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 24 * 60:  # YAML 1.1 read 7:00 as 420
        return dt.time(value // 60, value % 60)
    try:
        return dt.time.fromisoformat(str(value))
    except ValueError:
        raise InputError(f"{where}: {value!r} is not a time of day such as '07:00'") from None


# ------------------------------------------------------------------------------------------- writing

#: IfcTaskTime.DurationType of written tasks: durations count working time of the IfcWorkCalendar.
DURATION_TYPE = "WORKTIME"
#: Suffixes of ``--schedule-out``: what each writes (through ifc4d).
SCHEDULE_EXPORTS = {".p6.xml": "Primavera P6 XML", ".xml": "Microsoft Project XML"}


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


def schedule_export_kind(path: str | os.PathLike, option: str = "--schedule-out") -> str:
    """``"p6"`` for a name ending in .p6.xml, ``"msp"`` for another .xml; anything else is refused."""
    name = Path(path).name.lower()
    if name.endswith(".p6.xml"):
        return "p6"
    if name.endswith(".xml"):
        return "msp"
    if name.endswith(".xer"):
        raise InputError(f"{option} {path}: ifc4d writes Primavera P6 as P6 XML, not XER; give a name ending in "
                         ".p6.xml (P6 imports it), or .xml for Microsoft Project")
    raise InputError(f"{option} {path}: give a name ending in .xml (Microsoft Project XML) or .p6.xml (Primavera P6 XML)")


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
    ifc = _open(ifc_in) if parsed is None else parsed
    if ifc.schema == "IFC2X3":  # no IfcTaskTime in IFC2X3: the copy is migrated to IFC4 first
        ifc = migrated_to_ifc4(ifc, ifc_in)
    clock = _Clock(calendar, origin, calendar_time=bool(getattr(schedule, "epoch", None)))
    spans = {a.id: clock.span(a.start, a.finish) for a in activities}
    first, last = min(s for s, _ in spans.values()), max(f for _, f in spans.values())
    first_new_id = ifc.get_max_id() + 1
    work_schedule = sequence.add_work_schedule(ifc, name=name, predefined_type="PLANNED", start_time=first)
    work_schedule.Identification = "BIMROBOT"
    groups = _Groups(ifc, work_schedule)
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
    _assign_calendar(ifc, calendar, groups.roots)
    _stable_global_ids(ifc, first_new_id, seed=f"{_model_key(ifc, ifc_in)}/{name}")
    if groups.unassigned:
        log.warning("%d of %d activities act on no product of %s: their tasks are not assigned to a product",
                    groups.unassigned, len(activities), ifc_in)
    figures = ScheduleFigures(activities=len(activities), storeys=groups.storey_count, units=groups.unit_count,
                              calendar=calendar, start=first, finish=last,
                              working_days=working_days(calendar, first.date(), last.date()))
    return ifc, figures


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


def write_schedule_export(ifc, path: str | os.PathLike, calendar: WorkCalendar | None = None, *, inputs=(),
                          option: str = "--schedule-out") -> Path:
    """Write the work schedule of ``ifc`` (made by :func:`scheduled_model`) for a scheduler, through ifc4d:
    ``*.xml`` Microsoft Project XML (``ifc4d.ifc2msp``), ``*.p6.xml`` Primavera P6 XML (``ifc4d.ifc2p6``).

    ifc4d 0.9.0 writes a duration as its whole days times 8 h, which makes every robot activity (minutes
    long) 0 h, and a P6 calendar as 8 h a day; both are corrected from the IfcTaskTime and ``calendar``
    after ifc4d has run: durations in working hours (P6 hours, MS Project ``PT#H#M#S``), the calendar's
    hours per day, week, month and year (P6) and minutes per day (MS Project). MS Project tasks also get
    a Start No Earlier Than constraint at their simulated start, so that auto-scheduling keeps the waits
    for a busy robot that no link shows. The file carries ``io.SIGNATURE`` in an XML comment; it goes
    through the output policy. Returns ``path``."""
    from bimrobot.core import io

    calendar = calendar or WorkCalendar()
    kind = schedule_export_kind(path, option)
    work_schedule = next((w for w in ifc.by_type("IfcWorkSchedule") if w.Identification == "BIMROBOT"), None)
    if work_schedule is None:
        raise InputError(f"{option} {path}: the model has no work schedule written by bimrobot to export")
    root = (_msp_export if kind == "msp" else _p6_export)(ifc, work_schedule, calendar)
    import xml.etree.ElementTree as ET

    text = ET.tostring(root, encoding="unicode")
    comment = f"<!-- {io.signature(SCHEDULE_EXPORTS['.p6.xml' if kind == 'p6' else '.xml'] + ' through ifc4d')} -->"
    with io.atomic_output_file(path, inputs=inputs, option=option) as tmp:
        tmp.write_text(f"<?xml version='1.0' encoding='utf-8'?>\n{comment}\n{text}\n", encoding="utf-8")
    return Path(path)


def _working_hours(task, calendar: WorkCalendar) -> float:
    """The task's ScheduleDuration (working days, P1D = one working day) in working hours."""
    from ifcopenshell.util.date import ifc2datetime

    days = ifc2datetime(task.TaskTime.ScheduleDuration)
    return days.total_seconds() / 86400 * calendar.day_s / 3600


def _exported(exporter, work_schedule) -> None:
    """Run an ifc4d exporter into a scratch file, its progress prints silenced (the tree stays in memory)."""
    import contextlib
    import io as text_io
    import tempfile

    exporter.work_schedule = work_schedule
    with tempfile.TemporaryDirectory() as folder, contextlib.redirect_stdout(text_io.StringIO()):
        exporter.xml = str(Path(folder) / "schedule.xml")
        try:
            exporter.execute()
        except Exception as exc:  # ifc4d raises what its code meets (IndexError, KeyError ...)
            raise InputError(f"ifc4d's {type(exporter).__name__} could not export the work schedule of this model: "
                             f"{type(exc).__name__}: {exc}") from None


def _msp_export(ifc, work_schedule, calendar: WorkCalendar):
    """Microsoft Project XML (MSPDI) of the work schedule: ifc4d's Ifc2Msp, durations corrected."""
    import xml.etree.ElementTree as ET

    from ifc4d.ifc2msp import Ifc2Msp

    exporter = Ifc2Msp()
    exporter.file = ifc
    exporter.hours_per_day = calendar.day_s / 3600
    _exported(exporter, work_schedule)
    guids = exporter.root.findall("GUID")
    for duplicate in guids[1:]:  # ifc4d writes the project's GUID twice
        exporter.root.remove(duplicate)
    minutes_per_day = exporter.root.find("MinutesPerDay")
    minutes_per_day.text = str(round(calendar.day_s / 60))
    week = ET.Element("MinutesPerWeek")
    week.text = str(round(calendar.week_s / 60))
    exporter.root.insert(list(exporter.root).index(minutes_per_day) + 1, week)
    for task, element in exporter.element_map.items():
        if not task.is_a("IfcTask") or task.TaskTime is None:
            continue
        seconds = round(_working_hours(task, calendar) * 3600)
        element.find("Duration").text = f"PT{seconds // 3600}H{seconds // 60 % 60}M{seconds % 60}S"
        if not task.IsNestedBy:  # a leaf: keep its simulated start
            calendar_uid = element.find("CalendarUID")
            at = list(element).index(calendar_uid) if calendar_uid is not None else len(element)
            constraint, date = ET.Element("ConstraintType"), ET.Element("ConstraintDate")
            constraint.text, date.text = "4", task.TaskTime.ScheduleStart  # 4: Start No Earlier Than
            element.insert(at, constraint)
            element.insert(at + 2, date)
    return exporter.root


def _p6_export(ifc, work_schedule, calendar: WorkCalendar):
    """Primavera P6 XML of the work schedule: ifc4d's Ifc2P6, durations and calendar hours corrected."""
    from ifc4d.ifc2p6 import Ifc2P6

    exporter = Ifc2P6()
    exporter.file = ifc
    exporter.hours_per_day = calendar.day_s / 3600
    exporter.holiday_start_date = exporter.holiday_finish_date = dt.date.today()  # no holidays to list
    # ifc4d makes a P6 project of every IfcWorkSchedule in the file (a model may bring its own, whose
    # tasks may have no times) and takes the file's first calendar as the default: only ours here.
    exporter.create_projects = lambda: exporter.create_project(work_schedule)
    _exported(exporter, work_schedule)
    calendar_entity = next(c for c in ifc.by_type("IfcWorkCalendar") if c.Name == f"Site working time: {calendar}")
    for element in exporter.root.iter():
        if element.tag.rpartition("}")[2] == "ActivityDefaultCalendarObjectId":
            element.text = exporter.id_map[calendar_entity]
    hours = {"HoursPerDay": calendar.day_s / 3600, "HoursPerWeek": calendar.week_s / 3600,
             "HoursPerMonth": calendar.week_s / 3600 * 52 / 12, "HoursPerYear": calendar.week_s / 3600 * 52}
    for element in exporter.root.iter():
        tag = element.tag.rpartition("}")[2]
        if tag in hours:
            element.text = f"{hours[tag]:g}"
    for task, element in exporter.element_map.items():
        if task.is_a("IfcTask") and task.TaskTime is not None and element.find("PlannedDuration") is not None:
            for tag in ("PlannedDuration", "RemainingDuration"):
                element.find(tag).text = f"{_working_hours(task, calendar):.6f}".rstrip("0").rstrip(".")
    return exporter.root


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
