"""RCAN generated from the construction graph alone (thesis l.5779-5790): `rcan run --graph`.

The graph is built by `bimrobot graph` from the chapter-4 steel frame and the schedule `simulate` wrote
for fleet 2; the world package (`convert --layout yard`) gives the components their pick-up positions.
"""

from __future__ import annotations

import json
import sqlite3

import pytest

from bimrobot.cli import main
from bimrobot.schedule.csv import load_schedule_csv
from bimrobot.core.tasks import Activity
from bimrobot.schedule.schedule import Schedule
from bimrobot.rcan.activities import ActivityKind as K
from bimrobot.rcan.plans import ComponentFacts, plan_from_graph, plan_from_schedule


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """rdflib (about 0.3 s of imports with the graph module), imported when these tests run, not at collection."""
    global ConstructionGraph
    from bimrobot.lbd.graph import ConstructionGraph


@pytest.fixture(scope="module")
def frame(tmp_path_factory):
    """Folder with frame.ifc, sim/schedule.csv (fleet 2), package/ (yard layout) and graph.ttl."""
    folder = tmp_path_factory.mktemp("graph-frame")
    model = folder / "frame.ifc"
    assert main(["example", "steel-frame", "-o", str(model)]) == 0
    assert main(["simulate", str(model), "--fleet", "fleet2", "-o", str(folder / "sim"), "--no-progress"]) == 0
    assert main(["convert", str(model), "-o", str(folder / "package"), "--layout", "yard", "--no-progress"]) == 0
    assert main(["graph", str(model), "--schedule", str(folder / "sim" / "schedule.csv"), "--package",
                 str(folder / "package"), "-o", str(folder / "graph.ttl")]) == 0
    return folder


def _executed(db_path) -> dict[str, str]:
    with sqlite3.connect(db_path) as db:
        return dict(db.execute("SELECT activity_id, robot FROM activity"))


def _states(db_path) -> dict[str, str]:
    with sqlite3.connect(db_path) as db:
        return dict(db.execute("SELECT global_id, state FROM component"))


def test_a_run_from_the_graph_alone_matches_a_run_from_the_schedule_and_writes_the_states_back(frame, capsys):
    graph_run = ["rcan", "run", "--graph", str(frame / "graph.ttl"), "--capabilities", "fleet2", "-q",
                 "--state-db", str(frame / "g.db"), "--graph-out", str(frame / "after.ttl")]
    assert main(graph_run) == 0
    assert main(["rcan", "run", "--schedule", str(frame / "sim" / "schedule.csv"), "--model", str(frame / "frame.ifc"),
                 "--capabilities", "fleet2", "-q", "--state-db", str(frame / "s.db")]) == 0
    capsys.readouterr()
    # the same activities on the same robots (the ones the schedule assigned), the same end states
    executed = _executed(frame / "g.db")
    assert executed == _executed(frame / "s.db")
    rows = load_schedule_csv(frame / "sim" / "schedule.csv")
    assert {a.id for a in rows} == {activity.rsplit(".", 1)[0] for activity in executed}
    assigned = {a.id: a.robot for a in rows}
    assert all(robot == assigned[activity.rsplit(".", 1)[0]] for activity, robot in executed.items())
    assert _states(frame / "g.db") == _states(frame / "s.db")
    assert set(_states(frame / "g.db").values()) == {"Assembled"}
    # the graph after the run: every scheduled activity Completed, every component Assembled, nothing ready
    after = ConstructionGraph.open(frame / "after.ttl")
    assert {after.activity_state(a.id) for a in rows} == {"Completed"}
    assert {after.component_state(gid) for gid in rows.global_ids()} == {"Assembled"}
    assert after.query("rcan_ready_activities") == []
    # before the run the graph's ready activities are the schedule's first transports
    before = ConstructionGraph.open(frame / "graph.ttl")
    ready = before.query("rcan_ready_activities")
    assert ready and {r["activityType"] for r in ready} == {"transport"}
    assert {r["activityId"] for r in ready} == {a.id for a in rows if not a.predecessors and a.activity == "transport"}


