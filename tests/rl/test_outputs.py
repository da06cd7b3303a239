"""The output policy of ``rl train -o``, ``rl benchmark -o`` and ``rl compare -o``: bad paths are one sentence
before any training, the user's files stay byte for byte, bimrobot's own outputs are replaced (or, for a
benchmark folder, continued) saying so, and a failure leaves no empty folder behind."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bimrobot.cli import main
from bimrobot.core.errors import InputError
from bimrobot.core.io import MARKER, has_signature
from output_checks import snapshot


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """torch and Stable-Baselines3 (about 3 s of imports), imported when these tests run, not at collection."""
    global BenchmarkSpec, benchmark_folder, write_summary
    from bimrobot.rl.benchmark import BenchmarkSpec, write_summary
    from bimrobot.rl.benchmark_folder import benchmark_folder


TINY_PPO = ["--set", "n_envs=8", "--set", "n_steps=32", "--set", "n_epochs=1"]
TRAIN = ["rl", "train", "--setting", "E1S1", "--algo", "ppo", "--timesteps", "256", "--eval-episodes", "1",
         "--no-progress", *TINY_PPO]
BENCHMARK = ["rl", "benchmark", "--settings", "E1S1", "--algos", "ppo", "--seeds", "0", "--timesteps", "64"]


@pytest.fixture
def workspace(tmp_path, monkeypatch):
    """The current directory: a folder and a file of the user's, and a link to that folder."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("my notes\n")
    (tmp_path / "photo.png").write_bytes(b"\x89PNG not bimrobot's")
    (tmp_path / "link").symlink_to(tmp_path / "mine", target_is_directory=True)
    return tmp_path


def _refused(capsys, argv: list[str], message: str, folder: Path) -> None:
    before = snapshot(folder)
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert message in captured.err and captured.err.count("\n") == 1, captured.err
    assert "Traceback" not in captured.err and captured.out == ""
    assert snapshot(folder) == before


# ------------------------------------------------------------------------------------------ rl train -o


@pytest.mark.slow
def test_train_never_touches_a_run_dir_that_is_not_bimrobots(workspace, capsys):
    """-o is the parent folder; a folder (or link) of the run's name that is not bimrobot's is kept as it is
    and the run is written beside it (E1S1-ppo-s0-2); a file as the parent is refused."""
    (workspace / "runs" / "E1S1-ppo-s0").mkdir(parents=True)
    (workspace / "runs" / "E1S1-ppo-s0" / "my.txt").write_text("mine\n")
    assert main(TRAIN + ["-o", "runs"]) == 0
    assert (workspace / "runs" / "E1S1-ppo-s0" / "my.txt").read_text() == "mine\n"
    assert sorted(p.name for p in (workspace / "runs" / "E1S1-ppo-s0").iterdir()) == ["my.txt"]
    assert json.loads((workspace / "runs" / "E1S1-ppo-s0-2" / MARKER).read_text())["kind"] == "rl train run"
    (workspace / "linked").mkdir()
    (workspace / "linked" / "E1S1-ppo-s0").symlink_to(workspace / "mine", target_is_directory=True)
    before = snapshot(workspace / "mine")
    assert main(TRAIN + ["-o", "linked"]) == 0
    assert snapshot(workspace / "mine") == before and (workspace / "linked" / "E1S1-ppo-s0-2").is_dir()
    capsys.readouterr()
    _refused(capsys, TRAIN + ["-o", "photo.png"], "photo.png is a file, not a folder, so nothing can be written under it",
             workspace)
    _refused(capsys, TRAIN + ["-o", "photo.png/runs"], "photo.png is a file, not a folder", workspace)


