"""The 4D schedule a BIM user expects (issue 36): the simulated build written into a copy of the IFC with
summary tasks per storey and assembly unit, the site's IfcWorkCalendar, times in working hours and
outputs on the parts with a body; and the same schedule for Microsoft Project and Primavera P6 through
ifc4d. Every check re-reads what was written: the IFC with ``ifcopenshell.util.sequence``, the exports
with ifc4d's own importers (msp2ifc, p62ifc) and as XML."""

from __future__ import annotations

import contextlib
import datetime as dt
import io as text_io
import random
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from bimrobot.schedule.ifc import WorkCalendar, working_datetime, working_days
from bimrobot.cli import main
from bimrobot.schedule.csv import load_schedule_csv
from bimrobot.core.tasks import Activity
from bimrobot.schedule.schedule import Schedule

FRIDAY_LATE = "2026-03-06T15:50:00"  # the frame's 19 minutes of work run over the weekend
MSP = {"p": "http://schemas.microsoft.com/project"}


def when(text: str) -> dt.datetime:
    from ifcopenshell.util.date import ifc2datetime

    return ifc2datetime(text)


@pytest.fixture(scope="module")
def frame_ifc(frame_model) -> Path:
    return Path(frame_model.source)


@pytest.fixture(scope="module")
def frame_4d(frame_ifc, frame_schedule_csv, tmp_path_factory):
    """`bimrobot graph --ifc-out --schedule-out plan.xml` on the steel frame from a Friday at 15:50:
    (folder, printed output)."""
    folder = tmp_path_factory.mktemp("frame-4d")
    out = text_io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["graph", str(frame_ifc), "--schedule", str(frame_schedule_csv), "-o", str(folder / "g.ttl"),
                     "--ifc-out", str(folder / "frame-4d.ifc"), "--schedule-out", str(folder / "plan.xml"),
                     "--start", FRIDAY_LATE])
    assert code == 0
    return folder, out.getvalue()


def test_working_time_is_laid_onto_working_hours():
    week = WorkCalendar()  # Monday-Friday 07:00-16:00
    friday = dt.datetime(2026, 3, 6, 15, 30)
    assert working_datetime(week, friday, 3600, finish=True) == dt.datetime(2026, 3, 9, 7, 30)  # over the weekend
    assert working_datetime(week, friday, 1800, finish=True) == dt.datetime(2026, 3, 6, 16, 0)  # ends at 16:00 ...
    assert working_datetime(week, friday, 1800) == dt.datetime(2026, 3, 9, 7, 0)  # ... the next starts on Monday
    assert working_datetime(week, dt.datetime(2026, 3, 7, 10), 0) == dt.datetime(2026, 3, 9, 7, 0)  # Saturday
    assert working_datetime(week, dt.datetime(2026, 3, 2, 5), 45 * 3600, finish=True) == dt.datetime(2026, 3, 6, 16)
    short = WorkCalendar(days=("Monday", "Tuesday", "Wednesday", "Thursday"), hours=("06:30", "17:00"))
    assert working_datetime(short, friday, 0) == dt.datetime(2026, 3, 9, 6, 30)
    assert working_datetime(short, friday, 11 * 3600) == dt.datetime(2026, 3, 10, 7, 0)  # 10.5 h a day
    assert working_days(week, dt.date(2026, 3, 2), dt.date(2026, 3, 15)) == 10
    rng = random.Random(36)
    previous = friday
    for seconds in sorted(rng.uniform(0, 400 * 3600) for _ in range(300)):
        at = working_datetime(week, friday, seconds)
        assert at.isoweekday() <= 5 and dt.time(7) <= at.time() < dt.time(16) and at >= previous
        assert working_datetime(week, friday, seconds + week.week_s) == at + dt.timedelta(days=7)
        previous = at


