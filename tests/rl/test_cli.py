"""``bimrobot rl``: bad input is one sentence on stderr, exit status 2, and no output written."""

from __future__ import annotations

import pytest

from bimrobot.cli import main


@pytest.mark.parametrize(
    "argv,message",
    [
        (["rl", "train", "--setting", "E9S9", "--algo", "ppo"], "unknown setting 'E9S9'"),
        (["rl", "train", "--setting", "E1S1", "--algo", "ppo", "--timesteps", "lots"], "cannot read 'lots'"),
        (["rl", "train", "--setting", "E1S1", "--algo", "ppo", "--set", "gamma"], "write KEY=VALUE"),
        (["rl", "benchmark", "--seeds", "4-1"], "--seeds: cannot read '4-1'"),
        (["rl", "benchmark", "--settings", "E1S9"], "unknown setting 'E1S9'"),
        (["rl", "benchmark", "--algos", "ppo,sac"], "unknown algorithm 'sac'"),
        (["rl", "benchmark", "--timesteps-per-env", "E1:1e5"], "--timesteps-per-env: cannot read 'E1:1e5'"),
    ],
)
def test_bad_input_exits_2_with_one_sentence(tmp_path, capsys, argv, message):
    assert main(argv + ["-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_eval_of_a_folder_that_is_not_a_run_dir(tmp_path, capsys):
    assert main(["rl", "eval", str(tmp_path)]) == 2
    assert "is not a bimrobot rl run dir: config.json is missing" in capsys.readouterr().err


def test_summary_only_without_finished_runs(tmp_path, capsys):
    assert main(["rl", "benchmark", "--settings", "E1S1", "--summary-only", "-o", str(tmp_path)]) == 2
    assert "holds no finished run of this grid" in capsys.readouterr().err


def test_help_lists_the_algorithms_without_loading_torch():
    """``bimrobot --help`` and every other command build the whole parser: that must not import PyTorch."""
    import subprocess
    import sys

    code = (
        "import sys; from bimrobot.cli import build_parser; "
        "text = build_parser()._subparsers._group_actions[0].choices['rl'].format_help(); "
        "print('torch' in sys.modules)"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert loaded.strip() == "False"
    from bimrobot.rl.algorithms import ALGORITHMS
    from bimrobot.rl.names import ALGORITHM_NAMES

    assert tuple(ALGORITHMS) == ALGORITHM_NAMES


@pytest.mark.parametrize("command", [["train", "--setting", "E1S1", "--algo", "ppo"], ["benchmark"], ["compare", "grid"]])
def test_rl_takes_output_like_every_command_and_still_the_old_out(command):
    from bimrobot.cli import build_parser

    parser = build_parser()
    for option in ("-o", "--output", "--out"):
        assert parser.parse_args(["rl", *command, option, "somewhere"]).out == "somewhere"
    rl = parser._subparsers._group_actions[0].choices["rl"]
    help_text = rl._subparsers._group_actions[0].choices[command[0]].format_help()
    assert "--output" in help_text and "--out " not in help_text  # the old spelling is hidden


def test_compare_without_an_output_says_so(tmp_path, capsys):
    assert main(["rl", "compare", str(tmp_path)]) == 2
    assert "give the Markdown file to write with -o/--output" in capsys.readouterr().err


@pytest.mark.slow
def test_a_second_run_is_written_beside_the_first_and_the_temp_folder_stays_clean(tmp_path, monkeypatch, capsys):
    """`rl train` twice with the same setting, algorithm and seed: the first run dir is kept as it was and
    the second written beside it; PyTorch's cache (torchinductor_<user>, written by the optimiser's
    first step) goes to a folder of the run that is removed: the temporary folder is as before."""
    import tempfile

    pytest.importorskip("stable_baselines3")
    temp = tmp_path / "tmp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    monkeypatch.delenv("TORCHINDUCTOR_CACHE_DIR", raising=False)
    runs = tmp_path / "runs"
    argv = ["rl", "train", "--setting", "E1S1", "--algo", "a2c", "--timesteps", "160", "--eval-episodes", "1",
            "--no-progress", "--output", str(runs)]
    assert main(argv) == 0
    first = (runs / "E1S1-a2c-s0" / "model.zip").read_bytes()
    assert main(argv) == 0
    assert "holds an earlier run of this setting, algorithm and seed: kept; this run is E1S1-a2c-s0-2" in capsys.readouterr().out
    assert (runs / "E1S1-a2c-s0" / "model.zip").read_bytes() == first
    assert (runs / "E1S1-a2c-s0-2" / "results.json").is_file()
    assert list(temp.iterdir()) == []
    assert "TORCHINDUCTOR_CACHE_DIR" not in __import__("os").environ
