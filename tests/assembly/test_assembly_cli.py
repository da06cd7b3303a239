"""``bimrobot assembly optimum | play | validate``: outputs users read, exit status 2 on bad input."""

from __future__ import annotations

import subprocess
import sys

import imageio.v2 as imageio
import pytest
import yaml

from bimrobot.assembly.scenario import SETTINGS_DIR
from bimrobot.cli import main


def test_optimum_table_for_one_setting(capsys):
    assert main(["assembly", "optimum", "--setting", "E2S2", "--episodes", "10"]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("E2S2"))
    optimal, _, random, _ = (float(v) for v in row.split()[1:])
    assert optimal == -1.83 and -185.0 <= random < -150.0


def test_optimum_rejects_unknown_setting(capsys):
    assert main(["assembly", "optimum", "--setting", "E9S9"]) == 2
    err = capsys.readouterr().err
    assert "unknown setting 'E9S9'" in err and err.count("\n") == 1


def test_play_planner_writes_a_gif(tmp_path, capsys):
    gif = tmp_path / "e1s2.gif"
    assert main(["assembly", "play", "--setting", "E1S2", "--policy", "planner", "--seed", "2", "--gif", str(gif)]) == 0
    out = capsys.readouterr().out
    assert "return -3.0000 in 25 steps (terminated: structure complete)" in out
    assert "placed in order: col3, beam1" in out
    frames = imageio.mimread(gif)
    assert len(frames) >= 20 and frames[0].shape[:2] == (480, 640)
    colours = {tuple(c) for c in frames[5][..., :3].reshape(-1, 3)}
    assert (0x2F, 0x6F, 0xDB) in colours and (0xF3, 0x9C, 0x34) in colours  # moving blue, waiting orange


def test_play_random_ansi(capsys):
    assert main(["assembly", "play", "--setting", "E2S4", "--policy", "random", "--seed", "1", "--ansi"]) == 0
    out = capsys.readouterr().out
    assert out.count("E2S4 step") == 101 and "truncated: time limit" in out


def test_play_bad_inputs_leave_no_output(tmp_path, capsys):
    gif = tmp_path / "x.gif"
    assert main(["assembly", "play", "--policy", str(tmp_path / "no-run"), "--gif", str(gif)]) == 2
    assert "neither 'planner', 'random' nor a training run directory" in capsys.readouterr().err
    assert main(["assembly", "play", "--setting", "E2", "--gif", str(gif)]) == 2
    assert not gif.exists() and list(tmp_path.iterdir()) == []


def test_validate_good_and_bad_files(tmp_path, capsys):
    assert main(["assembly", "validate", str(SETTINGS_DIR / "E3S4.yaml")]) == 0
    out = capsys.readouterr().out
    assert "valid scenario 'E3S4'" in out and "solvable" in out and "return 13.0869" in out
    data = yaml.safe_load((SETTINGS_DIR / "E2S2.yaml").read_text())
    data["components"][0]["type"] = "truss"
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(data))
    assert main(["assembly", "validate", str(bad)]) == 2
    err = capsys.readouterr().err
    line = next(n for n, text in enumerate(bad.read_text().splitlines(), 1) if "truss" in text)
    assert err == (f"bimrobot assembly: error: {bad} line {line}: components.col2: unknown component type 'truss' "
                   "(expected one of column, beam)\n")


def test_help_has_examples():
    out = subprocess.run(
        [sys.executable, "-m", "bimrobot", "assembly", "play", "--help"], capture_output=True, text=True, check=True
    ).stdout
    assert "examples:" in out and "--gif" in out


@pytest.mark.slow
def test_play_a_trained_run_dir(tmp_path, capsys):
    """`play --policy <run dir>` loads the rl part's greedy policy and plays the run's own setting."""
    pytest.importorskip("sb3_contrib")
    pytest.importorskip("bimrobot.rl.policy")
    args = ["rl", "train", "--setting", "E1S2", "--algo", "maskable-ppo", "--timesteps", "256", "--seed", "0"]
    assert main(args + ["-o", str(tmp_path), "--no-progress", "--eval-episodes", "1"]) == 0
    run_dir = next(tmp_path.glob("E1S2-*"))
    capsys.readouterr()
    assert main(["assembly", "play", "--policy", str(run_dir), "--seed", "1"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"E1S2 seed 1 policy {run_dir}: return ")
    assert "steps (" in out