def test_frame_schedule_is_nested_per_storey_on_the_calendar_in_working_hours(frame_4d, frame_model, frame_schedule_csv):
    import ifcopenshell
    import ifcopenshell.util.sequence as sequence

    folder, printed = frame_4d
    schedule = load_schedule_csv(frame_schedule_csv, model=frame_model)
    assert ("with an IfcWorkSchedule of 30 IfcTasks (28 activities nested in 2 storeys), calendar Monday-Friday "
            "07:00-16:00: 2026-03-06 15:50 to 2026-03-09 07:09, 2 working days") in printed
    ifc = ifcopenshell.open(str(folder / "frame-4d.ifc"))
    (work_schedule,) = ifc.by_type("IfcWorkSchedule")
    roots = sequence.get_root_tasks(work_schedule)
    storeys = {s.global_id: s.name for s in frame_model.storeys}
    assert [t.Name for t in roots] == ["Level 1", "Level 2"] and {t.Name for t in roots} <= set(storeys.values())
    leaves = {t.Identification: t for root in roots for t in sequence.get_all_nested_tasks(root) if not t.IsNestedBy}
    assert set(leaves) == {a.id for a in schedule}
    (calendar,) = ifc.by_type("IfcWorkCalendar")
    (working,) = calendar.WorkingTimes
    assert working.RecurrencePattern.RecurrenceType == "WEEKLY" and working.RecurrencePattern.WeekdayComponent == (1, 2, 3, 4, 5)
    assert [(p.StartTime, p.EndTime) for p in working.RecurrencePattern.TimePeriods] == [("07:00:00", "16:00:00")]
    for a in schedule:
        task = leaves[a.id]
        parent = sequence.get_parent_task(task)
        assert parent in roots and storeys[frame_model.elements[a.global_id].storey_id] == parent.Name
        assert sequence.derive_calendar(task) == calendar  # inherited from the storey task
        start, finish = when(task.TaskTime.ScheduleStart), when(task.TaskTime.ScheduleFinish)
        for moment in (start, finish):
            assert sequence.is_working_day(moment.date(), calendar) and dt.time(7) <= moment.time() <= dt.time(16)
        assert task.TaskTime.DurationType == "WORKTIME"  # working days: P1D = 9 h
        worked = when(task.TaskTime.ScheduleDuration).total_seconds() / 86400 * 9 * 3600
        assert worked == pytest.approx(a.duration, abs=0.5)
        outputs = sequence.get_task_outputs(task)
        assert [p.GlobalId for p in outputs] == [a.global_id] and all(p.Representation for p in outputs)
    starts = sorted(when(t.TaskTime.ScheduleStart) for t in leaves.values())
    finishes = sorted(when(t.TaskTime.ScheduleFinish) for t in leaves.values())
    assert starts[0] == dt.datetime(2026, 3, 6, 15, 50) and finishes[-1].date() == dt.date(2026, 3, 9)
    for root in roots:  # a summary spans its activities
        nested = [t for t in sequence.get_nested_tasks(root)]
        assert when(root.TaskTime.ScheduleStart) == min(when(t.TaskTime.ScheduleStart) for t in nested)
        assert when(root.TaskTime.ScheduleFinish) == max(when(t.TaskTime.ScheduleFinish) for t in nested)


def test_precast_units_are_summary_tasks_whose_activities_output_the_parts(shared_ifc, tmp_path):
    """An IFC2X3 precast model (migrated to IFC4): one summary per storey, one per assembly unit, and
    each activity outputs the unit with every part of it that has a body."""
    import ifcopenshell
    import ifcopenshell.util.element
    import ifcopenshell.util.sequence as sequence

    from bimrobot.schedule.ifc import read_work_schedule, write_work_schedule

    source = shared_ifc("MULTICOM-trappen_bordessen.ifc")
    original = ifcopenshell.open(str(source))
    wholes = {a: ifcopenshell.util.element.get_aggregate(a) for a in original.by_type("IfcElementAssembly")}
    units = [a.GlobalId for a, whole in wholes.items() if whole is None or not whole.is_a("IfcElementAssembly")]
    activities, clock = [], 0.0
    for number, unit in enumerate(units):
        for kind, seconds in (("transport", 1800.0), ("position", 2700.0)):
            previous = (activities[-1].id,) if activities else ()
            activities.append(Activity(f"A{len(activities) + 1}", f"{kind} unit {number}", kind, unit, "Crane",
                                       clock, clock + seconds, previous))
            clock += seconds
    out = write_work_schedule(source, Schedule(activities), tmp_path / "trappen-4d.ifc", epoch="2027-03-01T07:00")
    ifc = ifcopenshell.open(str(out))
    assert ifc.schema == "IFC4"
    (work_schedule,) = ifc.by_type("IfcWorkSchedule")
    roots = sequence.get_root_tasks(work_schedule)
    assert all(r.Description.startswith("IfcBuildingStorey") for r in roots)
    unit_tasks = [t for r in roots for t in sequence.get_nested_tasks(r)]
    assert len(unit_tasks) == len(units) == 9
    for unit_task in unit_tasks:
        leaves = sequence.get_nested_tasks(unit_task)
        assert len(leaves) == 2 and not any(t.IsNestedBy for t in leaves)
        whole = ifc.by_guid(unit_task.Description.split()[1].rstrip(":"))
        parts = [p for p in ifcopenshell.util.element.get_decomposition(whole) if p.Representation]
        assert parts  # the parts that give the unit a body
        for leaf in leaves:
            outputs = sequence.get_task_outputs(leaf)
            assert set(outputs) == {whole, *parts}
    rows = {r.identification: r for r in read_work_schedule(out)}
    assert all(rows[a.id].outputs[0] == a.global_id for a in activities)  # the unit first, then its parts
    finish = max(when(t.TaskTime.ScheduleFinish) for t in ifc.by_type("IfcTask"))
    assert finish == dt.datetime(2027, 3, 2, 9, 15)  # 11.25 h of work: Monday 07:00-16:00, Tuesday 07:00-09:15


