"""`bimrobot graph` and `bimrobot query`: outputs, and one-sentence errors with exit 2 and no output."""

from __future__ import annotations

import json

import pytest

from bimrobot.bim.examples import steel_frame
from bimrobot.cli import main


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """rdflib (about 0.3 s of imports with the graph module), imported when these tests run, not at collection."""
    global rdflib
    import rdflib


@pytest.fixture(scope="module")
def frame_ifc(tmp_path_factory):
    return steel_frame(tmp_path_factory.mktemp("cli") / "frame.ifc")


def test_graph_with_schedule_then_query(frame_ifc, frame_schedule_csv, tmp_path, capsys):
    out = tmp_path / "frame.ttl"
    assert main(["graph", str(frame_ifc), "--schedule", str(frame_schedule_csv), "-o", str(out)]) == 0
    assert "88 elements, 2 storeys, 24 connections, 12 joints (0 inferred from geometry) with 24 nodes, 28 activities" in capsys.readouterr().out
    graph = rdflib.Graph().parse(out)
    assert len(set(graph.subjects(rdflib.RDF.type, rdflib.URIRef("https://w3id.org/digitalconstruction/0.5/Processes#Activity")))) == 28

    assert main(["query", str(out), "ready_activities", "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    # every component's transport has no predecessor: 4 columns + 4 beams ready, in planned order
    assert [r["activityType"] for r in rows] == ["transport"] * 8
    assert rows[0]["activityId"] == "A0001" and rows[0]["robot"] == "Transport 1"
    assert [r["start"] for r in rows] == sorted(r["start"] for r in rows)

    assert main(["query", str(out), "progress"]) == 0
    table = capsys.readouterr().out
    # the 4 footings are prebuilt (work of others): on site with their position fixed, not on the yard
    assert "OnYard         84" in table and "PositionFixed  4" in table and "(2 rows)" in table


def test_graph_json_ld_and_oxigraph_store(frame_ifc, tmp_path, capsys):
    pytest.importorskip("pyoxigraph")
    out, store = tmp_path / "frame.jsonld", tmp_path / "frame.oxigraph"
    assert main(["graph", str(frame_ifc), "-o", str(out), "--store", "oxigraph", "--store-path", str(store)]) == 0
    assert "@context" in json.loads(out.read_text())
    capsys.readouterr()
    # the store directory answers queries after the command ended
    assert main(["query", str(store), "progress", "--format", "csv"]) == 0
    assert capsys.readouterr().out.splitlines() == ["state,components", "OnYard,84", "PositionFixed,4"]


def test_ifc_schedule_option(shared_ifc, tmp_path, capsys):
    out = tmp_path / "tasks.ttl"
    assert main(["graph", str(shared_ifc("construction-scheduling-task.ifc")), "--ifc-schedule", "-o", str(out)]) == 0
    assert "8 activities" in capsys.readouterr().out


def test_bad_schedule_exits_2_and_writes_nothing(frame_ifc, tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("Identification,Activity,GlobalId,Start,Finish\nA1,transport,NOT_AN_ELEMENT,0,10\n")
    out = tmp_path / "out" / "frame.ttl"
    assert main(["graph", str(frame_ifc), "--schedule", str(bad), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("bimrobot graph: error:") and "line 2: GlobalId 'NOT_AN_ELEMENT'" in err
    assert len(err.splitlines()) == 1
    assert not out.exists() and not (out.parent.exists() and any(out.parent.iterdir()))


def test_bad_query_inputs_exit_2(frame_ifc, tmp_path, capsys):
    out = tmp_path / "frame.ttl"
    assert main(["graph", str(frame_ifc), "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["query", str(out), "no_such_query"]) == 2
    assert "unknown query 'no_such_query'" in capsys.readouterr().err
    assert main(["query", str(tmp_path / "absent.ttl"), "progress"]) == 2
    assert "does not exist" in capsys.readouterr().err
    (tmp_path / "folder").mkdir()
    assert main(["query", str(tmp_path / "folder"), "progress"]) == 2
    assert "is a directory but not an Oxigraph store" in capsys.readouterr().err
    assert not any((tmp_path / "folder").iterdir())
    assert main(["query", str(out), "component_state", "--bind", "globalId"]) == 2
    assert "is not VAR=VALUE" in capsys.readouterr().err
    broken = tmp_path / "broken.rq"
    broken.write_text("SELECT ?x WHERE { ?x ")
    assert main(["query", str(out), str(broken)]) == 2
    assert "is invalid" in capsys.readouterr().err
    assert main(["graph", str(frame_ifc), "-o", str(tmp_path / "frame.xyz")]) == 2
    assert "cannot tell the RDF format" in capsys.readouterr().err


def test_include_and_exclude_choose_the_elements(frame_ifc, tmp_path, capsys):
    out = tmp_path / "columns.ttl"
    assert main(["graph", str(frame_ifc), "-o", str(out), "--include", "IfcColumn"]) == 0
    assert " triples, 4 elements, " in capsys.readouterr().out
    graph = rdflib.Graph().parse(out)
    classes = {str(o) for o in graph.objects(None, rdflib.URIRef("https://bimrobot.example/ns#ifcClass"))}
    assert classes == {"IfcColumn"}
    assert main(["graph", str(frame_ifc), "-o", str(out), "--exclude", "IfcFastener, IfcMechanicalFastener"]) == 0
    capsys.readouterr()
    assert main(["graph", str(frame_ifc), "-o", str(out), "--include", "IfcColumn, IfcNoSuchThing"]) == 2
    err = capsys.readouterr().err
    assert "names 'IfcNoSuchThing', which is not an IFC4 class" in err and err.count("\n") == 1


def test_unwritable_folder_is_one_sentence(frame_ifc, tmp_path, capsys):
    import os

    if os.geteuid() == 0:
        pytest.skip("root may write into any folder: an unwritable folder cannot be made")
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        assert main(["graph", str(frame_ifc), "-o", str(locked / "g.ttl")]) == 2
        err = capsys.readouterr().err
        assert "is not writable" in err and err.count("\n") == 1
        assert not any(locked.iterdir())
    finally:
        locked.chmod(0o755)
