"""The construction graph of the chapter-4 steel frame: BOT topology, DiCon activities, live states,
the shipped SPARQL queries on both stores, and ontology conformance."""

from __future__ import annotations

import json

import pytest

from bimrobot.core.errors import InputError
from bimrobot.schedule.csv import load_schedule_csv
from bimrobot.schedule.task_rows import load_schedule_ifc
from shared_data import shared_file


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """rdflib (about 0.3 s of imports with the graph module), imported when these tests run, not at collection."""
    global rdflib, RDF, BOT, BRC, DICE, DICP, VOCABULARY_FILE, ConstructionGraph, build_graph, query_names
    import rdflib
    import rdflib.compare
    from rdflib import RDF

    from bimrobot.lbd.graph import ConstructionGraph, build_graph, query_names
    from bimrobot.lbd.terms import BOT, BRC, DICE, DICP, VOCABULARY_FILE


@pytest.fixture(scope="module")
def schedule(frame_schedule_csv, frame_model):
    return load_schedule_csv(frame_schedule_csv, model=frame_model)


@pytest.fixture
def graph(frame_model, schedule):
    return build_graph(frame_model, schedule)


def rdflib_graph(graph: ConstructionGraph) -> rdflib.Graph:
    return graph.store.graph


def test_bot_topology_site_building_storeys_elements(graph, frame_model):
    g = rdflib_graph(graph)
    (site,) = g.subjects(RDF.type, BOT.Site)
    (building,) = g.objects(site, BOT.hasBuilding)
    storeys = set(g.objects(building, BOT.hasStorey))
    assert len(storeys) == 2 and all((s, RDF.type, BOT.Storey) in g for s in storeys)
    contained = {e for s in storeys for e in g.objects(s, BOT.containsElement)}
    assert len(contained) == len(frame_model.elements) == 88
    assert set(g.subjects(RDF.type, BOT.Element)) == contained


def test_element_properties_weight_class_position(graph, frame_model):
    column = frame_model.by_class("IfcColumn")[0]
    g = rdflib_graph(graph)
    iri = graph.element_iri(column.global_id)
    assert g.value(iri, BRC.ifcClass).toPython() == "IfcColumn"
    assert g.value(iri, BRC.weightKg).toPython() == pytest.approx(289.81)  # W250x73, 4 m (thesis table)
    position = g.value(iri, DICE.hasQuality)
    assert (position, RDF.type, DICE.CartesianPosition) in g
    xyz = [g.value(position, p).toPython() for p in (DICE.hasX, DICE.hasY, DICE.hasZ)]
    assert xyz == pytest.approx(column.position.tolist())
    # property sets, as read from the IFC file
    from bimrobot.lbd.terms import PROPS

    assert g.value(iri, PROPS["Pset_ColumnCommon.Reference"]).toPython() == "W250x73"
    assert g.value(iri, PROPS["Pset_ColumnCommon.LoadBearing"]).toPython() is True
    assert len(build_graph(frame_model, properties=False)) < len(build_graph(frame_model))


def test_connections_are_interfaces_of_both_elements_with_their_bolts(graph, frame_model):
    g = rdflib_graph(graph)
    interfaces = set(g.subjects(RDF.type, BOT.Interface))
    assert len(interfaces) == len(frame_model.connections) == 24
    connection = frame_model.connections[0]
    iri = graph.interface_iri(f"{connection.relating_id}:{connection.related_id}")
    assert set(g.objects(iri, BOT.interfaceOf)) == {
        graph.element_iri(connection.relating_id),
        graph.element_iri(connection.related_id),
    }
    assert {graph.id_of(b) for b in g.objects(iri, BRC.realizingElement)} == set(connection.realizing_ids)


def test_iris_percent_encode_dollar(graph, frame_model):
    with_dollar = next(gid for gid in frame_model.elements if "$" in gid)
    iri = graph.element_iri(with_dollar)
    assert "$" not in iri and "%24" in iri
    assert graph.id_of(iri) == with_dollar


