"""simulate / allocators refuse what would destroy a user's files or make no physical sense, before working."""

import json
import os
from pathlib import Path

import pytest

from bimrobot.cli import main
from bimrobot.coordination.schedule import load_schedule_csv
from output_checks import snapshot
from shared_data import REPO_ROOT


@pytest.fixture
def project(tmp_path, steel_frame_ifc) -> Path:
    """A user's project folder: the model, notes, a fleet file and a folder of their own results."""
    folder = tmp_path / "project"
    (folder / "results").mkdir(parents=True)
    (folder / "frame.ifc").write_bytes(steel_frame_ifc.read_bytes())
    (folder / "notes.txt").write_text("site visit on Monday\n")
    (folder / "results" / "budget.xlsx").write_bytes(b"PK\x03\x04 not really a spreadsheet")
    (folder / "fleet.yaml").write_text((REPO_ROOT / "src/bimrobot/site/fleets/fleet2.yaml").read_text())
    return folder


@pytest.mark.parametrize("command", ["simulate", "allocators"])
@pytest.mark.parametrize("target", [".", "results", "frame.ifc", "..", "link-to-results", "fleet.yaml", "notes.txt/sim"])
def test_refused_output_paths_leave_every_file_byte_for_byte(project, monkeypatch, capsys, command, target):
    monkeypatch.chdir(project)
    os.symlink(project / "results", project / "link-to-results")
    before = snapshot(project.parent)
    extra = ["--no-optimal", "--seeds", "1"] if command == "allocators" else ["--no-gantt", "--no-progress"]
    output = "../" + project.name if target == ".." else target  # ..: the folder that holds the model
    assert main([command, "frame.ifc", "--fleet", "fleet.yaml", "-o", output, *extra]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"bimrobot {command}: error: -o ")
    assert snapshot(project.parent) == before
    assert not [p for p in project.parent.rglob("*.tmp")]


def test_the_output_path_is_checked_before_the_model_is_read(project, monkeypatch, capsys):
    import bimrobot.bim

    def never(*args, **kwargs):
        raise AssertionError("the model was read before the output path was checked")

    monkeypatch.setattr(bimrobot.bim, "load_model", never)
    monkeypatch.chdir(project)
    assert main(["simulate", "frame.ifc", "-o", "results"]) == 2
    assert "is a folder that bimrobot did not write and it is not empty" in capsys.readouterr().err


