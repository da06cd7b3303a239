"""The training / evaluation / benchmark harness on the real assembly environments, with tiny budgets."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bimrobot.assembly.planner import reference_returns
from bimrobot.core.errors import InputError
from bimrobot.core.io import MARKER


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """torch and Stable-Baselines3 (about 3 s of imports), imported when these tests run, not at collection."""
    global BenchmarkSpec, aggregate, markdown_table, parse_seeds, parse_settings, parse_timesteps
    global parse_timesteps_per_env, run_benchmark, summarise_finished, time_to_score, load_policy, TrainConfig
    global evaluate_run, train
    from bimrobot.rl.benchmark import (
        BenchmarkSpec,
        aggregate,
        markdown_table,
        parse_seeds,
        parse_settings,
        parse_timesteps,
        parse_timesteps_per_env,
        run_benchmark,
        summarise_finished,
        time_to_score,
    )
    from bimrobot.rl.policy import load_policy
    from bimrobot.rl.train import TrainConfig, evaluate_run, train


@pytest.fixture
def config(request):
    """The TrainConfig of the test's parameter (setting, algorithm, timesteps, keywords)."""
    *args, keywords = request.param
    return TrainConfig(*args, **keywords)


TINY_PPO = {"n_envs": 8, "n_steps": 32, "batch_size": 64, "n_epochs": 1}
TINY_DQN = {"n_envs": 4, "learning_starts": 200, "buffer_size": 2000}


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs")
    config = TrainConfig("E1S2", "maskable-ppo", 1024, seed=3, profile="fast", overrides=TINY_PPO, eval_episodes=3,
                         checkpoint_every=512, shaping=1.0)
    return train(config, out)


def test_run_dir_holds_config_model_logs_checkpoints_and_results(ppo_run):
    assert ppo_run.name == "E1S2-maskable-ppo-s3"
    names = {p.name for p in ppo_run.iterdir()}
    assert {"config.json", "model.zip", "episodes.csv", "progress.csv", "results.json", "checkpoints"} <= names
    assert any(name.startswith("events.out.tfevents") for name in names)  # TensorBoard
    assert len(list((ppo_run / "checkpoints").glob("model_*_steps.zip"))) == 2
    config = json.loads((ppo_run / "config.json").read_text())
    assert config["hyperparameters"]["n_steps"] == 32 and config["hyperparameters"]["gamma"] == 0.9
    results = json.loads((ppo_run / "results.json").read_text())
    assert results["timesteps"] == 1024 and len(results["eval_returns"]) == 3
    # 8 envs x 128 steps of E1 (time limit 100): every env finished at least one episode
    assert results["train_episodes"] >= 8


def test_reported_returns_are_the_environments_not_the_shaped_ones(ppo_run):
    """Episode returns of E1 are sums of -1/-2 step costs and +k placement rewards: no shaping terms."""
    rows = np.loadtxt(ppo_run / "episodes.csv", delimiter=",", skiprows=1, usecols=(1, 2))
    returns, lengths = rows[:, 0], rows[:, 1]
    timed_out_without_placing = -(15 + 2 * (lengths - 15))
    assert np.all((returns == timed_out_without_placing) | (returns > timed_out_without_placing))
    assert np.allclose(returns * 2, np.round(returns * 2))  # E1 rewards are multiples of 1/2 (c = 1, 2)


def test_eval_of_the_saved_model_reproduces_the_training_evaluation(ppo_run):
    results = json.loads((ppo_run / "results.json").read_text())
    again = evaluate_run(ppo_run, episodes=3)
    assert again["returns"] == results["eval_returns"]
    ref = reference_returns("E1S2")
    assert again["score"] == pytest.approx((again["mean"] - ref["random"]) / (ref["optimal"] - ref["random"]))


def test_load_policy_acts_only_through_unmasked_actions(ppo_run):
    from bimrobot.assembly import make_env

    policy = load_policy(ppo_run)
    env = make_env("E1S2")
    obs, info = env.reset(seed=0)
    for _ in range(30):
        action = policy(obs, info)
        assert info["action_mask"][action]
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break