def test_activities_with_sequence_interval_object_and_robot(graph, schedule):
    g = rdflib_graph(graph)
    activities = set(g.subjects(RDF.type, DICP.Activity))
    assert len(activities) == len(schedule) == 28
    a = schedule.activities[2]  # assemble of the first column on its base plate node
    iri = graph.activity_iri(a.id)
    assert [graph.id_of(p) for p in g.objects(iri, DICE.precededBy)] == list(a.predecessors)
    interval = g.value(iri, DICP.occupiesTimeInterval)
    assert (interval, RDF.type, DICE.TimeInterval) in g
    assert g.value(g.value(interval, DICE.hasStart), BRC.atSecond).toPython() == a.start
    assert g.value(g.value(interval, DICE.hasEnd), BRC.atSecond).toPython() == a.finish
    assert g.value(iri, DICP.hasOutputObject) == graph.element_iri(a.global_id)
    assert graph.interface_iri(a.node_id) in set(g.objects(iri, DICP.hasObject))
    assert graph.query("activity_robot", activityId=a.id) == [
        {"robot": "Assembly 1", "robotIri": str(graph.iri("robot", "Assembly 1"))}
    ]
    transport = schedule.activities[0]
    assert g.value(graph.activity_iri(transport.id), DICP.hasOutputObject) is None  # transport outputs nothing new


def test_live_states_drive_ready_activities(graph, schedule):
    first = [a.id for a in schedule.ready(done=[])]
    ready = graph.query("ready_activities")
    assert [r["activityId"] for r in ready] == first
    assert ready[0] == {"activityId": "A0001", "activityType": "transport", "globalId": schedule["A0001"].global_id,
                        "robot": "Transport 1", "start": 0.0}
    graph.set_activity_state("A0001", "Started")
    assert graph.activity_state("A0001") == "Started"
    assert "A0001" not in [r["activityId"] for r in graph.query("ready_activities")]
    graph.set_activity_state("A0001", "Completed")
    now_ready = [r["activityId"] for r in graph.query("ready_activities")]
    assert now_ready == [a.id for a in schedule.ready(done=["A0001"])]
    assert "A0002" in now_ready


def test_component_state_updates_and_progress(graph, schedule):
    column = schedule["A0001"].global_id
    assert graph.component_state(column) == "OnYard"
    for state in ("InTransit", "Arrived", "InLocation", "WorkingInPositioning", "PositionFixed"):
        graph.set_component_state(column, state)
    assert graph.query("component_state", globalId=column) == [{"state": "PositionFixed", "ifcClass": "IfcColumn"}]
    assert graph.query("progress") == [
        {"state": "OnYard", "components": 87},
        {"state": "PositionFixed", "components": 1},
    ]
    node = schedule["A0003"].node_id
    assert graph.component_state(node) is None  # nodes get a state once the build reaches them
    graph.set_component_state(node, "Assembled")
    assert graph.component_state(node) == "Assembled"


def test_bad_state_or_id_is_an_input_error(graph, schedule):
    with pytest.raises(InputError, match="unknown component state 'Flying'"):
        graph.set_component_state(schedule["A0001"].global_id, "Flying")
    with pytest.raises(InputError, match="no element or connection node 'nope'"):
        graph.set_component_state("nope", "Assembled")
    with pytest.raises(InputError, match="no activity 'A9999'"):
        graph.set_activity_state("A9999", "Completed")
    with pytest.raises(InputError, match="unknown activity state 'Done'"):
        graph.set_activity_state("A0001", "Done")


def test_storey_components_in_construction_order(graph, schedule, frame_model):
    level1 = frame_model.storeys[0].global_id
    rows = graph.query("storey_components", storeyId=level1)
    scheduled = [r["globalId"] for r in rows if r["firstStart"] is not None]
    expected = sorted({a.global_id for a in schedule if a.storey == level1},
                      key=lambda gid: (schedule.of_component(gid)[0].start, gid))
    assert scheduled == expected
    assert all(r["firstStart"] is None for r in rows[len(scheduled):])  # unscheduled ones last
    assert len(rows) == sum(1 for e in frame_model.elements.values() if e.storey_id == level1)


