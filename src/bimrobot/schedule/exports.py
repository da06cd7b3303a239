"""A scheduled model's work schedule for Microsoft Project or Primavera P6 (``--schedule-out``), through
IfcOpenShell's ifc4d, with the durations (working hours) and the calendar corrected afterwards.
"""

from __future__ import annotations

import datetime as dt
import os
from pathlib import Path

from bimrobot.core.errors import InputError
from bimrobot.site.working_time import WorkCalendar

#: Suffixes of ``--schedule-out``: what each writes (through ifc4d).
SCHEDULE_EXPORTS = {".p6.xml": "Primavera P6 XML", ".xml": "Microsoft Project XML"}


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
