"""`bimrobot graph`'s writing options under the output policy: `-o` (a graph file) and `--store-path`
(an Oxigraph store folder). Every refused path leaves every file on disk byte for byte as it was and
gives one sentence with exit 2; bimrobot's own outputs are replaced, and the command says so."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bimrobot.bim.examples import steel_frame
from bimrobot.cli import main
from output_checks import snapshot


@pytest.fixture(scope="module")
def frame_ifc(tmp_path_factory):
    return steel_frame(tmp_path_factory.mktemp("model") / "frame.ifc")


@pytest.fixture
def site(tmp_path, frame_ifc, monkeypatch):
    """A user's disk: project/ with the model, a foreign folder of the user's files, a symbolic link to
    it, a regular file, and an empty work folder that is the current directory."""
    project = tmp_path / "project"
    project.mkdir()
    model = project / "frame.ifc"
    model.write_bytes(frame_ifc.read_bytes())
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("my notes\n")
    (mine / "sub").mkdir()
    (mine / "sub" / "photo.jpg").write_bytes(b"\xff\xd8\xff\xe0 not really a jpeg")
    (tmp_path / "link").symlink_to(mine, target_is_directory=True)
    (tmp_path / "somefile.txt").write_text("a file\n")
    (tmp_path / "graph.ttl").write_text("@prefix ex: <http://example.org/> .\nex:a ex:b ex:c .\n")  # the user's own graph
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    return {"root": tmp_path, "model": model}


def cases(site: dict) -> dict[str, tuple[str, str]]:
    """Case name -> (path to give, words the one-sentence refusal must contain)."""
    root, model = site["root"], site["model"]
    return {
        "the current directory": (".", "is the current directory"),
        "the input file": (str(model), "is an input of this command"),
        "a parent of the input": (str(model.parent), "is a folder"),
        "a non-empty foreign folder": (str(root / "mine"), "is a folder"),
        "a symlink to a foreign folder": (str(root / "link"), "is a folder"),
        "a path under a regular file": (str(root / "somefile.txt" / "out.ttl"), "is a file, not a folder, so nothing can be written under it"),
        "a foreign file": (str(root / "graph.ttl"), "is an existing file that bimrobot did not write"),
    }


def refused(args: list[str], root: Path, words: str, capsys) -> None:
    before = snapshot(root)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("bimrobot graph: error: ") and words in err and err.count("\n") == 1, err
    assert snapshot(root) == before  # every file byte for byte, nothing added


CASE_NAMES = [
    "the current directory", "the input file", "a parent of the input", "a non-empty foreign folder",
    "a symlink to a foreign folder", "a path under a regular file", "a foreign file",
]


@pytest.mark.parametrize("case", CASE_NAMES)
def test_graph_output_file_is_refused(site, case, capsys):
    target, words = cases(site)[case]
    refused(["graph", str(site["model"]), "-o", target], site["root"], words, capsys)


@pytest.mark.parametrize("case", CASE_NAMES)
def test_oxigraph_store_path_is_refused(site, case, capsys):
    pytest.importorskip("pyoxigraph")
    target, words = cases(site)[case]
    words = {
        "a parent of the input": "contains an input of this command",
        "a non-empty foreign folder": "is a folder that bimrobot did not write and it is not empty",
        "a symlink to a foreign folder": "is a folder that bimrobot did not write and it is not empty",
        "a foreign file": "is an existing file, not a folder",
    }.get(case, words)
    args = ["graph", str(site["model"]), "-o", str(site["root"] / "work" / "g.ttl"), "--store", "oxigraph", "--store-path", target]
    refused(args, site["root"], words, capsys)


def test_a_schedule_given_as_output_is_refused(site, frame_schedule_csv, capsys):
    schedule = site["root"] / "project" / "schedule.csv"
    schedule.write_bytes(frame_schedule_csv.read_bytes())
    refused(["graph", str(site["model"]), "--schedule", str(schedule), "-o", str(schedule)], site["root"],
            "is an input of this command", capsys)


def test_own_outputs_are_replaced_and_signed(site, capsys):
    pytest.importorskip("pyoxigraph")
    out, store = Path("g.ttl"), Path("store")
    args = ["graph", str(site["model"]), "-o", str(out), "--store", "oxigraph", "--store-path", str(store)]
    assert main(args) == 0
    assert out.read_text().startswith("# written by bimrobot ")  # a Turtle comment: no triple
    assert (store / ".bimrobot-output.json").is_file() and (store / "CURRENT").is_file()
    capsys.readouterr()
    assert main(args) == 0  # both are bimrobot's: replaced, each in one line
    err = capsys.readouterr().err
    assert "bimrobot: replacing g.ttl (a file bimrobot wrote)" in err
    assert "bimrobot: replacing store (graph (Oxigraph store) output of frame.ifc" in err
    assert main(["query", str(store), "progress", "--format", "csv"]) == 0
    assert capsys.readouterr().out.splitlines() == ["state,components", "OnYard,84", "PositionFixed,4"]
    assert not [p for p in Path(".").iterdir() if p.name.startswith(".")]  # no temporary sibling left


def test_json_ld_carries_the_signature_as_an_ignored_key(site):
    import rdflib
    import rdflib.compare

    assert main(["graph", str(site["model"]), "-o", "g.jsonld"]) == 0
    assert main(["graph", str(site["model"]), "-o", "g.ttl"]) == 0
    document = json.loads(Path("g.jsonld").read_text())
    assert document["generator"].startswith("written by bimrobot ")
    assert document["@context"]["generator"] is None  # JSON-LD: a term mapped to null is not data
    jsonld = rdflib.Dataset().parse("g.jsonld", format="json-ld")
    assert [g.identifier for g in jsonld.graphs() if len(g)] == [rdflib.graph.DATASET_DEFAULT_GRAPH_ID]  # no named graph
    assert rdflib.compare.isomorphic(rdflib.Graph().parse("g.jsonld"), rdflib.Graph().parse("g.ttl"))


def test_other_output_mistakes_are_one_sentence(site, capsys):
    model = str(site["model"])
    for args, words in [
        (["-o", "g.ttl", "--store-path", "store"], "--store-path is only used with --store oxigraph"),
        (["-o", "store/g.ttl", "--store", "oxigraph", "--store-path", "store"], "is inside the --store-path folder"),
        (["-o", "g.ttl", "--store", "oxigraph"], "--store oxigraph needs --store-path"),
        (["-o", "g.ttl", "--base", "not an iri"], "is not an absolute IRI"),
    ]:
        refused(["graph", model, *args], site["root"], words, capsys)


def test_a_failed_build_leaves_nothing(site, capsys):
    """A schedule error is found after the model is read: still no graph file, no store folder, no
    temporary sibling, no parent folder created for them."""
    pytest.importorskip("pyoxigraph")
    bad = site["root"] / "project" / "bad.csv"
    bad.write_text("Identification,Activity,GlobalId,Start,Finish\nA1,transport,NOT_AN_ELEMENT,0,10\n")
    args = ["graph", str(site["model"]), "--schedule", str(bad), "-o", "new/dir/g.ttl",
            "--store", "oxigraph", "--store-path", "other/store"]
    refused(args, site["root"], "line 2: GlobalId 'NOT_AN_ELEMENT'", capsys)
    assert not list(Path(".").iterdir())
