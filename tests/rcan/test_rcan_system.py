"""The RCAN system end to end on the sim backend: experiments, state machine, retries, escalation."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bimrobot.core.errors import InputError
from bimrobot.schedule.csv import load_schedule_csv
from bimrobot.rcan.activities import ActivityKind as K, Pose, RcanActivity
from bimrobot.rcan.generation import load_capabilities
from bimrobot.rcan.plans import COLUMN_ID, FOOTING_ID, experiment, plan_from_schedule
from bimrobot.rcan.system import run_plan


class GraphObserver:
    """Stands where the lbd ConstructionGraph goes: records the notifications it receives."""

    def __init__(self):
        self.components, self.activities = [], []

    def set_component_state(self, global_id, state):
        if not self.components or self.components[-1] != (global_id, state):
            self.components.append((global_id, state))

    def set_activity_state(self, activity_id, state):
        self.activities.append((activity_id, state))


@pytest.mark.parametrize("number, component, activities", [
    (1, COLUMN_ID, ["Move to component", "Position for picking up", "Pick up", "Position for installing", "Install"]),
    (2, COLUMN_ID, ["Move to component", "Position for picking up", "Pick up", "Transport", "Position for installing", "Install"]),
    (3, FOOTING_ID, ["Move to component", "Position for picking up", "Pick up", "Transport", "Position for installing", "Install"]),
])
def test_thesis_experiments_assemble_the_component(number, component, activities):
    lines, graph = [], GraphObserver()
    report = run_plan(experiment(number).activities, load_capabilities(), log=lines.append, observers=[graph])
    assert report.status == "completed"
    assert report.component_states == {component: "Assembled"}
    executed = [line.split("executes '")[1].split("'")[0] for line in lines if " executes '" in line]
    assert executed == activities
    expected_states = ["OnYard", "InTransit"] + (["Arrived"] if "Transport" in activities else []) + [
        "WorkingInPositioning", "PositionFixed", "WorkingInAssembly", "Assembled"]
    assert [s for _, s in graph.components] == expected_states
    assert [s for _, s in graph.activities].count("done") == len(activities)
    # the interaction log has every step of fig. 5.12 for the pick-up
    pick = [line for line in lines if f"E{number}.3" in line]
    assert [line.split("]")[0] for line in pick] == ["[component " + component, "[generation", f"[rcan/E{number}.3", f"[rcan/E{number}.3"]


def test_column_out_of_reach_without_transport_is_escalated_with_a_report():
    exp1 = list(experiment(1).activities)
    far = Pose(4.0, 2.0, 0.3)
    plan = exp1[:3] + [RcanActivity(a.activity_id, a.component_id, a.kind, far, a.weight_kg, robot=a.robot,
                                    predecessors=a.predecessors) for a in exp1[3:]]
    report = run_plan(plan, load_capabilities(), max_attempts=2)
    assert report.status == "escalated"
    (escalation,) = report.escalations
    assert (escalation.component_id, escalation.activity_id, escalation.robot, escalation.attempts) == (
        COLUMN_ID, "E1.4", "husky_ur5", 2)
    assert "beyond its 0.85 m reach" in escalation.message
    assert report.done == ["E1.1", "E1.2", "E1.3"] and report.blocked == ["E1.5"]
    assert report.component_states[COLUMN_ID] == "InLocation"  # positioning aborted, waits for a technician


def test_failures_are_retried_then_succeed(tmp_path):
    import sqlite3

    db = tmp_path / "state.sqlite"
    report = run_plan(experiment(2).activities, load_capabilities(), state_db=str(db), max_attempts=10,
                      backend_options={"failure_probability": 0.4, "seed": 5})
    assert report.status == "completed"
    journal = sqlite3.connect(db).execute("SELECT activity_id, event, attempt FROM journal ORDER BY seq").fetchall()
    failed = [(a, n) for a, e, n in journal if e == "failed"]
    assert failed, "p=0.4 over six activities fails at least once with seed 5"
    for activity_id, attempt in failed:  # each failure is followed by the next attempt of the same activity
        assert (activity_id, "started", attempt + 1) in journal
    assert sorted(a for a, e, _ in journal if e == "done") == [f"E2.{i}" for i in range(1, 7)]


def test_schedule_plan_runs_two_robots_in_parallel(schedule_csv, cranes):
    schedule = load_schedule_csv(schedule_csv)
    plan = plan_from_schedule(schedule, yard=(-10.0, -10.0, 0.0))
    # transport: 4 activities, the component is set down at the drop-off and the robot is free;
    # position: a robot picks it up there again and positions it (4, frees the robot, PositionFixed);
    # assemble: a robot goes to the fixed component, positions its tool and installs (3)
    assert len(plan) == 4 * 11
    assert [a.kind for a in plan[:11]] == [
        K.MOVE_TO_COMPONENT, K.POSITION_FOR_PICKING_UP, K.PICK_UP, K.TRANSPORT,
        K.MOVE_TO_COMPONENT, K.POSITION_FOR_PICKING_UP, K.PICK_UP, K.POSITION_FOR_INSTALLING,
        K.MOVE_TO_COMPONENT, K.POSITION_FOR_INSTALLING, K.INSTALL]
    assert [a.releases_robot for a in plan[:11]] == [False, False, False, True] * 2 + [False, False, True]
    assert plan[3].target == Pose(0.0, 3.4, 0.0)  # 0.6 m stand-off before the installed position (0, 4, 0)
    assert plan[6].target == plan[3].target  # picked up again where the transport set it down
    assert [a.activity_id for a in plan[:11]] == ["A0001.1", "A0001.2", "A0001.3", "A0001.4", "A0002.1", "A0002.2",
                                                  "A0002.3", "A0002.4", "A0003.1", "A0003.2", "A0003.3"]
    assert plan[4].predecessors == ("A0001.4",) and plan[8].predecessors == ("A0002.4",)
    report = run_plan(plan, cranes)
    assert report.status == "completed"
    assert set(report.component_states.values()) == {"Assembled"}
    # two robots share the work: the makespan is well below one robot doing everything in sequence
    one_robot = run_plan(plan, replace(cranes, robots=(cranes.by_name["crane_a"],), source="one"))
    assert one_robot.status == "completed"
    assert report.makespan_s < 0.8 * one_robot.makespan_s


def test_plan_with_unknown_predecessor_or_incapable_fleet_is_refused(cranes):
    exp = list(experiment(1).activities)
    with pytest.raises(InputError, match="activity E1.2 names unknown predecessor NOPE"):
        run_plan([exp[0], RcanActivity("E1.2", COLUMN_ID, K.PICK_UP, Pose(0, 0, 0), predecessors=("NOPE",))], cranes)
    heavy = [RcanActivity("X.1", "SLAB", K.PICK_UP, Pose(0, 0, 0), weight_kg=5000.0)]
    with pytest.raises(InputError, match="no robot can take 'Pick up' of component SLAB"):
        run_plan(heavy, cranes)


def test_state_db_of_another_plan_is_refused(tmp_path):
    db = str(tmp_path / "s.sqlite")
    run_plan(experiment(1).activities, load_capabilities(), state_db=db)
    with pytest.raises(InputError, match="belongs to a different plan"):
        run_plan(experiment(2).activities, load_capabilities(), state_db=db)


def test_escalation_isolates_the_component_and_independent_work_runs_to_completion(tmp_path, cranes):
    """One capable robot, random faults, no retries: an escalated component does not keep the robot;
    every activity that does not depend on an escalated one is done, the others are reported blocked
    because of it."""
    from rcan_helpers import frame_schedule

    plan = plan_from_schedule(load_schedule_csv(frame_schedule(tmp_path / "s.csv", components=10)))
    one = replace(cranes, robots=(cranes.by_name["crane_a"],), source="one crane")
    report = run_plan(plan, one, max_attempts=1, backend_options={"failure_probability": 0.1, "seed": 1})
    assert report.status == "escalated"
    # seed 1: a transport fails while the robot holds the column; the robot sets it down and goes on
    assert "Transport" in [e.activity for e in report.escalations]
    successors = {}
    for a in plan:
        for p in a.predecessors:
            successors.setdefault(p, []).append(a.activity_id)
    depends, stack = set(), list(report.escalated)
    while stack:
        for s in successors.get(stack.pop(), ()):
            if s not in depends:
                depends.add(s)
                stack.append(s)
    independent = [a.activity_id for a in plan if a.activity_id not in depends and a.activity_id not in report.escalated]
    assert report.done == independent  # nothing independent is left waiting for the robot
    assert set(report.blocked) == depends == set(report.blocked_by)
    assert set(report.blocked_by.values()) <= set(report.escalated)
    assert len(report.done) > len(plan) / 3