@pytest.mark.parametrize(
    "extra,message",
    [
        (["--set", "foo=1"], "--set foo: unknown hyperparameter for ppo; valid names: batch_size, clip_range,"),
        (["--set", "learning_rate=abc"], "--set learning_rate='abc': learning_rate must be a finite number > 0 and <= 1"),
        (["--set", "learning_rate=NaN"], "--set learning_rate=nan: learning_rate must be a finite number"),
        (["--set", "gamma=1.5"], "--set gamma=1.5: gamma must be >= 0 and <= 1"),
        (["--set", "n_envs=0"], "--set n_envs=0: n_envs must be >= 1 and <= 4096"),
        (["--set", "n_steps=2.5"], "--set n_steps=2.5: n_steps must be a whole number"),
        (["--set", "normalize_advantage=1"], "--set normalize_advantage=1: normalize_advantage must be true or false"),
        (["--set", "n_envs=1", "--set", "n_steps=1"], "ppo: n_envs x n_steps must be at least 2, got 1 x 1"),
        (["--timesteps", "1e400"], "--timesteps: '1e400' env steps is more than the 1e+10 a run may take"),
        (["--timesteps", "1.2.3"], "--timesteps: cannot read '1.2.3' as a number of env steps"),
        (["--checkpoint-every", "0"], "--checkpoint-every: a number of env steps must be >= 1"),
        (["--seed", "-1"], "--seed must be from 0 to 2147483647, got -1"),
        (["--shaping", "nan"], "--shaping must be a finite scale from 0 to 1000, got nan"),
        (["--threads", "0"], "--threads must be from 1 to 1024, got 0"),
        (["--eval-episodes", "-1"], "--eval-episodes must be from 0 to 100000, got -1"),
    ],
)
def test_bad_training_options_are_one_sentence_and_write_nothing(workspace, capsys, extra, message):
    _refused(capsys, TRAIN + extra + ["-o", "runs"], message, workspace)
    assert not (workspace / "runs").exists()


@pytest.mark.slow
def test_train_into_the_current_directory_writes_only_its_run_dirs_and_keeps_the_earlier_run(workspace, capsys):
    before = snapshot(workspace)
    assert main(TRAIN + ["-o", "."]) == 0
    run = workspace / "E1S1-ppo-s0"
    assert json.loads((run / MARKER).read_text())["kind"] == "rl train run"
    assert sorted(p.name for p in workspace.iterdir()) == ["E1S1-ppo-s0", "link", "mine", "photo.png"]
    stamp = (run / "model.zip").stat().st_mtime_ns
    capsys.readouterr()
    assert main(TRAIN + ["-o", "."]) == 0
    assert "E1S1-ppo-s0 holds an earlier run of this setting, algorithm and seed: kept" in capsys.readouterr().out
    assert (run / "model.zip").stat().st_mtime_ns == stamp  # the earlier run is kept as it was
    assert json.loads((workspace / "E1S1-ppo-s0-2" / MARKER).read_text())["kind"] == "rl train run"
    assert {k: v for k, v in snapshot(workspace).items() if not k.startswith("E1S1-ppo-s0")} == before


def test_an_interrupted_run_leaves_no_run_dir_and_no_parent_it_created(tmp_path, monkeypatch):
    """Ctrl-C in the middle of training: neither the run dir nor the parent folders made for it remain."""
    import bimrobot.rl.train as train_module

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(train_module, "build_model", interrupted)
    config = train_module.TrainConfig("E1S1", "ppo", 64)
    with pytest.raises(KeyboardInterrupt):
        train_module.train(config, tmp_path / "new" / "runs")
    assert list(tmp_path.iterdir()) == []


# -------------------------------------------------------------------------------------- rl benchmark -o


@pytest.mark.parametrize(
    "target,message",
    [
        (".", "-o . is the current directory"),
        ("mine", "-o mine is a folder that bimrobot did not write and it is not empty"),
        ("link", "-o link is a folder that bimrobot did not write and it is not empty"),
        ("photo.png", "-o photo.png is an existing file, not a folder"),
        ("photo.png/grid", "photo.png is a file, not a folder, so nothing can be written under it"),
    ],
)
@pytest.mark.parametrize("summary_only", [False, True], ids=["benchmark", "summary-only"])
def test_benchmark_refuses_bad_folders_before_training(workspace, capsys, target, message, summary_only):
    _refused(capsys, BENCHMARK + ["-o", target] + (["--summary-only"] if summary_only else []), message, workspace)


