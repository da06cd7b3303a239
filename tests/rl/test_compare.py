"""``bimrobot rl compare``: several benchmark grids as one Table 6.1, read from the grids' real summary files."""

from __future__ import annotations

import pytest

from bimrobot.assembly.planner import reference_returns
from bimrobot.cli import main


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """torch and Stable-Baselines3 (about 3 s of imports), imported when these tests run, not at collection."""
    global BenchmarkSpec, write_summary
    from bimrobot.rl.benchmark import BenchmarkSpec, write_summary


def _returns_at(setting: str, score: float) -> float:
    ref = reference_returns(setting)
    return ref["random"] + score * (ref["optimal"] - ref["random"])


def _write_grid(folder, algo_scores: dict[str, float], seeds: list[int], steps: int) -> None:
    """A finished grid on E1S1 whose runs have the given normalised scores (train and eval alike)."""
    spec = BenchmarkSpec(["E1S1"], list(algo_scores), seeds, steps, profile="fast", shaping=1.0)
    results = []
    for algo, target in algo_scores.items():
        good = _returns_at("E1S1", target)
        for seed in seeds:
            episodes = [(10 * (i + 1), good) for i in range(150)]
            results.append({"setting": "E1S1", "algo": algo, "seed": seed, "timesteps": steps,
                            "train_last100_mean": good, "eval_mean": good, "train_seconds": 5.0,
                            "episodes": episodes, "episode_wall_s": [0.1 * (i + 1) for i in range(150)]})
    write_summary(folder, spec, results, command=f"bimrobot rl benchmark --algos {','.join(algo_scores)}")


def test_compare_puts_every_grid_side_by_side_in_the_thesis_column_order(tmp_path, capsys):
    _write_grid(tmp_path / "mppo", {"maskable-ppo": 0.95}, [0, 1, 2], 2000)
    _write_grid(tmp_path / "rest", {"ppo": 0.5, "double-dqn": 0.8}, [0], 1000)
    out = tmp_path / "table.md"
    assert main(["rl", "compare", str(tmp_path / "mppo"), str(tmp_path / "rest"), "-o", str(out)]) == 0
    table = out.read_text()
    # the thesis' columns first, under their honest names, then the extra algorithms
    assert '| setting | double-dqn (thesis "DQN") | ppo (thesis "PPO") | maskable-ppo | thesis best |' in table
    assert "| E1S1 | 0.80 | 0.50 | **0.95** | 0.99 |" in table
    assert "| E4S4 | not run | not run | not run | 0.71 |" in table
    # where each column came from: seeds and budgets differ per grid
    assert "| maskable-ppo | `" in table and "| 3 | 2k / 2k / 2k / 2k | fast | 1 (path) |" in table
    assert "| 1 | 1k / 1k / 1k / 1k |" in table and "--algos ppo,double-dqn" in table
    # 0.95 is >= 0.9 but below the thesis' 0.99 on E1S1; nothing else ran
    assert "| E1S1 | maskable-ppo | 0.95 | 0.95 | 0.99 | yes | no |" in table
    assert "Met on 1 of 16 settings; above the thesis' best cell on 0 of 16." in table
    assert "| E1S1 | - (0/1) | - (0/1) | 1k (3/3) |" in table  # env steps until the last-100 mean scored 0.9


@pytest.mark.parametrize(
    "grids,message",
    [
        (["missing"], "missing is not a bimrobot rl benchmark folder: grid.json is missing"),
        (["a", "b"], "algorithm 'ppo' is in both"),
    ],
)
def test_bad_compare_input_exits_2_with_one_sentence_and_writes_nothing(tmp_path, capsys, grids, message):
    _write_grid(tmp_path / "a", {"ppo": 0.5}, [0], 1000)
    _write_grid(tmp_path / "b", {"ppo": 0.6}, [1], 1000)
    out = tmp_path / "table.md"
    assert main(["rl", "compare", *[str(tmp_path / g) for g in grids], "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not out.exists()