def test_a_schedule_read_in_calendar_time_keeps_its_dates(frame_ifc, frame_model, tmp_path):
    """A schedule from Microsoft Project or an IFC has its own dates (``Schedule.epoch``): they are kept,
    not laid onto working hours again; the duration is the working time between them."""
    import ifcopenshell

    from bimrobot.schedule.ifc import write_work_schedule

    column = frame_model.by_class("IfcColumn")[0].global_id
    night = Schedule([Activity("T1", "Erect", "position", column, None, 0.0, 24 * 3600.0)], epoch="2026-03-02T08:00:00")
    out = write_work_schedule(frame_ifc, night, tmp_path / "planned.ifc")
    ifc = ifcopenshell.open(str(out))
    (task,) = [t for t in ifc.by_type("IfcTask") if not t.IsNestedBy]
    assert (task.TaskTime.ScheduleStart, task.TaskTime.ScheduleFinish) == ("2026-03-02T08:00:00", "2026-03-03T08:00:00")
    assert when(task.TaskTime.ScheduleDuration) == dt.timedelta(days=1)  # 8 + 1 working hours = one 9 h day


def test_ms_project_export_reads_back_with_ifc4d(frame_4d, frame_model, frame_schedule_csv, tmp_path):
    import ifcopenshell
    from ifc4d.msp2ifc import MSP2Ifc

    from bimrobot.core import io

    folder, printed = frame_4d
    assert "plan.xml: Microsoft Project XML of the same 30 tasks (ifc4d)" in printed
    assert io.has_signature(folder / "plan.xml")
    written_ifc = ifcopenshell.open(str(folder / "frame-4d.ifc"))
    written = {t.Identification: t for t in written_ifc.by_type("IfcTask")}
    back = _ifc4d_read(MSP2Ifc, folder / "plan.xml", tmp_path)
    tasks = {t.Identification: t for t in back.by_type("IfcTask")}
    leaves = [t for t in tasks.values() if not t.IsNestedBy]
    assert len(tasks) == 30 and len(leaves) == 28 and {t.Name for t in tasks.values() if t.IsNestedBy} == {"Level 1", "Level 2"}
    for leaf in leaves:
        assert (leaf.TaskTime.ScheduleStart, leaf.TaskTime.ScheduleFinish) == (
            written[leaf.Identification].TaskTime.ScheduleStart, written[leaf.Identification].TaskTime.ScheduleFinish)
    (calendar,) = back.by_type("IfcWorkCalendar")
    pattern = calendar.WorkingTimes[0].RecurrencePattern
    assert pattern.WeekdayComponent == (1, 2, 3, 4, 5) and pattern.TimePeriods[0].StartTime == "07:00:00"
    assert len(back.by_type("IfcRelSequence")) == len(written_ifc.by_type("IfcRelSequence")) == 20
    # the durations MS Project schedules with are the simulated seconds of work (ifc4d alone writes 0 h)
    schedule = load_schedule_csv(frame_schedule_csv, model=frame_model)
    root = ET.parse(folder / "plan.xml").getroot()
    assert root.findtext("p:MinutesPerDay", namespaces=MSP) == "540"
    durations = {t.findtext("p:OutlineNumber", namespaces=MSP): t.findtext("p:Duration", namespaces=MSP)
                 for t in root.iterfind("p:Tasks/p:Task", MSP)}
    for a in schedule:
        hours, minutes, seconds = (int(v) for v in durations[a.id][2:-1].replace("H", " ").replace("M", " ").split())
        assert hours * 3600 + minutes * 60 + seconds == pytest.approx(a.duration, abs=1)