@pytest.mark.parametrize(
    "extra,message",
    [
        (["--seeds", "0-99999999999"], "--seeds: '0-99999999999' goes beyond the largest seed, 2147483647"),
        (["--seeds", "0-5000"], "--seeds: '0-5000' asks for more than 1000 seeds"),
        (["--workers", "0"], "--workers must be from 1 to 1024, got 0"),
        (["--shaping", "inf"], "--shaping must be a finite scale from 0 to 1000, got inf"),
        (["--timesteps-per-env", "E1=nan"], "--timesteps-per-env E1: cannot read 'nan' as a number of env steps"),
        (["--timesteps-per-env", "E1=1e99"], "--timesteps-per-env E1: '1e99' env steps is more than"),
        (["--eval-episodes", "-5"], "--eval-episodes must be from 0 to 100000, got -5"),
    ],
)
def test_bad_benchmark_options_are_one_sentence_and_write_nothing(workspace, capsys, extra, message):
    _refused(capsys, BENCHMARK + extra + ["-o", "grid"], message, workspace)
    assert not (workspace / "grid").exists()


def test_a_failed_benchmark_leaves_no_folder_it_created(tmp_path):
    target = tmp_path / "a" / "grid"
    with pytest.raises(RuntimeError):
        with benchmark_folder(target) as folder:
            assert (folder / MARKER).is_file() and (folder / "runs").is_dir()
            raise RuntimeError("the first run failed")
    assert list(tmp_path.iterdir()) == []
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(KeyboardInterrupt):
        with benchmark_folder(empty):
            raise KeyboardInterrupt
    assert empty.is_dir() and list(empty.iterdir()) == []


def _finish_a_run(folder: Path, name: str = "E1S1-ppo-s0") -> None:
    run = folder / "runs" / name
    run.mkdir(parents=True)
    (run / "results.json").write_text("{}")


def test_another_bimrobot_output_is_replaced_saying_so_and_put_back_if_nothing_finished(tmp_path, capsys):
    from bimrobot.core.io import atomic_output_dir

    old = tmp_path / "out"
    with atomic_output_dir(old, kind="simulate") as tmp:  # marked, with the manifest of its files
        (tmp / "report.json").write_text("{}")
    before = snapshot(old)
    with pytest.raises(RuntimeError):
        with benchmark_folder(old):
            raise RuntimeError("no run finished")
    assert "bimrobot: replacing " in capsys.readouterr().err
    assert snapshot(old) == before and sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    with pytest.raises(RuntimeError):
        with benchmark_folder(old) as folder:
            _finish_a_run(folder)
            raise RuntimeError("interrupted after a finished run")
    assert json.loads((old / MARKER).read_text())["kind"] == "rl benchmark"
    assert (old / "runs" / "E1S1-ppo-s0" / "results.json").is_file() and not (old / "report.json").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no backup left


def test_a_benchmark_folder_is_continued_not_replaced(tmp_path, capsys):
    """Finished runs of an interrupted benchmark are kept; a failure while continuing removes nothing."""
    with pytest.raises(RuntimeError):
        with benchmark_folder(tmp_path / "grid") as folder:
            _finish_a_run(folder)
            raise RuntimeError("interrupted")
    capsys.readouterr()
    with pytest.raises(RuntimeError):
        with benchmark_folder(tmp_path / "grid") as folder:
            raise RuntimeError("interrupted again before the next run finished")
    assert "bimrobot: continuing the benchmark in " in capsys.readouterr().err
    assert (tmp_path / "grid" / "runs" / "E1S1-ppo-s0" / "results.json").is_file()