def test_connected_elements_of_a_column(graph, frame_model):
    column = frame_model.by_class("IfcColumn")[0]
    expected = {c.relating_id if c.related_id == column.global_id else c.related_id
                for c in frame_model.connections_of(column.global_id) if column.global_id in (c.relating_id, c.related_id)}
    rows = graph.query("connected_elements", globalId=column.global_id)
    assert {r["connectedId"] for r in rows} == expected
    assert {frame_model.element(r["connectedId"]).ifc_class for r in rows} == {"IfcPlate", "IfcMember"}  # base plate, clip angles
    assert all(r["realizingCount"] >= 2 for r in rows)  # bolted


def test_component_activities_carry_rcan_properties(graph, schedule, frame_model):
    column = schedule["A0001"].global_id
    rows = graph.query("component_activities", globalId=column)
    assert [r["activityId"] for r in rows] == [a.id for a in schedule.of_component(column)]
    assert rows[0]["weightKg"] == pytest.approx(289.81)
    size = sorted((rows[0]["sizeX"], rows[0]["sizeY"], rows[0]["sizeZ"]))
    assert size[2] == pytest.approx(4.0, abs=0.01)  # the 4 m column; its W250x73 section below
    assert size[0] == pytest.approx(0.254, abs=0.01) and size[1] == pytest.approx(0.254, abs=0.01)
    assert (rows[0]["targetX"], rows[0]["targetY"], rows[0]["targetZ"]) == pytest.approx(schedule["A0001"].target)
    assert {r["state"] for r in rows} == {"NotStarted"}


def test_every_ontology_term_is_defined(graph, ontology_file):
    definitions = rdflib.Graph()
    for name in ("bot.ttl", "dicon-entities-0.5.ttl", "dicon-processes-0.5.ttl"):
        definitions.parse(ontology_file(name), format="turtle")
    definitions.parse(VOCABULARY_FILE, format="turtle")
    defined = set(definitions.subjects(RDF.type, None))
    g = rdflib_graph(graph)
    used = set(g.predicates()) | {o for o in g.objects(None, RDF.type)}
    used |= {o for o in g.objects() if isinstance(o, rdflib.URIRef) and str(o).startswith(str(BRC))}
    ours = {t for t in used if any(str(t).startswith(str(ns)) for ns in (BOT, DICE, DICP, BRC))}
    assert {BOT.Element, BOT.Interface, DICP.Activity, DICP.occupiesTimeInterval, DICE.hasEntityState} <= ours
    assert sorted(ours - defined) == []


def test_turtle_and_jsonld_round_trip(graph, tmp_path):
    ttl = graph.serialize(tmp_path / "frame.ttl")
    jsonld = graph.serialize(tmp_path / "frame.jsonld")
    original = rdflib_graph(graph)
    for path, fmt in ((ttl, "turtle"), (jsonld, "json-ld")):
        again = rdflib.Graph().parse(path, format=fmt)
        assert len(again) == len(original)
        assert rdflib.compare.isomorphic(again, original)
    assert "@prefix bot: <https://w3id.org/bot#>" in ttl.read_text()
    assert json.loads(jsonld.read_text())["@context"]["dicp"] == str(DICP)
    reopened = ConstructionGraph.open(ttl)
    assert reopened.query("progress") == graph.query("progress")


def test_serialize_refuses_unknown_format(graph, tmp_path):
    with pytest.raises(InputError, match="cannot tell the RDF format"):
        graph.serialize(tmp_path / "frame.xyz")
    assert not list(tmp_path.iterdir())


