"""The graph on what the other parts produce: the schedule `bimrobot simulate` writes, and the thesis'
state names of bimrobot.sco."""

from __future__ import annotations

import pytest

from bimrobot.cli import main
from bimrobot.schedule.csv import load_schedule_csv


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """rdflib (about 0.3 s of imports with the graph module), imported when these tests run, not at collection."""
    global COMPONENT_STATES, build_graph
    from bimrobot.lbd.graph import build_graph
    from bimrobot.lbd.terms import COMPONENT_STATES


def test_component_states_are_the_sco_state_machine_names():
    states = pytest.importorskip("bimrobot.sco.states")
    assert COMPONENT_STATES == tuple(state.value for state in states.State)


def test_simulated_schedule_builds_a_graph_whose_readiness_follows_the_schedule(frame_model, tmp_path, capsys):
    assert main(["simulate", str(frame_model.source), "--fleet", "fleet2", "-o", str(tmp_path / "sim")]) == 0
    capsys.readouterr()
    schedule = load_schedule_csv(tmp_path / "sim" / "schedule.csv", model=frame_model)
    assert len(schedule) > 0 and schedule.global_ids() <= set(frame_model.elements)
    graph = build_graph(frame_model, schedule)
    # Replay the schedule in topological order: after each completion, the graph's ready activities
    # are exactly those the schedule's predecessor relation allows.
    done: list[str] = []
    for activity in schedule.topological_order()[:12]:
        assert [r["activityId"] for r in graph.query("ready_activities")] == [a.id for a in schedule.ready(done)]
        graph.set_activity_state(activity.id, "Completed")
        done.append(activity.id)
    robots = {a.robot for a in schedule}
    assert {graph.query("activity_robot", activityId=a.id)[0]["robot"] for a in schedule.activities[::4]} <= robots
