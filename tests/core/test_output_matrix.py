"""Every option that writes a file or a folder, against every path that would destroy data.

One table: (command, option) x (the current directory, an input file, the folder that holds the input, a
non-empty folder bimrobot did not write, a symbolic link to one, a path under a regular file, a path on a
read-only file system). Each must exit 2 with one sentence, print no traceback, and leave every file
byte for byte as it was. The per-part test files cover the successful and replacing cases.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from bimrobot.cli import main
from output_checks import snapshot

CASES = ("dot", "input", "parent_of_input", "foreign_folder", "symlink_to_foreign", "under_a_file", "read_only_fs")

#: (name, argv with {out}, cases that apply). {model}, {schedule}, {scenario} are the inputs.
OPTIONS = [
    # example reads nothing; the 'input' model here is an earlier example output, which it may replace.
    ("example -o", ["example", "steel-frame", "-o", "{out}"], tuple(c for c in CASES if c != "input")),
    ("split -o", ["split", "{model}", "-o", "{out}"], CASES),
    ("convert -o", ["convert", "{model}", "-o", "{out}", "--no-progress"], CASES),
    ("simulate -o", ["simulate", "{model}", "-o", "{out}", "--no-progress"], CASES),
    ("allocators -o", ["allocators", "{model}", "-o", "{out}", "--no-optimal", "--seeds", "1"], CASES),
    ("graph -o", ["graph", "{model}", "-o", "{out}"], CASES),
    ("plan export -o", ["plan", "export", "{model}", "-o", "{out}"], CASES),
    ("graph --store-path", ["graph", "{model}", "--store", "oxigraph", "--store-path", "{out}", "-o", "fresh.ttl"], CASES),
    ("rcan run --report", ["rcan", "run", "--schedule", "{schedule}", "--model", "{model}", "--reallocate", "-q", "--report", "{out}"], CASES),
    ("rcan run --graph-out", ["rcan", "run", "--schedule", "{schedule}", "--model", "{model}", "--reallocate", "-q", "--graph-out", "{out}"], CASES),
    ("rcan run --state-db", ["rcan", "run", "--schedule", "{schedule}", "--model", "{model}", "--reallocate", "-q", "--state-db", "{out}"], CASES),
    ("assembly optimum --json", ["assembly", "optimum", "--setting", "E1S1", "--episodes", "1", "--json", "{out}"], CASES),
    ("assembly play --gif", ["assembly", "play", "--scenario", "{scenario}", "--policy", "planner", "--gif", "{out}"], CASES),
    ("rl benchmark -o", ["rl", "benchmark", "--settings", "E1S1", "--algos", "ppo", "--seeds", "0", "--timesteps", "64",
                         "--workers", "1", "-o", "{out}"], CASES),
    ("rl compare -o", ["rl", "compare", "{grid}", "-o", "{out}"], CASES),
    # rl train -o names the PARENT of a new run folder: '.', the input's folder and a foreign folder are
    # legitimate parents (the new run folder is added beside what is there), so only these apply.
    ("rl train -o", ["rl", "train", "--setting", "E1S1", "--algo", "ppo", "--timesteps", "64", "-o", "{out}"],
     ("input", "under_a_file", "read_only_fs")),
]

SCENARIO = """name: tiny
grid: [6, 6, 3]
"""


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict:
    """A real model, the schedule simulate writes for it, a scenario and a benchmark grid (module-wide)."""
    root = tmp_path_factory.mktemp("inputs")
    model = root / "model.ifc"
    assert main(["example", "steel-frame", "-o", str(model)]) == 0
    assert main(["simulate", str(model), "-o", str(root / "sim"), "--no-progress", "--no-gantt"]) == 0
    scenario = root / "scenario.yaml"
    setting = Path(__file__).resolve().parents[2] / "src" / "bimrobot" / "assembly" / "settings"
    scenario.write_text(next(setting.glob("E1S1*.yaml")).read_text())
    grid = Path(__file__).resolve().parents[2] / "docs" / "results" / "double-dqn"
    return {"model": model, "schedule": root / "sim" / "schedule.csv", "scenario": scenario, "grid": grid}


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("name, argv, applies", OPTIONS, ids=[o[0] for o in OPTIONS])
def test_a_destructive_path_is_refused_and_nothing_changes(name, argv, applies, case, inputs, tmp_path, monkeypatch, capsys):
    if case not in applies:
        pytest.skip(f"{name}: '{case}' is a legitimate target for this option")
    project = tmp_path / "project"
    work, model_dir, foreign = project / "work", project / "model", project / "foreign"
    for folder in (work, model_dir, foreign):
        folder.mkdir(parents=True)
    copied = {key: model_dir / inputs[key].name for key in ("model", "schedule", "scenario")}
    for key, path in copied.items():
        shutil.copy(inputs[key], path)
    copied["grid"] = model_dir / "grid"
    shutil.copytree(inputs["grid"], copied["grid"])
    (foreign / "thesis.docx").write_bytes(b"\x00\x01 my only copy")
    (project / "link").symlink_to(foreign)
    (project / "notes.txt").write_text("mine")
    primary = {"rl compare -o": copied["grid"] / "table.md", "assembly play --gif": copied["scenario"]}.get(name, copied["model"])
    target = {
        "dot": ".", "input": str(primary), "parent_of_input": str(primary.parent), "foreign_folder": str(foreign),
        "symlink_to_foreign": str(project / "link"), "under_a_file": str(project / "notes.txt" / "out"),
        "read_only_fs": "/proc/bimrobot-test-out",
    }[case]
    values = {"out": target, **{key: str(path) for key, path in copied.items()}}
    monkeypatch.chdir(work)
    before = snapshot(project)
    code = main([arg.format(**values) for arg in argv])
    err = capsys.readouterr().err
    assert code == 2, f"{name} {case}: exit {code}\n{err}"
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1 and "Traceback" not in err, err
    assert snapshot(project) == before, f"{name} {case} changed files"


#: Options that write a folder: argv with {out}, run twice into one folder.
FOLDER_OPTIONS = [o for o in OPTIONS if o[0] in ("split -o", "convert -o", "simulate -o", "allocators -o", "graph --store-path")]


@pytest.mark.parametrize("change", ["added", "changed"])
@pytest.mark.parametrize("name, argv, applies", FOLDER_OPTIONS, ids=[o[0] for o in FOLDER_OPTIONS])
def test_a_file_the_user_added_to_or_changed_in_an_output_folder_is_never_deleted(name, argv, applies, change, inputs,
                                                                                  tmp_path, monkeypatch, capsys):
    """Issue 35: ``simulate -o out; echo mine > out/notes.txt; simulate -o out`` deleted notes.txt. The
    second run is refused with one sentence naming the file; the folder stays byte for byte."""
    if "--store-path" in argv:
        pytest.importorskip("pyoxigraph")
        if change == "changed":
            pytest.skip("a store's files are RocksDB's own, which a query rewrites (bimrobot.core.io.MANAGED_FILES)")
    monkeypatch.chdir(tmp_path)
    values = {"out": "out", "model": str(inputs["model"]), "schedule": str(inputs["schedule"])}
    command = [arg.format(**values) for arg in argv]
    assert main(command) == 0
    written = sorted(p.name for p in Path("out").iterdir())
    if change == "added":
        Path("out/notes.txt").write_text("mine")
        named = "'notes.txt' (added)"
    else:
        victim = next(p for p in sorted(Path("out").rglob("*")) if p.is_file() and not p.name.startswith("."))
        victim.write_bytes(victim.read_bytes() + b"\n# my edit")
        named = f"'{victim.relative_to('out').as_posix()}' (changed)"
    capsys.readouterr()
    before = snapshot(tmp_path)
    assert main(command) == 2
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1 and "Traceback" not in err and "replacing" not in err, err
    assert named in errors[0] and "delete it yourself" in errors[0], errors[0]
    assert snapshot(tmp_path) == before, f"{name}: files changed"
    assert written  # the first run wrote something to protect


def test_an_output_folder_of_one_kind_is_not_replaced_by_another(inputs, tmp_path, monkeypatch, capsys):
    """Issue 35: a simulation folder was replaced by a split. Refused, naming both kinds."""
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", str(inputs["model"]), "-o", "out", "--no-progress", "--no-gantt"]) == 0
    capsys.readouterr()
    before = snapshot(tmp_path)
    assert main(["split", str(inputs["model"]), "-o", "out"]) == 2
    err = capsys.readouterr().err
    assert "holds a simulate output of model.ifc" in err and "not a split output" in err and "Traceback" not in err
    assert snapshot(tmp_path) == before
    assert main(["simulate", str(inputs["model"]), "-o", "out", "--no-progress", "--no-gantt"]) == 0  # same kind: replaced
    assert "bimrobot: replacing out (simulate output of model.ifc" in capsys.readouterr().err