QUERY_BINDINGS = {
    "activity_robot": {"activityId": "A0005"},
    "component_activities": {"globalId": None},
    "component_state": {"globalId": None},
    "connected_elements": {"globalId": None},
    "progress": {},
    "rcan_plan": {},
    "rcan_ready_activities": {},
    "ready_activities": {},
    "storey_components": {"storeyId": "storey"},
}


def test_every_shipped_query_is_covered():
    assert sorted(QUERY_BINDINGS) == query_names()


@pytest.mark.parametrize("name", sorted(QUERY_BINDINGS))
def test_oxigraph_store_answers_like_rdflib_and_persists(name, frame_model, schedule, tmp_path):
    pytest.importorskip("pyoxigraph")
    column = schedule["A0001"].global_id
    bindings = {k: (column if v is None else frame_model.storeys[0].global_id if v == "storey" else v)
                for k, v in QUERY_BINDINGS[name].items()}
    memory = build_graph(frame_model, schedule)
    oxigraph = build_graph(frame_model, schedule, store="oxigraph", path=tmp_path / "store")
    for g in (memory, oxigraph):
        g.set_activity_state("A0001", "Completed")
        g.set_component_state(column, "Arrived")
    expected = memory.query(name, **bindings)
    assert expected, f"{name} returned nothing"
    assert oxigraph.query(name, **bindings) == expected
    assert len(oxigraph) == len(memory)
    oxigraph.close()
    with ConstructionGraph.open(tmp_path / "store") as reopened:  # persisted on disk, states included
        assert reopened.query(name, **bindings) == expected
        assert reopened.component_state(column) == "Arrived"


def test_oxigraph_needs_an_empty_directory(frame_model, tmp_path):
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("x")
    with pytest.raises(InputError, match="is not empty"):
        build_graph(frame_model, store="oxigraph", path=tmp_path / "full")
    with pytest.raises(InputError, match="needs a directory"):
        build_graph(frame_model, store="oxigraph")


def test_ifc_work_schedule_graph(shared_ifc):
    from bimrobot.bim import load_model

    path = shared_ifc("construction-scheduling-task.ifc")
    model = load_model(path)
    graph = build_graph(model, load_schedule_ifc(path, model=model))
    g = rdflib_graph(graph)
    assert len(set(g.subjects(RDF.type, DICP.Activity))) == 8
    assert len(list(g.triples((None, DICE.precededBy, None)))) == 7
    assert len(list(g.triples((None, DICP.hasSubActivity, None)))) == 7  # 2 under the root, 1 slab, 4 walls
    walls = {graph.id_of(o) for o in g.objects(None, DICP.hasOutputObject)} & {e.global_id for e in model.by_class("IfcWall")}
    assert len(walls) == 4
    assert [r["activityId"] for r in graph.query("ready_activities")] == ["3vesIabXX7guLU5lIRuXh7"]  # Slab #1 first


def test_ifcunit_connections_become_interfaces(shared_ifc):
    from bimrobot.bim import load_model

    model = load_model(shared_ifc("ifcUnit.ifc"))
    graph = build_graph(model)
    assert len(set(rdflib_graph(graph).subjects(RDF.type, BOT.Interface))) == 36


def test_custom_base_is_kept_when_reopened(frame_model, schedule, tmp_path):
    graph = build_graph(frame_model, schedule, base="https://example.org/site-42")
    assert graph.base == "https://example.org/site-42/"
    assert str(graph.activity_iri("A0001")) == "https://example.org/site-42/activity/A0001"
    path = graph.serialize(tmp_path / "g.ttl")
    reopened = ConstructionGraph.open(path)
    assert reopened.base == graph.base
    reopened.set_activity_state("A0001", "Completed")  # finds the activity under the custom base
    assert reopened.activity_state("A0001") == "Completed"
    with pytest.raises(InputError, match="is not an absolute IRI"):
        build_graph(frame_model, base="not an iri")