def test_double_dueling_dqn_trains_on_the_batched_env(tmp_path):
    run = train(TrainConfig("E2S1", "double-dueling-dqn", 800, seed=1, overrides=TINY_DQN, eval_episodes=1), tmp_path)
    results = json.loads((run / "results.json").read_text())
    assert results["timesteps"] == 800 and len(results["eval_returns"]) == 1
    assert json.loads((run / "config.json").read_text())["hyperparameters"]["target_update_interval"] == 500


def test_a_failing_run_leaves_no_run_dir(tmp_path):
    """An unknown hyperparameter is refused before the run dir exists (it used to be a TypeError from SB3)."""
    with pytest.raises(InputError, match="unknown hyperparameter for ppo; valid names: batch_size, "):
        train(TrainConfig("E1S1", "ppo", 64, overrides={"not_a_ppo_argument": 1}), tmp_path / "runs")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "config,message",
    [
        (("E5S1", "ppo", 10, {}), "unknown setting 'E5S1'"),
        (("E1S1", "sac", 10, {}), "unknown algorithm 'sac'"),
        (("E1S1", "ppo", 0, {}), "--timesteps must be a number of env steps from 1 to 1e"),
        (("E1S1", "ppo", 10, {"seed": -1}), "--seed must be from 0 to 2147483647"),
        (("E1S1", "dqn", 10, {"overrides": {"buffer_size": 10**12}}), "buffer_size must be >= 1 and <= 1e"),
    ],
    indirect=["config"],
)
def test_bad_training_requests_are_clear_errors(tmp_path, config, message):
    with pytest.raises(InputError, match=message):
        train(config, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_grid_parsers():
    assert parse_seeds("0-2,7") == [0, 1, 2, 7]
    assert parse_settings("E1S1,S2") == ["E1S1", "E1S2", "E2S2", "E3S2", "E4S2"]
    assert len(parse_settings("all")) == 16
    assert parse_timesteps("1e6") == 1_000_000 and parse_timesteps("250k") == 250_000
    assert parse_timesteps_per_env("E1=1e5,E4S4=2e6") == {"E1": 100_000, "E4S4": 2_000_000}
    spec = BenchmarkSpec(["E1S1", "E4S4", "E4S1"], ["ppo"], [0], 5000, parse_timesteps_per_env("E1=1e5,E4S4=2e6"))
    assert [spec.budget(s) for s in spec.settings] == [100_000, 2_000_000, 5000]
    for bad, parse in (("3-1", parse_seeds), ("E7", parse_settings), ("lots", parse_timesteps),
                       ("E1:5", parse_timesteps_per_env)):
        with pytest.raises(InputError):
            parse(bad)


def test_time_to_score_uses_the_rolling_mean_of_100_training_episodes():
    ref = reference_returns("E2S2")
    good = ref["random"] + 0.95 * (ref["optimal"] - ref["random"])
    episodes = [(10 * (i + 1), ref["random"]) for i in range(150)] + [(1500 + 10 * (i + 1), good) for i in range(200)]
    # the rolling mean passes 0.9 when 95/100 of the window are good: after good episode 95
    assert time_to_score(episodes, "E2S2") == 1500 + 10 * 95
    assert time_to_score(episodes[:150], "E2S2") is None


def test_table_cells_are_mean_and_standard_error_over_seeds():
    ref = reference_returns("E1S1")
    runs = [
        {"setting": "E1S1", "algo": "ppo", "seed": s, "timesteps": 1000, "train_last100_mean": m,
         "eval_mean": m + 1, "train_seconds": 10.0, "episodes": []}
        for s, m in enumerate([-10.0, -12.0, -14.0])
    ]
    (row,) = aggregate(runs)
    assert row["train_mean"] == pytest.approx(-12.0)
    assert row["train_se"] == pytest.approx(2.0 / np.sqrt(3))  # sample std 2, 3 seeds
    assert row["eval_mean"] == pytest.approx(-11.0)
    assert row["train_score"] == pytest.approx((-12.0 - ref["random"]) / (ref["optimal"] - ref["random"]))
    table = markdown_table([row], BenchmarkSpec(["E1S1", "E4S4"], ["ppo"], [0, 1, 2], 1000), "bimrobot rl benchmark ...")
    assert "| E1S1 | **-12.00 ± 1.15 (" in table
    assert "| E4S4 | not run |" in table and "Finished runs: 3 of 6" in table
    assert "bimrobot rl benchmark ..." in table


def test_time_to_score_in_env_steps_and_wall_seconds_median_over_seeds():
    ref = reference_returns("E1S1")
    good = ref["random"] + 1.1 * (ref["optimal"] - ref["random"])  # 82 of them in 100 score 0.902

    def run(seed: int, bad_episodes: int) -> dict:
        returns = [ref["random"]] * bad_episodes + [good] * 150
        return {"setting": "E1S1", "algo": "ppo", "seed": seed, "timesteps": 10_000, "train_last100_mean": good,
                "eval_mean": good, "train_seconds": 100.0,
                "episodes": [(10 * (i + 1), r) for i, r in enumerate(returns)],
                "episode_wall_s": [0.5 * (i + 1) for i in range(len(returns))]}

    # the rolling mean of 100 passes 0.9 at the 82nd good episode; the median seed has 200 bad ones first
    (row,) = aggregate([run(0, 100), run(1, 200), run(2, 300)])
    assert row["seeds_reaching_0.9"] == 3
    assert row["median_steps_to_0.9"] == 10 * (200 + 82)
    assert row["median_wall_s_to_0.9"] == pytest.approx(0.5 * (200 + 82))
    table = markdown_table([row], BenchmarkSpec(["E1S1"], ["ppo"], [0, 1, 2], 10_000), "")
    assert "| 3/3 | 2,820 | 141 s |" in table


@pytest.mark.slow
def test_benchmark_grid_in_parallel_and_resumed(tmp_path):
    spec = BenchmarkSpec(["E1S2"], ["maskable-ppo", "double-dqn"], [0, 1], 512, profile="fast", eval_episodes=2,
                         overrides={"maskable-ppo": TINY_PPO, "double-dqn": TINY_DQN})
    results = run_benchmark(spec, tmp_path, workers=2, command="test grid")
    assert sorted((r["algo"], r["seed"]) for r in results) == [
        ("double-dqn", 0), ("double-dqn", 1), ("maskable-ppo", 0), ("maskable-ppo", 1)]
    table = (tmp_path / "table.md").read_text()
    assert "| setting | maskable-ppo | double-dqn |" in table and "| E1S2 |" in table
    assert (tmp_path / "learning_curves.png").read_bytes()[:4] == b"\x89PNG"
    assert json.loads((tmp_path / MARKER).read_text())["kind"] == "rl benchmark"
    assert all(json.loads((run / MARKER).read_text())["kind"] == "rl train run" for run in (tmp_path / "runs").iterdir())
    grid = json.loads((tmp_path / "grid.json").read_text())
    assert grid["command"] == "test grid" and len(grid["runs"]) == 4
    # a second call reuses the finished runs instead of training again
    stamps = {p: p.stat().st_mtime for p in (tmp_path / "runs").glob("*/model.zip")}
    again = run_benchmark(spec, tmp_path, workers=1)
    assert [r["eval_mean"] for r in again] == [r["eval_mean"] for r in results]
    assert stamps == {p: p.stat().st_mtime for p in (tmp_path / "runs").glob("*/model.zip")}
    # the summary alone can be rebuilt from the finished runs
    (tmp_path / "table.md").unlink()
    assert len(summarise_finished(spec, tmp_path)) == 4
    assert "Finished runs: 4 of 4." in (tmp_path / "table.md").read_text()
    # ... but never from, or on top of, runs trained with another budget
    longer = BenchmarkSpec(spec.settings, spec.algos, spec.seeds, 1024, profile="fast", overrides=spec.overrides)
    with pytest.raises(InputError, match="E1S2-maskable-ppo-s0 was trained with timesteps=512, not 1024"):
        run_benchmark(longer, tmp_path, workers=1)


@pytest.mark.slow  # starts a local Ray instance and trains two PPO runs
def test_benchmark_on_a_local_ray_instance(tmp_path):
    ray = pytest.importorskip("ray", reason="Ray is an optional extra (pip install 'bimrobot[ray]')")
    spec = BenchmarkSpec(["E1S1"], ["ppo"], [0, 1], 256, profile="fast", eval_episodes=1,
                         overrides={"ppo": TINY_PPO})
    try:
        results = run_benchmark(spec, tmp_path, workers=2, ray_address="local")
    finally:
        ray.shutdown()
    assert sorted(r["seed"] for r in results) == [0, 1]
    assert (tmp_path / "table.md").is_file()
