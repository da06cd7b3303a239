"""One task vocabulary: transport, position, assemble with their requirement and IfcTaskTypeEnum value."""

import csv
import io
import json

import pytest

from bimrobot.sco.states import REQUIREMENT_OF, Requirement
from bimrobot.core.tasks import KIND_TASKS, TASKS, Task


def test_each_task_is_written_with_an_ifc4_task_type_of_its_own():
    ifcopenshell = pytest.importorskip("ifcopenshell")
    enum = ifcopenshell.schema_by_name("IFC4").declaration_by_name("IfcTaskTypeEnum").enumeration_items()
    assert [t.ifc_task_type for t in TASKS] == ["LOGISTIC", "INSTALLATION", "CONSTRUCTION"]
    assert all(t.ifc_task_type in enum for t in TASKS)
    assert [Task.from_ifc_task_type(t.ifc_task_type) for t in TASKS] == list(TASKS)
    assert Task.from_ifc_task_type("DEMOLITION") is None


def test_a_task_is_ready_exactly_in_the_states_that_publish_its_requirement():
    # The state chart (sco) and the vocabulary say the same thing: a component waiting in a ready state
    # of a task publishes that task's requirement.
    assert [t.requirement for t in TASKS] == [
        Requirement.NEED_TO_TRANSFER, Requirement.NEED_TO_POSITION, Requirement.NEED_TO_ASSEMBLE]
    for task in TASKS:
        assert task.ready_states and all(REQUIREMENT_OF[s] == task.requirement for s in task.ready_states)


def test_a_task_reads_and_writes_as_its_plain_name():
    # CSV cells, JSON and log lines stay what they were when tasks were strings.
    out = io.StringIO()
    csv.writer(out).writerow([Task.POSITION, Task.ASSEMBLE.ifc_task_type])
    assert out.getvalue() == "position,CONSTRUCTION\r\n"
    assert json.dumps({"activity": Task.TRANSPORT}) == '{"activity": "transport"}'
    assert f"Publish {Task.POSITION.word} requirements" == "Publish positioning requirements"
    assert Task.parse("assemble") is Task.ASSEMBLE and {"transport": 1}[Task.TRANSPORT] == 1
    with pytest.raises(ValueError, match="'weld' is not a construction task"):
        Task.parse("weld")


def test_every_robot_kind_of_a_fleet_bids_for_its_own_task():
    assert KIND_TASKS == {"transport": (Task.TRANSPORT,), "positioning": (Task.POSITION,),
                          "assembly": (Task.ASSEMBLE,), "mobile_manipulator": TASKS}


def test_the_simulation_and_the_schedule_file_share_one_activity_record(tmp_path):
    # One schedule row type: a row the simulation records is the row the CSV reader gives back, so
    # every field (aborted included) and the duration mean the same everywhere.
    from bimrobot.core.tasks import Activity
    from bimrobot.planning.dispatch import frame_problem
    from bimrobot.planning.planners import plan
    from bimrobot.schedule.csv import load_schedule_csv, write_schedule_csv

    recorded = plan("market", frame_problem())[0].activities
    assert recorded and all(type(a) is Activity for a in recorded)
    read_back = load_schedule_csv(write_schedule_csv(recorded, tmp_path / "schedule.csv")).activities
    assert all(type(a) is Activity for a in read_back)
    assert [(a.id, a.activity, a.global_id, a.robot) for a in read_back] == [(a.id, a.activity, a.global_id, a.robot) for a in recorded]
    row = Activity("A1", "Transport C1", Task.TRANSPORT, "C1", "crane", 2.0, 7.5, target=(1.0, 0.0, 3.0))
    assert row.duration == 5.5 and not row.aborted and row.predefined_type == ""