def test_turtle_keeps_full_double_precision(frame_model, schedule, tmp_path):
    import dataclasses

    from bimrobot.schedule.schedule import Schedule

    first = dataclasses.replace(schedule.activities[0], target=(123.4567891, -0.000123456789, 98765.4321))
    graph = build_graph(frame_model, Schedule([first]))
    reopened = ConstructionGraph.open(graph.serialize(tmp_path / "precise.ttl"))
    (row,) = reopened.query("component_activities", globalId=first.global_id)
    assert (row["targetX"], row["targetY"], row["targetZ"]) == (123.4567891, -0.000123457, 98765.4321)  # 1e-9 m grid


@pytest.fixture(scope="module")
def precast_model():
    """MULTICOM-trappen_bordessen.ifc: Tekla precast stairs and landings, with IfcElementAssemblies."""
    from bimrobot.bim import load_model

    return load_model(shared_file("ifc", "MULTICOM-trappen_bordessen.ifc"))


def test_precast_assemblies_are_elements_with_their_parts_as_sub_elements(precast_model, ontology_file, tmp_path):
    from bimrobot.core.tasks import Activity
    from bimrobot.schedule.schedule import Schedule

    model = precast_model
    assert model.assemblies, "the Tekla export groups its parts into assemblies"
    graph = build_graph(model)
    g = rdflib_graph(graph)
    for gid, assembly in model.assemblies.items():
        iri = graph.element_iri(gid)
        assert (iri, RDF.type, BOT.Element) in g
        assert g.value(iri, BRC.ifcClass).toPython() == "IfcElementAssembly"
        assert {graph.id_of(p) for p in g.objects(iri, BOT.hasSubElement)} == set(assembly.part_ids)
        assert len(list(g.subjects(BOT.containsElement, iri))) == 1  # in its storey (or the building)
        weights = [model.elements[p].weight_kg for p in assembly.part_ids]
        if all(w is not None for w in weights):  # the unit weighs what its parts weigh together
            assert g.value(iri, BRC.weightKg).toPython() == pytest.approx(sum(weights))
        else:
            assert g.value(iri, BRC.weightKg) is None  # unknown, not a guess
    # every term is defined: bot:hasSubElement relates two bot:Elements in BOT itself
    bot = rdflib.Graph().parse(ontology_file("bot.ttl"), format="turtle")
    assert (BOT.hasSubElement, rdflib.RDFS.domain, BOT.Element) in bot and (BOT.hasSubElement, rdflib.RDFS.range, BOT.Element) in bot

    # a schedule may name the assembly: the unit is the activity's object, and its parts follow its state
    unit, assembly = next(iter(model.assemblies.items()))
    row = Activity("A1", "Transport unit", "transport", unit, "Crane", 0.0, 60.0)
    with_schedule = build_graph(model, Schedule([row]))
    assert with_schedule.query("component_activities", globalId=unit)[0]["activityId"] == "A1"
    with_schedule.set_component_state(unit, "InTransit")
    assert {with_schedule.component_state(p) for p in assembly.part_ids} == {"InTransit"}

    # element by element: no assembly in the graph
    by_element = rdflib_graph(build_graph(model, assemblies=False))
    assert not list(by_element.triples((None, BOT.hasSubElement, None)))
    assert len(set(by_element.subjects(RDF.type, BOT.Element))) == len(model.elements)


def test_schedule_rows_may_name_an_assembly(precast_model, tmp_path):
    unit = next(iter(precast_model.assemblies))
    path = tmp_path / "units.csv"
    path.write_text("Identification,Activity,GlobalId,Start,Finish\n"
                    f"A1,transport,{unit},0,60\nA2,transport,NOT_A_UNIT,0,60\n")
    with pytest.raises(InputError, match="line 3: GlobalId 'NOT_A_UNIT' is not an element of"):
        load_schedule_csv(path, model=precast_model)
    path.write_text("Identification,Activity,GlobalId,Start,Finish\n" f"A1,transport,{unit},0,60\n")
    assert load_schedule_csv(path, model=precast_model).global_ids() == {unit}
