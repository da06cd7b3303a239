"""Schedules in and out: Microsoft Project XML in (the real Schependomlaan planning and small files),
the simulated schedule out as an IfcWorkSchedule in a copy of the IFC, and one CSV reader/writer."""

from __future__ import annotations

from pathlib import Path

import pytest

from bimrobot.cli import main
from bimrobot.core.errors import InputError
from bimrobot.schedule.msproject import load_schedule_msproject
from bimrobot.schedule.csv import load_schedule, load_schedule_csv
from bimrobot.core.tasks import Activity
from bimrobot.schedule.schedule import Schedule
from shared_data import SHARED, SHARED_IFC

PLANNING = SHARED / "data" / "schedules" / "schependomlaan-planning.xml"


@pytest.fixture(scope="module")
def frame_ifc(frame_model):
    return Path(frame_model.source)


@pytest.fixture
def schedule(frame_schedule_csv, frame_model):
    return load_schedule_csv(frame_schedule_csv, model=frame_model)


def msp(tmp_path, tasks: str) -> Path:
    path = tmp_path / "plan.xml"
    path.write_text(f'<?xml version="1.0"?><Project xmlns="http://schemas.microsoft.com/project"><Tasks>{tasks}</Tasks></Project>')
    return path


def task(uid, name, start, finish, *, level=1, summary=0, links=""):
    return (f"<Task><UID>{uid}</UID><ID>{uid}</ID><Name>{name}</Name><OutlineLevel>{level}</OutlineLevel>"
            f"<Summary>{summary}</Summary><Start>{start}</Start><Finish>{finish}</Finish>{links}</Task>")


def link(uid, kind=1):
    return f"<PredecessorLink><PredecessorUID>{uid}</PredecessorUID><Type>{kind}</Type></PredecessorLink>"


@pytest.mark.skipif(not PLANNING.is_file(), reason=f"{PLANNING} is absent")
def test_real_microsoft_project_planning_is_read_whole():
    schedule = load_schedule(PLANNING)
    assert len(schedule.activities) == 157 and not schedule.phases
    assert schedule.epoch == "2015-02-19T08:00:00"
    assert schedule.makespan == pytest.approx((301 * 24 + 8) * 3600)  # 19 Feb 08:00 to 17 Dec 2015 16:00
    links = sum(len(a.predecessors) for a in schedule.activities)
    assert links == 44  # the FINISH_START links; the 4 START_START ones are logged, not used
    assert schedule["74"].predecessors == ("72",) and schedule["74"].name == "Opstellen"
    order = [a.id for a in schedule.topological_order()]
    assert order.index("72") < order.index("74")


def test_tasks_are_matched_to_the_model_or_listed_as_unmatched(tmp_path, frame_model):
    column = frame_model.by_class("IfcColumn")[0].global_id
    storey = frame_model.storeys[1]
    path = msp(tmp_path, "".join([
        task(1, "Steel", "2026-03-02T08:00:00", "2026-03-04T16:00:00", summary=1),
        task(2, f"Erect column {column}", "2026-03-02T08:00:00", "2026-03-02T12:00:00", level=2),
        task(3, storey.name.upper(), "2026-03-02T13:00:00", "2026-03-03T16:00:00", level=2, links=link(2)),
        task(4, "Site cabins", "2026-03-04T08:00:00", "2026-03-04T16:00:00", links=link(3, kind=3)),
    ]))
    schedule = load_schedule(path, model=frame_model)
    assert [p.id for p in schedule.phases] == ["1"]
    assert schedule["2"].global_id == column and schedule["2"].parent == "1"  # by its GlobalId
    assert schedule["3"].global_id == storey.global_id and schedule["3"].predecessors == ("2",)  # by storey name
    assert schedule["4"].global_id is None and schedule["4"].predecessors == ()  # START_START: not a predecessor
    assert schedule.unmatched == ["4"]  # kept, and said
    assert (schedule["3"].start, schedule["3"].finish) == (5 * 3600, (24 + 8) * 3600)