def test_a_folder_bimrobot_wrote_is_replaced_and_the_schedule_still_loads(project, monkeypatch, capsys):
    monkeypatch.chdir(project)
    assert main(["simulate", "frame.ifc", "--fleet", "fleet2", "-o", "sim", "--no-gantt", "--no-progress"]) == 0
    marker = json.loads((project / "sim" / ".bimrobot-output.json").read_text())
    assert marker["kind"] == "simulate" and marker["inputs"] == [str(project / "frame.ifc")]
    capsys.readouterr()
    assert main(["simulate", "frame.ifc", "--fleet", "fleet1", "-o", "sim", "--no-gantt", "--no-progress"]) == 0
    assert "bimrobot: replacing sim (simulate output of frame.ifc" in capsys.readouterr().err
    summary = json.loads((project / "sim" / "summary.json").read_text())
    assert summary["fleet"] == "fleet1" and summary["generator"].startswith("written by bimrobot")
    rows = load_schedule_csv(project / "sim" / "schedule.csv")
    assert rows and {r["Activity"] for r in rows} == {"transport", "position", "assemble"}
    lbd_schedule = pytest.importorskip("bimrobot.schedule.csv")
    from bimrobot.bim import load_model

    assert len(lbd_schedule.load_schedule_csv(project / "sim" / "schedule.csv", load_model(project / "frame.ifc")).activities) == len(rows)
    assert main(["allocators", "generated:2x1x1", "--fleet", "fleet1", "--no-optimal", "--seeds", "1", "-o", "cmp"]) == 0
    assert {p.name for p in (project / "cmp").iterdir()} == {"allocators.csv", "allocators.md", "allocators.json", "allocators.png", ".bimrobot-output.json"}
    assert json.loads((project / "cmp" / ".bimrobot-output.json").read_text())["kind"] == "allocators"


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--tolerance", "0"], "argument --tolerance: expected a number > 0 and <= 0.5 m, got '0'"),
        (["--tolerance", "-0.01"], "argument --tolerance: expected a number > 0 and <= 0.5 m, got '-0.01'"),
        (["--tolerance", "nan"], "argument --tolerance: expected a number > 0 and <= 0.5 m, got 'nan'"),
        (["--seed", "-1"], "argument --seed: expected a whole number >= 0"),
        (["--breakdown", "AssemblyRobot31@-5"], "the breakdown time must be >= 0 and <= 1e+09 s, got '-5'"),
        (["--breakdown", "AssemblyRobot31@nan"], "the breakdown time must be >= 0 and <= 1e+09 s, got 'nan'"),
        (["--breakdown", "AssemblyRobot31@inf"], "the breakdown time must be >= 0 and <= 1e+09 s, got 'inf'"),
        (["--breakdown", "AssemblyRobot31@60+0"], "the repair time must be > 0 and <= 1e+09 s, got '0'"),
        (["--breakdown", "AssemblyRobot31@60+-5"], "the repair time must be > 0 and <= 1e+09 s, got '-5'"),
        (["--unknown-weight", "-2400"], "argument --unknown-weight: expected 'auto', 'refuse' or a density in kg/m3"),
    ],
)
def test_impossible_simulate_options_are_refused(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", "generated:2x1x1", "-o", str(tmp_path / "sim"), *argv])
    assert exit_.value.code == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--seeds", "0"], "argument --seeds: expected a whole number >= 1 and <= 1000, got '0'"),
        (["--seeds", "-3"], "argument --seeds: expected a whole number >= 1"),
        (["--max-tasks", "0"], "argument --max-tasks: expected a whole number >= 1"),
        (["--time-limit", "-1"], "argument --time-limit: expected a number > 0 and <= 86400 s, got '-1'"),
        (["--time-limit", "0"], "argument --time-limit: expected a number > 0"),
        (["--tolerance", "-1"], "argument --tolerance: expected a number > 0"),
    ],
)
def test_impossible_allocators_options_are_refused(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_:
        main(["allocators", "generated:2x1x1", "-o", str(tmp_path / "cmp"), *argv])
    assert exit_.value.code == 2
    assert message in capsys.readouterr().err


def test_a_breakdown_of_an_unknown_robot_is_refused_before_the_model_is_read(tmp_path, capsys):
    assert main(["simulate", str(tmp_path / "missing.ifc"), "--breakdown", "Robot9@10", "-o", str(tmp_path / "sim")]) == 2
    assert "--breakdown names robot 'Robot9', which is not in fleet fleet2" in capsys.readouterr().err


def test_include_and_exclude_choose_what_is_built(steel_frame_ifc, tmp_path, capsys):
    out = tmp_path / "sim"
    assert main(["simulate", str(steel_frame_ifc), "--exclude", "IfcBeam", "-o", str(out), "--no-gantt", "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())["smart_components"]
    assert summary["components"] == 8  # 4 footings + 4 columns; no beam
    rows = load_schedule_csv(out / "schedule.csv")
    assert {r["GlobalId"] for r in rows if r["Activity"] == "transport"} and len({r["GlobalId"] for r in rows if r["Activity"] == "transport"}) == 4
    capsys.readouterr()
    assert main(["simulate", str(steel_frame_ifc), "--include", "IfcColum", "-o", str(tmp_path / "bad")]) == 2
    assert "--include names 'IfcColum', which is not an" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()


def test_unknown_weights_follow_the_one_rule(shared_ifc, tmp_path, capsys):
    model = shared_ifc("ifcColumn.ifc")  # a column and a slab without any weight in the file
    out = tmp_path / "sim"
    assert main(["simulate", str(model), "--fleet", "site-crane", "-o", str(out), "--no-gantt", "--no-progress"]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    report = summary["unknown_weight"]
    assert report["rule"].startswith("assume volume x 2400 kg/m3, or by class and material") and report["count"] >= 1
    assert report["by_material"] == {"concrete 2400 kg/m3": 1, "steel 7850 kg/m3": 1}  # the slab; the anchor bolt
    assert "(--unknown-weight)" in printed
    assert all(kg is None or kg > 0 for kg in report["elements"].values())
    assert main(["simulate", str(model), "--fleet", "site-crane", "--unknown-weight", "refuse", "-o", str(tmp_path / "no")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "have no weight in the model" in err and "--unknown-weight is refuse" in err
    assert not (tmp_path / "no").exists()