def test_the_graph_plan_is_the_schedule_plan_with_the_yard_of_the_world_package(frame):
    from bimrobot.bim import load_model

    model = load_model(frame / "frame.ifc")
    from_graph = plan_from_graph(ConstructionGraph.open(frame / "graph.ttl"))
    from_schedule = plan_from_schedule(load_schedule_csv(frame / "sim" / "schedule.csv", model), model)
    assert [a.activity_id for a in from_graph] == [a.activity_id for a in from_schedule]
    for g, s in zip(from_graph, from_schedule):
        assert (g.kind, g.component_id, g.robot, set(g.predecessors), g.lifts) == \
               (s.kind, s.component_id, s.robot, set(s.predecessors), s.lifts)
        assert g.weight_kg == pytest.approx(s.weight_kg) and g.section_m == pytest.approx(s.section_m, abs=1e-3)
    # picked up where the world package shows the component on the yard: its centre of mass there
    report = json.loads((frame / "package" / "report.json").read_text())
    poses = {e["global_id"]: e for e in report["converted"]}
    transported = {a.activity_id.rsplit(".", 1)[0] for a in from_graph if a.kind is K.TRANSPORT}
    picks = [a for a in from_graph if a.kind is K.PICK_UP and a.activity_id.rsplit(".", 1)[0] in transported]
    assert picks
    import trimesh.transformations as tf  # here, not at collection

    for pick in picks:
        entry = poses[pick.component_id]
        pose = tf.euler_matrix(*entry["pose_xyz_rpy"][3:], "sxyz")
        pose[:3, 3] = entry["pose_xyz_rpy"][:3]
        centre = (pose @ [*entry["center_of_mass_m"], 1.0])[:3]
        assert pick.target.as_tuple() == pytest.approx(tuple(centre), abs=1e-5)
        yard = report["yard"]["bounds_xy_m"]
        assert yard[0][0] - 1e-6 <= pick.target.x <= yard[1][0] + 1e-6 and yard[0][1] - 1e-6 <= pick.target.y <= yard[1][1] + 1e-6
        assert 0.0 < pick.target.z < 1.0  # a member lying on the ground


def test_graph_package_of_another_layout_is_refused(frame, tmp_path, capsys):
    installed = tmp_path / "installed"
    assert main(["convert", str(frame / "frame.ifc"), "-o", str(installed), "--no-progress"]) == 0
    capsys.readouterr()
    code = main(["graph", str(frame / "frame.ifc"), "--schedule", str(frame / "sim" / "schedule.csv"),
                 "--package", str(installed), "-o", str(tmp_path / "g.ttl")])
    assert code == 2
    err = capsys.readouterr().err
    assert "--layout installed" in err and "--layout yard" in err and err.count("\n") == 1
    assert not (tmp_path / "g.ttl").exists()


