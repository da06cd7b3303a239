"""The graph as the hub of the system: the simulation's joints and connection nodes (from IFC relations or
inferred from geometry) with provenance, points and method; prebuilt elements in their starting state; and
the query RCAN's generation system uses to pick what it may start."""

from __future__ import annotations


import pytest

from bimrobot.cli import main
from bimrobot.schedule.csv import load_schedule_csv
from bimrobot.sco import build_smart_model
from shared_data import SHARED_IFC


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """rdflib (about 0.3 s of imports with the graph module), imported when these tests run, not at collection."""
    global RDF, ALLOWED_STATES, ready_activities, BRC, build_graph
    from rdflib import RDF

    from bimrobot.lbd.generation import ALLOWED_STATES, ready_activities
    from bimrobot.lbd.graph import build_graph
    from bimrobot.lbd.terms import BRC


@pytest.fixture(scope="module")
def smart(frame_model):
    return build_smart_model(frame_model, by_element=True)


@pytest.fixture
def hub(frame_model, frame_schedule_csv, smart):
    schedule = load_schedule_csv(frame_schedule_csv, model=frame_model)
    return build_graph(frame_model, schedule, smart=smart), schedule


def test_every_joint_and_node_of_the_simulation_is_in_the_graph(hub, smart):
    graph, _ = hub
    g = graph.store.graph
    joints = set(g.subjects(RDF.type, BRC.Joint))
    assert {graph.id_of(j) for j in joints} == set(smart.joints)
    nodes = set(g.subjects(RDF.type, BRC.ConnectionNode))
    assert {graph.id_of(n) for n in nodes} == set(smart.nodes)
    node = next(iter(smart.nodes.values()))
    iri = graph.interface_iri(node.id)
    assert g.value(iri, BRC.assemblyPoints).toPython() == node.assembly_point_number
    assert str(g.value(iri, BRC.assemblyMethod)) == node.assembly_method == "bolt"
    assert str(g.value(iri, BRC.provenance)) == "ifc-relation"  # the frame's IfcRelConnectsWithRealizingElements
    assert g.value(iri, BRC.partOfJoint) == graph.iri("joint", node.joint_id)


def test_prebuilt_elements_start_in_their_own_state(hub, smart):
    graph, _ = hub
    footings = [c for c in smart.components.values() if c.prebuilt]
    assert len(footings) == 4 and all(c.ifc_class == "IfcFooting" for c in footings)
    assert {graph.component_state(c.id) for c in footings} == {"PositionFixed"}
    assert graph.component_state(next(c.id for c in smart.components.values() if not c.prebuilt)) == "OnYard"


def test_generation_query_follows_predecessors_and_component_states(hub):
    graph, schedule = hub
    first = ready_activities(graph)
    assert {r["activityType"] for r in first} == {"transport"}  # everything is on the yard
    assert all(r["componentState"] == "OnYard" and r["robot"] == "Transport 1" for r in first)
    column = schedule["A0001"].global_id
    graph.set_activity_state("A0001", "Completed")
    # the transport is done but nobody said the column arrived: its positioning may not start yet
    assert "A0002" not in [r["activityId"] for r in ready_activities(graph)]
    graph.set_component_state(column, "Arrived")
    row = next(r for r in ready_activities(graph) if r["activityId"] == "A0002")
    assert (row["activityType"], row["globalId"], row["robot"]) == ("position", column, "Positioning 1")
    assert (row["targetX"], row["targetY"], row["targetZ"]) == pytest.approx(schedule["A0002"].target)
    assert row["weightKg"] == pytest.approx(289.81)
    graph.set_activity_state("A0002", "Completed")
    graph.set_component_state(column, "PositionFixed")
    assemble = next(r for r in ready_activities(graph) if r["activityId"] == "A0003")
    assert assemble["nodeId"] == schedule["A0003"].node_id and assemble["assemblyPoints"] >= 2
    assert assemble["assemblyMethod"] == "bolt" and "PositionFixed" in ALLOWED_STATES["assemble"]


@pytest.mark.skipif(not (SHARED_IFC / "MULTICOM-Prefab.ifc").is_file(), reason="../shared/data/ifc is absent")
def test_prefab_inferred_joints_answer_connected_elements(tmp_path, capsys):
    out = tmp_path / "prefab.ttl"
    assert main(["graph", str(SHARED_IFC / "MULTICOM-Prefab.ifc"), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "60 joints (60 inferred from geometry) with 120 nodes" in printed
    import re

    unit = re.search(r'brc:jointId "([^":]+):', out.read_text())[1]
    assert main(["query", str(out), "connected_elements", "--bind", f"globalId={unit}", "--format", "json"]) == 0
    import json

    rows = json.loads(capsys.readouterr().out)
    from bimrobot.sco.build import ASSUMED_POINTS_PER_JOINT

    # a joint the model gives no fasteners for has the assumed points per joint (4), not 4 per node as before
    assert rows and all(r["provenance"] == "inferred-geometry" and r["assemblyPoints"] == ASSUMED_POINTS_PER_JOINT
                        for r in rows)
    assert {r["ifcClass"] for r in rows} == {"IfcElementAssembly"}  # precast units joined to precast units


def test_progress_bar_only_on_a_terminal(monkeypatch):
    import io as stdio

    from bimrobot.core import progress

    class Terminal(stdio.StringIO):
        def isatty(self):
            return True

    monkeypatch.setattr(progress.sys, "stderr", stdio.StringIO())
    assert progress.progress_bar(10, "graph").disable  # a pipe or a log file: silent
    monkeypatch.setattr(progress.sys, "stderr", Terminal())
    with progress.progress_bar(10, "graph") as bar:
        assert not bar.disable and bar.total == 10
