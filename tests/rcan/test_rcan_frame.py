"""The thesis' chapter-4 steel frame: coordination's schedule executed through RCAN, graph kept live."""

from __future__ import annotations

import pytest

from bimrobot.rcan.activities import ActivityKind as K
from bimrobot.rcan.generation import load_capabilities
from bimrobot.rcan.observers import GraphStateObserver
from bimrobot.rcan.plans import plan_from_schedule
from bimrobot.rcan.system import run_plan


@pytest.fixture(scope="module")
def frame(tmp_path_factory, steel_frame_model):
    """(model, schedule, schedule path) of the steel frame built by fleet 2."""
    from bimrobot.site.fleet import load_fleet
    from bimrobot.coordination.schedule import write_schedule_csv
    from bimrobot.coordination.simulation import simulate
    from bimrobot.schedule.csv import load_schedule_csv
    from bimrobot.sco import build_smart_model

    folder, model = tmp_path_factory.mktemp("frame"), steel_frame_model
    result = simulate(build_smart_model(model), load_fleet("fleet2"),
                      storey_elevations=[s.elevation for s in model.storeys])
    path = write_schedule_csv(result.activities, folder / "schedule.csv")
    return model, load_schedule_csv(path, model), path


class Recorder:
    def __init__(self):
        self.events = []

    def set_component_state(self, global_id, state):
        self.events.append(("component", global_id, state))

    def set_activity_state(self, activity_id, state):
        self.events.append(("activity", activity_id, state))


def test_frame_schedule_through_rcan_assembles_every_component_and_updates_the_graph(frame):
    from bimrobot.lbd.graph import build_graph

    model, schedule, _ = frame
    plan = plan_from_schedule(schedule, model)
    graph = build_graph(model, schedule)
    recorder = Recorder()
    report = run_plan(plan, load_capabilities(), observers=[GraphStateObserver(graph, plan), recorder])

    assert report.status == "completed" and len(report.done) == len(plan)
    built = schedule.global_ids()
    assert set(report.component_states) == built and set(report.component_states.values()) == {"Assembled"}
    assert {gid: graph.component_state(gid) for gid in built} == dict.fromkeys(built, "Assembled")
    assert {row.id: graph.activity_state(row.id) for row in schedule} == {row.id: "Completed" for row in schedule}
    # steel members weigh more than the UR5 carries: the allocator gives every one to the heavy robot
    heaviest = max(model.elements[gid].weight_kg for gid in built)
    assert heaviest > 5.0
    assert all(a.weight_kg == model.elements[a.component_id].weight_kg for a in plan)
    # sections for gripper matching come from the members' bounding boxes, e.g. a W250x73 column
    sections = {model.elements[a.component_id].ifc_class: a.section_m for a in plan}
    assert sections["IfcColumn"] == pytest.approx((0.253, 0.254), abs=1e-3)

    # a component with several connection nodes is Assembled only after its last install
    for gid in built:
        installs = {a.activity_id for a in plan if a.component_id == gid and a.kind is K.INSTALL}
        done_at = [i for i, e in enumerate(recorder.events) if e[0] == "activity" and e[1] in installs and e[2] == "done"]
        assembled_at = next(i for i, e in enumerate(recorder.events) if e == ("component", gid, "Assembled"))
        assert len(done_at) == len(installs) and assembled_at > max(done_at)
    assert any(len({a.activity_id for a in plan if a.component_id == gid and a.kind is K.INSTALL}) > 1 for gid in built)


def test_frame_schedule_from_the_cli_with_graph_output(frame, tmp_path, capsys):
    from bimrobot.cli import main
    from bimrobot.lbd.graph import ConstructionGraph

    model, schedule, path = frame
    ttl = tmp_path / "after.ttl"
    code = main(["rcan", "run", "--schedule", str(path), "--model", str(model.source), "--capabilities", "fleet2",
                 "--graph-out", str(ttl), "-q"])
    assert code == 0
    assert f"components: {len(schedule.global_ids())} Assembled" in capsys.readouterr().out
    graph = ConstructionGraph.open(ttl)
    first = next(iter(schedule)).global_id
    assert graph.component_state(first) == "Assembled"


def test_per_node_frame_schedule_runs_to_completion_with_robots_released_after_transport(tmp_path, steel_frame_model):
    """Per connection node, a beam's positioning waits for the columns it joins; fleet 1 has one
    transport robot: the robot sets each component down at its drop-off and brings the next."""
    from bimrobot.site.fleet import load_fleet
    from bimrobot.coordination.schedule import write_schedule_csv
    from bimrobot.coordination.simulation import simulate
    from bimrobot.schedule.csv import load_schedule_csv
    from bimrobot.sco import build_smart_model

    model = steel_frame_model
    result = simulate(build_smart_model(model), load_fleet("fleet1"),
                      storey_elevations=[s.elevation for s in model.storeys], per_node=True)
    schedule = load_schedule_csv(write_schedule_csv(result.activities, tmp_path / "schedule.csv"), model)
    plan = plan_from_schedule(schedule, model)
    report = run_plan(plan, load_capabilities())
    assert report.status == "completed" and len(report.done) == len(plan)
    assert set(report.component_states.values()) == {"Assembled"}
    transports = [a for a in plan if a.kind is K.TRANSPORT]
    assert transports and all(a.releases_robot for a in transports)


def test_prefab_per_node_schedule_does_not_stall_on_one_capable_robot(shared_ifc, tmp_path):
    """MULTICOM-Prefab per node with the site crane: only one robot of the table carries its units."""
    from bimrobot.bim import load_model
    from bimrobot.bim.unknown_weight import UnknownWeightRule, apply_unknown_weight_rule
    from bimrobot.site.fleet import load_fleet
    from bimrobot.coordination.schedule import write_schedule_csv
    from bimrobot.coordination.simulation import simulate
    from bimrobot.schedule.csv import load_schedule_csv
    from bimrobot.sco import build_smart_model

    model = load_model(shared_ifc("MULTICOM-Prefab.ifc"))
    apply_unknown_weight_rule(model.elements.values(), UnknownWeightRule(), "prefab")
    result = simulate(build_smart_model(model), load_fleet("site-crane"),
                      storey_elevations=[s.elevation for s in model.storeys], per_node=True)
    schedule = load_schedule_csv(write_schedule_csv(result.activities, tmp_path / "schedule.csv"), model)
    plan = plan_from_schedule(schedule, model)
    report = run_plan(plan, load_capabilities())
    assert report.status == "completed", report.blocked[:5]
    assert len(report.done) == len(plan)
