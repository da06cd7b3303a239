"""The output policy of ``assembly play --gif``, ``assembly optimum --json`` and ``--write``: a bad path is
refused in one sentence before the episode or the planning starts, and nothing of the user's is touched."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bimrobot.assembly.scenario import SETTINGS_DIR
from bimrobot.cli import main
from bimrobot.core.io import has_signature
from output_checks import snapshot


@pytest.fixture
def workspace(tmp_path, monkeypatch):
    """A project folder as the current directory: a scenario, a folder and a file of the user's, a link
    to that folder, and every file's bytes to compare afterwards."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "site.yaml").write_text((SETTINGS_DIR / "E1S2.yaml").read_text())
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("my notes\n")
    (tmp_path / "photo.gif").write_bytes(b"GIF89a not bimrobot's")
    (tmp_path / "link").symlink_to(tmp_path / "mine", target_is_directory=True)
    return tmp_path


PLAY = ["assembly", "play", "--scenario", "site.yaml", "--policy", "planner", "--gif"]
OPTIMUM = ["assembly", "optimum", "--setting", "E1S2", "--episodes", "2", "--json"]

CASES = [
    (".", "is the current directory"),
    ("site.yaml", "is an input of this command"),
    ("mine", "is a folder; give a file name"),
    ("link", "is a folder; give a file name"),
    ("photo.gif", "is an existing file that bimrobot did not write"),
    ("site.yaml/out.gif", "is a file, not a folder, so nothing can be written under it"),
    ("mine/notes.txt", "is an existing file that bimrobot did not write"),
]


@pytest.mark.parametrize("command", [PLAY, OPTIMUM], ids=["play --gif", "optimum --json"])
@pytest.mark.parametrize("target,message", CASES)
def test_bad_output_paths_are_refused_before_the_work_and_touch_nothing(workspace, capsys, command, target, message):
    if command is OPTIMUM and target == "site.yaml":
        target = str(SETTINGS_DIR / "E1S2.yaml")  # optimum reads the shipped setting, not the user's copy
    before = snapshot(workspace)
    assert main(command + [target]) == 2
    captured = capsys.readouterr()
    assert message in captured.err and captured.err.count("\n") == 1
    assert f"{command[-1]} {target}" in captured.err  # names the option and the path as given
    assert captured.out == ""  # refused before the episode / the table was computed
    assert snapshot(workspace) == before  # byte for byte, nothing added
    assert (SETTINGS_DIR / "E1S2.yaml").read_text().startswith("# Benchmark setting E1S2")


def test_play_gif_is_signed_and_replaced_with_a_message(workspace, capsys):
    assert main(PLAY + ["out.gif"]) == 0
    assert has_signature(workspace / "out.gif")  # a GIF comment: "written by bimrobot ..."
    first = (workspace / "out.gif").read_bytes()
    assert main(PLAY + ["out.gif", "--fps", "3"]) == 0
    err = capsys.readouterr().err
    assert "bimrobot: replacing out.gif (a file bimrobot wrote); the new one is from site.yaml" in err
    assert (workspace / "out.gif").read_bytes() != first
    assert sorted(p.name for p in workspace.iterdir()) == ["link", "mine", "out.gif", "photo.gif", "site.yaml"]


def test_optimum_json_is_signed_and_replaced_with_a_message(workspace, capsys):
    assert main(OPTIMUM + ["table.json"]) == 0
    table = json.loads((workspace / "table.json").read_text())
    assert table["generator"].startswith("written by bimrobot") and "E1S2" in table["settings"]
    assert main(OPTIMUM + ["table.json"]) == 0
    assert "bimrobot: replacing table.json (a file bimrobot wrote)" in capsys.readouterr().err


def test_write_checks_the_reference_file_before_an_hour_of_planning(workspace, capsys, monkeypatch):
    """--write replaces the shipped table only when it is bimrobot's; the check comes before the planning."""
    import bimrobot.assembly.planner as planner

    foreign = workspace / "reference.json"
    foreign.write_text('{"settings": {}}\n')
    monkeypatch.setattr(planner, "REFERENCE_FILE", foreign)

    def planning_started(*args, **kwargs):
        raise AssertionError("the planning started before the output path was checked")

    monkeypatch.setattr(planner, "compute_reference_returns", planning_started)
    assert main(["assembly", "optimum", "--setting", "all", "--write"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"bimrobot assembly: error: --write {foreign} is an existing file that bimrobot did not write")
    assert foreign.read_text() == '{"settings": {}}\n'
    assert has_signature(Path(planner.__file__).with_name("settings") / "reference_returns.json")


@pytest.mark.parametrize(
    "argv,message",
    [
        (["assembly", "play", "--fps", "nan"], "--fps must be a number of frames per second above 0 and at most 100, got nan"),
        (["assembly", "play", "--fps", "inf"], "--fps must be a number of frames per second above 0"),
        (["assembly", "play", "--fps", "0"], "--fps must be a number of frames per second above 0"),
        (["assembly", "play", "--seed", "-1"], "--seed must be from 0 to 2147483647, got -1"),
        (["assembly", "optimum", "--episodes", "1000000000"], "--episodes must be from 2 to 100000"),
    ],
)
def test_impossible_option_values_exit_2_with_one_sentence(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