def test_a_graph_without_a_schedule_is_refused_in_one_sentence(frame, tmp_path, capsys):
    assert main(["graph", str(frame / "frame.ifc"), "-o", str(tmp_path / "bare.ttl")]) == 0
    capsys.readouterr()
    assert main(["rcan", "run", "--graph", str(tmp_path / "bare.ttl"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "has no scheduled activities" in err and err.count("\n") == 1


def _row(id_, kind, gid, start, predecessors=()):
    return Activity(id_, f"{kind} {gid}", kind, gid, "R1", start, start + 10, predecessors, (5.0, 0.0, 0.0))


def test_a_component_no_assembly_fixes_is_installed_by_its_positioning():
    """Chapter 4: a component without connection nodes is Assembled once positioned; RCAN must not leave
    it PositionFixed (before: 27 of 118 components on MULTICOM-Prefab)."""
    rows = [_row("T1", "transport", "C1", 0), _row("P1", "position", "C1", 10, ("T1",)),
            _row("T2", "transport", "C2", 0), _row("P2", "position", "C2", 10, ("T2",)),
            _row("A2", "assemble", "C2", 20, ("P2",))]
    plan = plan_from_schedule(Schedule(rows))
    kinds = {row: [a.kind for a in plan if a.activity_id.startswith(row + ".")] for row in ("P1", "P2", "A2")}
    assert kinds["P1"][-1] is K.INSTALL  # nothing else fixes C1
    assert K.INSTALL not in kinds["P2"] and kinds["A2"] == [K.MOVE_TO_COMPONENT, K.POSITION_FOR_INSTALLING, K.INSTALL]
    # the robot holds C1 until it is installed (it is not released after positioning)
    p1 = [a for a in plan if a.activity_id.startswith("P1.")]
    assert [a.releases_robot for a in p1] == [False] * (len(p1) - 1) + [True]


def test_a_component_waiting_on_the_yard_within_reach_is_picked_up_there():
    """The thesis' experiment 1: one assemble row and no transport; the component starts OnYard (as the
    graph says), so the row picks it up from its pick-up position and installs it."""
    near = Activity("A1", "Assemble C1", "assemble", "C1", "R1", 0, 10, (), (0.55, -0.35, 0.30))
    on_yard = ComponentFacts(2.0, (0.04, 0.04), None, (0.0, -0.75, 0.45), "OnYard")
    plan = plan_from_schedule(Schedule([near]), facts=lambda gid: on_yard)
    assert [a.kind for a in plan] == [K.MOVE_TO_COMPONENT, K.POSITION_FOR_PICKING_UP, K.PICK_UP,
                                      K.POSITION_FOR_INSTALLING, K.INSTALL]
    assert plan[2].target.as_tuple() == (0.0, -0.75, 0.45) and all(a.lifts for a in plan[:4])
    stand = plan[0].target  # midway: both the pick-up and the install within the UR5's 0.85 m
    assert stand.distance_xy(plan[2].target) <= 0.43 and stand.distance_xy(plan[4].target) <= 0.43
    # 5 m away: the robot carries it over itself and does not let go in between
    rows = [_row("A1", "assemble", "C1", 0)]
    far = plan_from_schedule(Schedule(rows), facts=lambda gid: on_yard)
    assert [a.kind for a in far] == [K.MOVE_TO_COMPONENT, K.POSITION_FOR_PICKING_UP, K.PICK_UP, K.TRANSPORT,
                                     K.POSITION_FOR_INSTALLING, K.INSTALL]
    assert [a.releases_robot for a in far] == [False] * 5 + [True]
    # a component whose start the CSV does not give is taken to be in place (a footing): no pick-up
    in_place = plan_from_schedule(Schedule(rows))
    assert [a.kind for a in in_place] == [K.MOVE_TO_COMPONENT, K.POSITION_FOR_INSTALLING, K.INSTALL]


@pytest.mark.parametrize("number", [1, 2, 3])
def test_the_experiments_are_generated_from_an_ifc_file_and_a_schedule_through_the_graph(number, tmp_path, capsys):
    """`bimrobot example rcan-experiment-N` + a one-row schedule -> `bimrobot graph` -> `rcan run --graph`
    executes exactly the experiment's activities; whether the robot transports the component follows
    from the positions (experiment 1's column is within reach, 2's and 3's are not)."""
    import csv

    from bimrobot.bim import load_model
    from bimrobot.bim.examples import RCAN_EXPERIMENTS
    from bimrobot.rcan.plans import experiment

    _, gid, ifc_class, section, _, kg, pick_up, installed = RCAN_EXPERIMENTS[number]
    model = tmp_path / "experiment.ifc"
    assert main(["example", f"rcan-experiment-{number}", "-o", str(model)]) == 0
    loaded = load_model(model)
    assert loaded.elements[gid].ifc_class == ifc_class and loaded.elements[gid].weight_kg == pytest.approx(kg)
    schedule = tmp_path / "schedule.csv"
    with schedule.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        writer.writerow(["Identification", "Name", "Activity", "GlobalId", "Robot", "Start", "Finish", "Predecessors",
                         "TargetX", "TargetY", "TargetZ"])
        writer.writerow([f"E{number}", f"Assemble {gid}", "assemble", gid, "husky_ur5", 0, 0, "", *installed])
    graph = ConstructionGraph.open(_graph_with_pick_up(model, schedule, gid, pick_up, tmp_path))
    plan = plan_from_graph(graph)
    assert plan == list(experiment(number).activities)
    kinds = [a.kind for a in plan]
    assert (K.TRANSPORT in kinds) == (number != 1)
    assert plan[0].section_m == pytest.approx(section)
    capsys.readouterr()


def _graph_with_pick_up(model, schedule, gid, pick_up, folder):
    """The graph of ``model`` and ``schedule`` with ``gid`` waiting at ``pick_up`` (what `graph --package`
    writes from a yard layout; the experiments' yard is the thesis' pick-up pose)."""
    from bimrobot.bim import load_model
    from bimrobot.lbd.graph import build_graph
    from bimrobot.schedule.csv import load_schedule_csv

    loaded = load_model(model)
    graph = build_graph(loaded, load_schedule_csv(schedule, loaded), pick_up={gid: pick_up})
    path = folder / "experiment.ttl"
    graph.serialize(path)
    return path