def test_malformed_microsoft_project_files_are_one_sentence(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text('<Project xmlns="http://schemas.microsoft.com/project"><Tasks>')  # cut short
    with pytest.raises(InputError, match=r"bad.xml is not a well-formed Microsoft Project XML schedule"):
        load_schedule_msproject(bad)
    bad.write_text("<schedule/>")
    with pytest.raises(InputError, match=r"is XML but not a Microsoft Project schedule"):
        load_schedule_msproject(bad)
    with pytest.raises(InputError, match="without any task"):
        load_schedule_msproject(msp(tmp_path, ""))
    with pytest.raises(InputError, match="task UID 2 links to predecessor UID 9, which is not a task"):
        load_schedule_msproject(msp(tmp_path, task(2, "x", "2026-01-01T08:00:00", "2026-01-01T09:00:00", links=link(9))))
    with pytest.raises(InputError, match="Start 'soon', which is not an ISO date-time"):
        load_schedule_msproject(msp(tmp_path, task(2, "x", "soon", "2026-01-01T09:00:00")))


def test_graph_cli_reads_an_msp_schedule_and_says_what_it_could_not_match(frame_ifc, tmp_path, capsys):
    path = msp(tmp_path, task(7, "Site cabins", "2026-03-02T08:00:00", "2026-03-02T16:00:00"))
    assert main(["graph", str(frame_ifc), "--schedule", str(path), "-o", str(tmp_path / "g.ttl")]) == 0
    out = capsys.readouterr().out
    assert "1 activities" in out and "1 of 1 tasks name no element or storey of the model (e.g. 7 'Site cabins')" in out
    (tmp_path / "broken.xml").write_text("<Project")
    assert main(["graph", str(frame_ifc), "--schedule", str(tmp_path / "broken.xml"), "-o", str(tmp_path / "h.ttl")]) == 2
    assert "is not a well-formed Microsoft Project XML schedule" in capsys.readouterr().err
    assert not (tmp_path / "h.ttl").exists()


def test_simulated_schedule_is_written_as_an_ifc_work_schedule(frame_ifc, frame_model, schedule, tmp_path):
    import ifcopenshell
    import ifcopenshell.util.sequence as sequence

    from bimrobot.core import io
    from bimrobot.schedule.ifc import read_work_schedule, write_work_schedule

    out = write_work_schedule(frame_ifc, schedule, tmp_path / "frame-4d.ifc", epoch="2026-03-02T08:00:00")
    ifc = ifcopenshell.open(str(out))
    tasks = [t for t in ifc.by_type("IfcTask") if not t.IsNestedBy]  # the activities, nested in storey summaries
    assert len(tasks) == len(schedule.activities) == 28 and len(ifc.by_type("IfcWorkSchedule")) == 1
    by_id = {t.Identification: t for t in tasks}
    for a in schedule.activities:
        assert [p.GlobalId for p in sequence.get_task_outputs(by_id[a.id])] == [a.global_id]
    assert len(ifc.by_type("IfcRelSequence")) == sum(len(a.predecessors) for a in schedule.activities)
    assert io.has_signature(out) and len(ifcopenshell.open(str(frame_ifc)).by_type("IfcTask")) == 0  # a copy
    rows = read_work_schedule(out)  # read back: the same activities
    ids = {r.global_id: r.identification for r in rows}
    back = {r.identification: r for r in rows}
    for a in schedule.activities:
        row = back[a.id]
        assert (row.name, row.outputs, row.resources, row.predefined_type) == (a.name, (a.global_id,), (a.robot,), a.predefined_type)
        assert tuple(ids[p] for p in row.predecessors) == a.predecessors
    again = load_schedule(out, model=frame_model)
    assert sorted((a.start, a.finish) for a in again) == sorted((a.start, a.finish) for a in schedule)


def test_work_schedule_output_policy_and_ifc2x3(frame_ifc, schedule, tmp_path, capsys):
    from bimrobot.schedule.ifc import write_work_schedule

    foreign = tmp_path / "mine.ifc"
    foreign.write_text("not bimrobot's")
    with pytest.raises(InputError, match="bimrobot did not write"):
        write_work_schedule(frame_ifc, schedule, foreign)
    assert foreign.read_text() == "not bimrobot's"
    with pytest.raises(InputError):
        write_work_schedule(frame_ifc, schedule, frame_ifc)  # never over its input
    trappen = SHARED_IFC / "MULTICOM-trappen_bordessen.ifc"
    if trappen.is_file():  # IFC2X3 has no IfcTaskTime: the scheduled copy is migrated to IFC4
        import ifcopenshell

        original = ifcopenshell.open(str(trappen))
        column = original.by_type("IfcElementAssembly")[0].GlobalId  # a precast unit
        one = Schedule([Activity("A1", "Transport", "transport", column, "R1", 0.0, 60.0),
                        Activity("A2", "Position", "position", column, "R1", 60.0, 90.0, ("A1",))])
        write_work_schedule(trappen, one, tmp_path / "t.ifc", epoch="2027-03-01T07:00")
        copy = ifcopenshell.open(str(tmp_path / "t.ifc"))
        assert copy.schema == "IFC4"
        assert len(copy.by_type("IfcProduct")) == len(original.by_type("IfcProduct"))  # every element kept
        tasks = {t.Identification: t for t in copy.by_type("IfcTask") if not t.IsNestedBy}
        assert set(tasks) == {"A1", "A2"} and tasks["A2"].TaskTime.ScheduleStart == "2027-03-01T07:01:00"
        products = [r.RelatingProduct for r in tasks["A1"].HasAssignments if r.is_a("IfcRelAssignsToProduct")]
        assert products[0].GlobalId == column and len(products) > 1  # the unit, then its parts with a body
        assert all(p.Representation is not None for p in products[1:])
        assert tasks["A2"].IsSuccessorFrom[0].RelatingProcess == tasks["A1"]


def test_graph_cli_writes_the_scheduled_ifc(frame_ifc, frame_schedule_csv, tmp_path, capsys):
    out = tmp_path / "frame-4d.ifc"
    args = ["graph", str(frame_ifc), "--schedule", str(frame_schedule_csv), "-o", str(tmp_path / "g.ttl"), "--ifc-out", str(out)]
    assert main(args) == 0
    assert "with an IfcWorkSchedule of 30 IfcTasks (28 activities nested in 2 storeys)" in capsys.readouterr().out
    assert main(args) == 0  # its own output is replaced
    assert main(["graph", str(frame_ifc), "-o", str(tmp_path / "h.ttl"), "--ifc-out", str(tmp_path / "x.ifc")]) == 2
    assert "--ifc-out writes the schedule out: give --schedule FILE" in capsys.readouterr().err


def test_coordination_writes_and_reads_through_the_one_schedule_module(tmp_path, schedule):
    from bimrobot.coordination import schedule as coordination
    from bimrobot.schedule import csv as lbd

    assert coordination.COLUMNS is lbd.COLUMNS and coordination.is_schedule_csv is lbd.is_schedule_csv
    path = lbd.write_schedule_csv(schedule, tmp_path / "s.csv")
    rows = coordination.load_schedule_csv(path)
    assert [r["Identification"] for r in rows] == [a.id for a in lbd.load_schedule_csv(path)]
    assert rows[1]["Predecessors"] == ["A0001"] and isinstance(rows[0]["Start"], float)


def test_successors_and_topological_order_on_a_long_chain():
    n = 20_000
    chain = [Activity(f"A{i}", "x", "transport", "C", None, float(i), float(i + 1), (f"A{i - 1}",) if i else ())
             for i in range(n)]
    schedule = Schedule(list(reversed(chain)))
    assert [a.id for a in schedule.topological_order()] == [a.id for a in chain]
    assert [a.id for a in schedule.successors("A41")] == ["A42"]


def test_a_schedule_built_by_hand_names_its_cycle_or_its_unknown_predecessor():
    # Earliest start first, ties by id; a cycle is named by its activities in execution order.
    rows = [Activity("B", "x", "position", "C", None, 0.0, 1.0), Activity("A", "x", "transport", "C", None, 0.0, 1.0),
            Activity("C", "x", "assemble", "C", None, 0.0, 1.0, ("B",))]
    assert [a.id for a in Schedule(rows).topological_order()] == ["A", "B", "C"]
    looped = [Activity("A1", "x", "transport", "C", None, 0, 0, ("A3",)), Activity("A2", "x", "position", "C", None, 0, 0, ("A1",)),
              Activity("A3", "x", "assemble", "C", None, 0, 0, ("A2",)), Activity("A4", "x", "assemble", "C", None, 0, 0)]
    with pytest.raises(InputError, match=r"^the activities of the schedule form a cycle A1 -> A2 -> A3 -> A1$"):
        Schedule(looped).topological_order()
    with pytest.raises(InputError, match=r"^activity A2 of the schedule has the predecessor 'A9', which is not one of its"):
        Schedule([looped[3], Activity("A2", "x", "position", "C", None, 0, 0, ("A9",))]).topological_order()


def test_two_microsoft_project_tasks_with_one_uid_are_refused_not_merged(tmp_path):
    path = msp(tmp_path, task(2, "a", "2026-01-01T08:00:00", "2026-01-01T09:00:00")
               + task(2, "b", "2026-01-01T09:00:00", "2026-01-01T10:00:00"))
    with pytest.raises(InputError, match=r"plan.xml: tasks 1 and 2 of the file have the same UID 2 \(each task needs its own\)"):
        load_schedule_msproject(path)


def test_microsoft_project_limits_refuse_before_or_while_reading(tmp_path, monkeypatch):
    tasks = "".join(task(n, f"t{n}", "2026-01-01T08:00:00", "2026-01-01T09:00:00") for n in range(1, 6))
    path = msp(tmp_path, tasks)
    monkeypatch.setenv("BIMROBOT_SCHEDULE_MAX_ROWS", "4")
    with pytest.raises(InputError, match=r"plan.xml: the file has more than 4 tasks, the limit; .*BIMROBOT_SCHEDULE_MAX_ROWS"):
        load_schedule_msproject(path)
    monkeypatch.setenv("BIMROBOT_SCHEDULE_MAX_ROWS", "5")
    assert len(load_schedule_msproject(path)) == 5
    path.write_text(path.read_text().replace("<Tasks>", "<Tasks>" + " " * 1_100_000))
    monkeypatch.setenv("BIMROBOT_MSPROJECT_MAX_MB", "1")
    with pytest.raises(InputError, match=r"more than the 1 MB a Microsoft Project XML file may have; .*BIMROBOT_MSPROJECT_MAX_MB"):
        load_schedule_msproject(path)


def test_a_microsoft_project_plan_over_31_years_is_refused(tmp_path):
    path = msp(tmp_path, task(1, "a", "2026-01-01T08:00:00", "2026-01-01T09:00:00")
               + task(2, "b", "2026-01-01T08:00:00", "2090-01-01T09:00:00"))
    with pytest.raises(InputError, match=r"task 2 ends 2.02e\+09 s after the earliest start, more than the 1e\+09 s"):
        load_schedule_msproject(path)
