"""`bimrobot graph` on every shared real model (../shared/data/ifc): each gives a graph whose every
element is a bot:Element, with its precast assemblies as elements holding their parts; never a
traceback. Skipped when ../shared is absent."""

from __future__ import annotations


import pytest

from bimrobot.cli import main
from shared_data import SHARED_IFC, shared_models


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """rdflib (about 0.3 s of imports with the graph module), imported when these tests run, not at collection."""
    global rdflib, BOT
    import rdflib

    from bimrobot.lbd.terms import BOT


MODELS = [path.name for path in shared_models()]


@pytest.mark.skipif(not MODELS, reason=f"{SHARED_IFC} is absent: the shared real models live beside the repository")
@pytest.mark.parametrize("name", MODELS)
def test_graph_of_every_shared_model(name, tmp_path, capsys):
    import re

    out = tmp_path / "graph.ttl"
    assert main(["graph", str(SHARED_IFC / name), "-o", str(out)]) == 0, capsys.readouterr().err
    summary = capsys.readouterr().out
    match = re.search(r": (\d+) triples, (\d+) elements(?: \((\d+) assemblies\))?", summary)
    triples, elements, assemblies = int(match[1]), int(match[2]), int(match[3] or 0)
    graph = rdflib.Graph().parse(out)
    assert len(graph) == triples
    ifc_class = rdflib.URIRef("https://bimrobot.example/ns#ifcClass")
    units = {s for s, _, o in graph.triples((None, ifc_class, None)) if str(o) == "IfcElementAssembly"}
    assert len(units) == assemblies
    assert len(set(graph.subjects(rdflib.RDF.type, BOT.Element))) == elements + assemblies
    for unit in units:  # each unit holds parts, and each part is an element of its own
        parts = set(graph.objects(unit, BOT.hasSubElement))
        assert parts and all((p, rdflib.RDF.type, BOT.Element) in graph for p in parts)