def test_a_benchmark_folder_from_before_markers_is_recognised(tmp_path):
    legacy = tmp_path / "docs-grid"
    legacy.mkdir()
    (legacy / "grid.json").write_text(json.dumps({"command": "", "spec": {}, "runs": []}))
    (legacy / "table.md").write_text("# Assembly-planning benchmark results\n\nCommand: ...\n")
    with benchmark_folder(legacy) as folder:
        assert folder == legacy.resolve()
    assert json.loads((legacy / MARKER).read_text())["kind"] == "rl benchmark"
    assert (legacy / "table.md").read_text().startswith("# Assembly-planning")


def test_summary_files_carry_the_signature(tmp_path):
    spec = BenchmarkSpec(["E1S1"], ["ppo"], [0], 1000)
    run = {"setting": "E1S1", "algo": "ppo", "seed": 0, "timesteps": 1000, "train_last100_mean": -100.0,
           "eval_mean": -90.0, "train_seconds": 1.0, "episodes": [(10, -100.0)], "episode_wall_s": [0.1]}
    with benchmark_folder(tmp_path / "grid") as folder:
        write_summary(folder, spec, [run], "bimrobot rl benchmark ...")
    lines = (folder / "table.md").read_text().splitlines()
    assert lines[0].startswith("<!-- written by bimrobot") and lines[1] == "# Assembly-planning benchmark results"
    assert json.loads((folder / "grid.json").read_text())["generator"].startswith("written by bimrobot")
    assert has_signature(folder / "learning_curves.png")  # a PNG text chunk


# ---------------------------------------------------------------------------------------- rl compare -o


@pytest.fixture
def grid(workspace):
    spec = BenchmarkSpec(["E1S1"], ["ppo"], [0], 1000)
    run = {"setting": "E1S1", "algo": "ppo", "seed": 0, "timesteps": 1000, "train_last100_mean": -100.0,
           "eval_mean": -90.0, "train_seconds": 1.0, "episodes": [(10, -100.0)], "episode_wall_s": [0.1]}
    with benchmark_folder(workspace / "grid") as folder:
        write_summary(folder, spec, [run], "bimrobot rl benchmark ...")
    return folder


@pytest.mark.parametrize(
    "target,message",
    [
        (".", "-o . is the current directory"),
        ("grid/table.csv", "-o grid/table.csv is an input of this command"),
        ("grid/table.md", "-o grid/table.md is an input of this command"),
        ("mine", "-o mine is a folder; give a file name"),
        ("link", "-o link is a folder; give a file name"),
        ("mine/notes.txt", "-o mine/notes.txt is an existing file that bimrobot did not write"),
        ("photo.png/table.md", "photo.png is a file, not a folder, so nothing can be written under it"),
    ],
)
def test_compare_refuses_bad_paths(workspace, grid, capsys, target, message):
    _refused(capsys, ["rl", "compare", "grid", "-o", target], message, workspace)


def test_compare_output_is_signed_and_replaced_saying_so(workspace, grid, capsys):
    assert main(["rl", "compare", "grid", "-o", "table.md"]) == 0
    lines = (workspace / "table.md").read_text().splitlines()
    assert lines[0].startswith("<!-- written by bimrobot") and lines[0].endswith("(rl compare) -->")
    assert lines[1].startswith("# Assembly-planning benchmark: all grids side by side")
    assert main(["rl", "compare", "grid", "-o", "table.md"]) == 0
    assert "bimrobot: replacing table.md (a file bimrobot wrote)" in capsys.readouterr().err
    # a comparison written before signatures (like docs/results/table.md) is recognised by its heading
    old = workspace / "old.md"
    old.write_text("# Assembly-planning benchmark: all grids side by side (thesis Table 6.1)\n\nold\n")
    assert main(["rl", "compare", "grid", "-o", "old.md"]) == 0
    assert has_signature(old)


def test_summary_only_refuses_a_folder_that_is_not_a_benchmark(tmp_path):
    from bimrobot.rl.benchmark import summarise_finished

    with pytest.raises(InputError, match="holds no finished run of this grid"):
        summarise_finished(BenchmarkSpec(["E1S1"], ["ppo"], [0], 64), tmp_path / "none")
    assert list(tmp_path.iterdir()) == []