def test_p6_export_reads_back_with_ifc4d_on_the_site_calendar(frame_ifc, frame_schedule_csv, frame_model, tmp_path, capsys):
    """--site's work_calendar (Monday-Thursday 06:30-17:00) is the IFC's and P6's calendar."""
    from ifc4d.p62ifc import P62Ifc

    site = tmp_path / "site.yaml"
    site.write_text("work_calendar:\n  days: [Mon, Tue, Wed, Thu]\n  hours: [6:30, '17:00']\n")
    plan = tmp_path / "plan.p6.xml"
    assert main(["graph", str(frame_ifc), "--schedule", str(frame_schedule_csv), "-o", str(tmp_path / "g.ttl"),
                 "--schedule-out", str(plan), "--site", str(site), "--start", FRIDAY_LATE]) == 0
    assert f"{plan}: Primavera P6 XML of the same 30 tasks (ifc4d)" in capsys.readouterr().out
    back = _ifc4d_read(P62Ifc, plan, tmp_path)
    tasks = {t.Identification: t for t in back.by_type("IfcTask")}
    assert len(tasks) == 30 and {t.Name for t in tasks.values() if t.IsNestedBy} == {"Level 1", "Level 2"}
    schedule = load_schedule_csv(frame_schedule_csv, model=frame_model)
    first = min(schedule, key=lambda a: (a.start, a.id))
    assert tasks[first.id].TaskTime.ScheduleStart == "2026-03-09T06:30:00"  # Friday is no working day
    (calendar,) = back.by_type("IfcWorkCalendar")
    pattern = calendar.WorkingTimes[0].RecurrencePattern
    assert pattern.WeekdayComponent == (1, 2, 3, 4) and pattern.TimePeriods[0].EndTime == "17:00:00"
    root = ET.parse(plan).getroot()
    ns = {"p": root.tag[1:].partition("}")[0]}
    assert root.findtext("p:Project/p:Calendar/p:HoursPerDay", namespaces=ns) == "10.5"
    planned = {a.findtext("p:Id", namespaces=ns): float(a.findtext("p:PlannedDuration", namespaces=ns))
               for a in root.iterfind("p:Project/p:Activity", ns)}
    assert all(planned[a.id] * 3600 == pytest.approx(a.duration, abs=0.5) for a in schedule)  # hours of work


def test_bad_names_and_calendars_are_refused_before_anything_is_written(frame_ifc, frame_schedule_csv, tmp_path, capsys):
    graph = ["graph", str(frame_ifc), "--schedule", str(frame_schedule_csv), "-o", str(tmp_path / "g.ttl")]
    refusals = [
        (["--schedule-out", str(tmp_path / "plan.xer")],
         "ifc4d writes Primavera P6 as P6 XML, not XER; give a name ending in .p6.xml"),
        (["--schedule-out", str(tmp_path / "plan.mpp")], "give a name ending in .xml (Microsoft Project XML) or .p6.xml"),
        (["--ifc-out", str(tmp_path / "x.ifczip")], "the scheduled copy is written as .ifc (STEP)"),  # issue 35 item 7
    ]
    site = tmp_path / "site.yaml"
    site.write_text("work_calendar:\n  days: [Monday, Funday]\n")
    refusals.append((["--schedule-out", str(tmp_path / "p.xml"), "--site", str(site)],
                     "site.yaml line 2: work_calendar: key 'days': 'Funday' is not a weekday"))
    for extra, message in refusals:
        assert main(graph + extra) == 2
        assert message in capsys.readouterr().err
        assert not (tmp_path / "g.ttl").exists()  # refused before the graph was written
    assert main(["graph", str(frame_ifc), "-o", str(tmp_path / "g.ttl"), "--schedule-out", str(tmp_path / "p.xml")]) == 2
    assert "--schedule-out writes the schedule out: give --schedule FILE" in capsys.readouterr().err
    for name, message in (("plan.xer", "not XER"), ("out/plan.xml", "without a folder; it is written into the output folder")):
        assert main(["build", str(frame_ifc), "-o", str(tmp_path / "out"), "--schedule-out", name]) == 2
        assert message in capsys.readouterr().err and not (tmp_path / "out").exists()


def test_build_passes_schedule_out_and_the_site_to_the_graph_stage(frame_ifc, tmp_path):
    from bimrobot.cli import build_parser
    from bimrobot.pipeline import PLACED_SITE, STAGES, _unknown_weight_text, _work_schedule_row

    site = tmp_path / "site.yaml"
    args = build_parser().parse_args(["build", str(frame_ifc), "-o", str(tmp_path / "out"), "--schedule-out",
                                      "plan.p6.xml", "--site", str(site)])
    args.unknown_weight_text = _unknown_weight_text(args)  # as build_command sets it
    (graph,) = [s for s in STAGES if s.name == "graph"]
    argv = graph.argv(args, tmp_path / "partial")
    assert argv[argv.index("--schedule-out") + 1] == str(tmp_path / "partial" / "plan.p6.xml")
    assert argv[argv.index("--site") + 1] == str(tmp_path / "partial" / PLACED_SITE)  # the site, placed
    assert "| `plan.p6.xml` | the same work schedule as Primavera P6 XML" in _work_schedule_row(args)


def _ifc4d_read(importer, path: Path, tmp_path: Path):
    """The IFC that ifc4d's importer (MSP2Ifc or P62Ifc) makes of ``path``."""
    import ifcopenshell

    reader = importer()
    reader.xml, reader.output = str(path), str(tmp_path / f"{path.name}.ifc")
    with contextlib.redirect_stdout(text_io.StringIO()):  # P62Ifc prints its timings
        reader.execute()
    return ifcopenshell.open(reader.output)
