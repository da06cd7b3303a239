"""The same answer twice: commands run twice on the same input write the same bytes (issue 35).

Only what is a time stamp may differ, and each test names it."""

from __future__ import annotations

import re
from pathlib import Path

from bimrobot.core.tasks import Activity
from bimrobot.schedule.schedule import Schedule


def _frame_schedule(model) -> Schedule:
    """Each column transported then positioned, by two robots: activities, sequences, resources."""
    activities, clock = [], 0.0
    for number, column in enumerate(model.by_class("IfcColumn")[:3]):
        carry = Activity(f"T{number}", f"Transport {column.global_id}", "transport", column.global_id,
                         "Transport 1", clock, clock + 60.0)
        place = Activity(f"P{number}", f"Position {column.global_id}", "position", column.global_id,
                         "Positioning 1", clock + 60.0, clock + 180.0, predecessors=(carry.id,))
        activities += [carry, place]
        clock += 60.0
    return Schedule(activities, epoch="2026-03-02T08:00:00")


#: The one time stamp in a scheduled copy's data: the IfcWorkSchedule's CreationDate (IfcOpenShell's
#: sequence.add_work_schedule sets it to now). The header's FILE_NAME time stamp is the source model's.
_CREATION_DATE = re.compile(rb"(IFCWORKSCHEDULE\('[^']*',[^,]*,'[^']*',[^,]*,[^,]*,'[^']*',)'[^']*'")


def test_a_scheduled_copy_and_its_scheduler_exports_are_the_same_bytes_twice(steel_frame_ifc, steel_frame_model,
                                                                             tmp_path):
    import ifcopenshell

    from bimrobot.schedule.ifc import scheduled_model, write_schedule_export, write_work_schedule

    schedule = _frame_schedule(steel_frame_model)
    copies = [write_work_schedule(steel_frame_ifc, schedule, tmp_path / f"run{n}.ifc") for n in (1, 2)]
    first, second = (_CREATION_DATE.sub(rb"\1'(time)'", p.read_bytes()) for p in copies)
    assert first == second
    ifc = ifcopenshell.open(str(copies[0]))
    new = ifc.by_type("IfcTask") + ifc.by_type("IfcRelSequence") + ifc.by_type("IfcWorkCalendar")
    assert len(new) == 1 + 6 + 3 + 1  # a storey's summary task, 6 activities, 3 sequences, the calendar
    assert len({e.GlobalId for e in ifc.by_type("IfcRoot")}) == len(ifc.by_type("IfcRoot"))
    assert ifc.by_type("IfcProject")[0].GlobalId == ifcopenshell.open(str(steel_frame_ifc)).by_type("IfcProject")[0].GlobalId

    exports = []  # Microsoft Project XML and Primavera P6 XML (ifc4d), from a fresh copy each run
    for n in (1, 2):
        model, _ = scheduled_model(steel_frame_ifc, schedule)
        exports.append([write_schedule_export(model, tmp_path / f"plan{n}{kind}").read_bytes()
                        for kind in (".xml", ".p6.xml")])
    assert exports[0] == exports[1] and b"<GUID>" in exports[0][0]


def test_rcan_prints_its_interaction_log_in_the_same_order_every_run(tmp_path):
    """Two robots work at once on the sim backend: their threads finish in varying order, the printed
    log is ordered by simulated time and plan order, so each run prints the same lines in the same order.
    The plan names no robot: results are handled in simulated-time order, never in thread order, so each
    activity goes to the same crane and the makespan is the same every run (before: 179.98 s or 180.31 s,
    4 and 6 of 10 runs)."""
    import importlib.util

    from bimrobot.schedule.csv import load_schedule_csv
    from bimrobot.rcan.plans import plan_from_schedule
    from bimrobot.rcan.system import run_plan

    spec = importlib.util.spec_from_file_location("rcan_helpers", Path(__file__).parents[1] / "rcan" / "rcan_helpers.py")
    helpers = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(helpers)
    plan = plan_from_schedule(load_schedule_csv(helpers.frame_schedule(tmp_path / "s.csv")), yard=(-10.0, -10.0, 0.0))
    assert all(activity.robot is None for activity in plan)  # no schedule's assignment: RCAN allocates
    logs, makespans, allocations = [], set(), set()
    for _ in range(5):
        lines: list[str] = []
        report = run_plan(plan, helpers.two_crane_capabilities(), log=lines.append)
        logs.append(lines)
        makespans.add(report.makespan_s)
        allocations.add(tuple(sorted((i, a["robot"]) for i, a in report.activities.items())))
    assert len(allocations) == 1 and len(makespans) == 1, (makespans, len(allocations))
    assert 100.0 < makespans.pop() < 600.0  # 4 columns, 44 activities, two cranes: about 180 s
    for log in logs:  # results in order of their simulated finish; each activity published, sent, then done
        finishes = [float(line.rsplit("-", 1)[1].split()[0]) for line in log if "] result: " in line]
        assert finishes == sorted(finishes)
        for activity in plan:
            at = [next(n for n, line in enumerate(log) if line.startswith(prefix)) for prefix in (
                f"[component {activity.component_id}] publishes {activity.activity_id} ",
                f"[rcan/{activity.activity_id}] robot ", f"[rcan/{activity.activity_id}] result: ")]
            assert at == sorted(at), activity.activity_id
    assert all(log == logs[0] for log in logs)  # component states included, where two results end at once
    assert {line.split("]")[0] for line in logs[0]} >= {"[component " + plan[0].component_id}
    assert sum("robot crane_a executes" in line for line in logs[0]) and sum("robot crane_b executes" in line for line in logs[0])
