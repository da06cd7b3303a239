"""The construction graph on a remote SPARQL 1.1 endpoint: a real `oxigraph serve` on 127.0.0.1,
started and stopped by the test (skipped when the `oxigraph` server binary is not installed)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from bimrobot.cli import main
from bimrobot.core.errors import InputError
from bimrobot.schedule.csv import load_schedule_csv


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """rdflib (about 0.3 s of imports with the graph module), imported when these tests run, not at collection."""
    global ConstructionGraph, build_graph
    from bimrobot.lbd.graph import ConstructionGraph, build_graph


def oxigraph_binary() -> str:
    found = shutil.which("oxigraph") or str(Path(sys.executable).with_name("oxigraph"))
    if not Path(found).exists():
        pytest.skip("the `oxigraph` SPARQL server is not installed (pip install oxigraph)")
    return found


@pytest.fixture
def endpoint(tmp_path, free_port):
    port = free_port()
    server = subprocess.Popen(
        [oxigraph_binary(), "serve", "--location", str(tmp_path / "db"), "--bind", f"127.0.0.1:{port}"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 30
        while True:
            try:
                urllib.request.urlopen(f"{url}/query?query=ASK%7B%7D", timeout=1)
                break
            except OSError:
                if time.monotonic() > deadline or server.poll() is not None:
                    pytest.fail("oxigraph serve did not start")
                time.sleep(0.2)
        yield url
    finally:
        server.terminate()
        server.wait(timeout=10)


def test_graph_on_a_sparql_endpoint_answers_like_memory(endpoint, frame_model, frame_schedule_csv):
    schedule = load_schedule_csv(frame_schedule_csv, model=frame_model)
    memory = build_graph(frame_model, schedule)
    remote = build_graph(frame_model, schedule, store="sparql", path=endpoint)
    assert len(remote) == len(memory)
    column = schedule["A0001"].global_id
    for graph in (memory, remote):
        graph.set_activity_state("A0001", "Completed")
        graph.set_component_state(column, "InTransit")
    for name, bindings in (("ready_activities", {}), ("component_activities", {"globalId": column}), ("progress", {})):
        assert remote.query(name, **bindings) == memory.query(name, **bindings)
    # another client (another machine) sees the live state
    other = ConstructionGraph.open(endpoint)
    assert other.component_state(column) == "InTransit"
    assert other.activity_state("A0001") == "Completed"


def test_cli_builds_on_and_queries_an_endpoint(endpoint, frame_model, frame_schedule_csv, tmp_path, capsys):
    out = tmp_path / "frame.ttl"
    args = ["graph", str(frame_model.source), "--schedule", str(frame_schedule_csv), "-o", str(out)]
    assert main([*args, "--store", "sparql", "--store-path", endpoint]) == 0
    capsys.readouterr()
    assert main(["query", endpoint, "progress", "--format", "csv"]) == 0
    assert capsys.readouterr().out.splitlines() == ["state,components", "OnYard,84", "PositionFixed,4"]


def test_unreachable_endpoint_is_one_sentence(free_port):
    with pytest.raises(InputError, match=r"the SPARQL endpoint http://127.0.0.1:\d+ did not answer"):
        ConstructionGraph.open(f"http://127.0.0.1:{free_port()}").query("progress")
