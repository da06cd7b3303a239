"""Train one algorithm on one assembly setting with one seed, and evaluate it: a self-contained *run dir*.

A run dir ``<out>/<setting>-<algo>-s<seed>/`` holds

* ``config.json``: what was asked (setting, algorithm, seed, timesteps, hyperparameters, versions);
* ``model.zip``: the final SB3 model (``bimrobot rl eval`` / ``bimrobot.rl.policy.load_policy`` read it);
* ``episodes.csv``: every finished training episode (``timestep, return, length, wall_s``): the learning
  curve and the "mean of the last 100 training episodes" of Table 6.1 come from it;
* ``progress.csv`` and ``events.out.tfevents.*``: SB3's own training log (CSV and TensorBoard);
* ``checkpoints/``: the model every ``checkpoint_every`` env steps;
* ``results.json``: last-100 training mean, greedy evaluation (20 episodes by default), normalised
  scores against the planner's reference table, wall time and throughput.

The run dir appears only when the run completes (written through :func:`bimrobot.core.io.atomic_output_dir`).
Returns are in the environment's reward units; time in seconds.
"""

from __future__ import annotations

import contextlib
import csv
import json
import logging
import math
import os
import platform
import shutil
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, CheckpointCallback
from stable_baselines3.common.logger import configure
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv, VecMonitor

from bimrobot.core.errors import InputError
from bimrobot.core.io import atomic_output_dir
from bimrobot.rl.algorithms import MAX_TIMESTEPS, get_algorithm, hyperparameters
from bimrobot.rl.names import SHAPING_METRICS

log = logging.getLogger(__name__)

LAST_EPISODES = 100  # Table 6.1: mean return of the last 100 training episodes
EVAL_SEED_OFFSET = 10_000  # evaluation resets never reuse a training seed
MAX_EVAL_EPISODES = 100_000
MAX_THREADS = 1024
MAX_SHAPING = 1000.0  # the shaping pays +-scale per cell; the env's own rewards are about 1 per step
RUN_KIND = "rl train run"  # the kind in a run dir's bimrobot.core.io marker


@dataclass
class TrainConfig:
    """One training run. ``timesteps`` counts env steps over all parallel envs; ``threads`` torch threads."""

    setting: str
    algo: str
    timesteps: int
    seed: int = 0
    profile: str = "thesis"
    overrides: dict[str, Any] = field(default_factory=dict)
    eval_episodes: int = 20
    checkpoint_every: int = 100_000
    threads: int = 1
    progress_bar: bool = False
    shaping: float = 0.0  # scale of the potential-based distance shaping (bimrobot.rl.shaping); 0 = off
    shaping_metric: str = "path"  # its distance: "path" (shortest unblocked path) or "manhattan"

    @property
    def run_name(self) -> str:
        return f"{self.setting}-{self.algo}-s{self.seed}"

    def validate(self) -> None:
        """Refuse, in one sentence naming the option, anything that would fail or make no sense in training."""
        from bimrobot.assembly import SETTINGS
        from bimrobot.assembly.env import MAX_SEED

        if self.setting not in SETTINGS:
            raise InputError(f"unknown setting {self.setting!r}: expected one of {', '.join(SETTINGS)}")
        get_algorithm(self.algo)
        if not 1 <= self.timesteps <= MAX_TIMESTEPS:
            raise InputError(f"--timesteps must be a number of env steps from 1 to {MAX_TIMESTEPS:.0e}, got {self.timesteps}")
        if not 1 <= self.checkpoint_every <= MAX_TIMESTEPS:
            raise InputError(f"--checkpoint-every must be from 1 to {MAX_TIMESTEPS:.0e} env steps, got {self.checkpoint_every}")
        if not 0 <= self.seed <= MAX_SEED:
            raise InputError(f"--seed must be from 0 to {MAX_SEED}, got {self.seed}")
        if not (math.isfinite(self.shaping) and 0 <= self.shaping <= MAX_SHAPING):
            raise InputError(f"--shaping must be a finite scale from 0 to {MAX_SHAPING:g}, got {self.shaping}")
        if not 0 <= self.eval_episodes <= MAX_EVAL_EPISODES:
            raise InputError(f"--eval-episodes must be from 0 to {MAX_EVAL_EPISODES}, got {self.eval_episodes}")
        if not 1 <= self.threads <= MAX_THREADS:
            raise InputError(f"--threads must be from 1 to {MAX_THREADS}, got {self.threads}")
        if self.shaping_metric not in SHAPING_METRICS:
            raise InputError(f"--shaping-metric must be one of {', '.join(SHAPING_METRICS)}, got {self.shaping_metric!r}")
        hyperparameters(self.algo, self.setting, self.profile, self.overrides)  # unknown names, bad values


def make_vec_env(setting: str, n_envs: int, seed: int) -> VecEnv:
    """``n_envs`` environments of ``setting`` as an SB3 VecEnv that reports Monitor-style episode infos
    and ``action_masks()``: the assembly part's batched simulator when it exists, else a DummyVecEnv."""
    try:
        from bimrobot.assembly.vector import AssemblySB3VecEnv
    except ImportError:
        AssemblySB3VecEnv = None
    if AssemblySB3VecEnv is not None:
        venv = AssemblySB3VecEnv(setting, num_envs=n_envs, seed=seed)
    else:  # pragma: no cover - only before the batched simulator exists
        from bimrobot.assembly import make_env

        venv = VecMonitor(DummyVecEnv([lambda: make_env(setting) for _ in range(n_envs)]))
        venv.seed(seed)
    return venv


class EpisodeLog(BaseCallback):
    """Appends every finished training episode to ``episodes.csv`` (timestep, return, length, wall_s)."""

    def __init__(self, path: Path):
        super().__init__()
        self.path = path
        self.returns: list[float] = []

    def _on_training_start(self) -> None:
        self._file = open(self.path, "w", newline="")
        self._writer = csv.writer(self._file)
        self._writer.writerow(["timestep", "return", "length", "wall_s"])
        self._t0 = time.perf_counter()

    def _on_step(self) -> bool:
        for info in self.locals["infos"]:
            episode = info.get("episode")
            if episode is not None:
                self.returns.append(float(episode["r"]))
                self._writer.writerow(
                    [self.num_timesteps, f"{episode['r']:.4f}", int(episode["l"]), f"{time.perf_counter() - self._t0:.2f}"]
                )
        return True

    def _on_training_end(self) -> None:
        self._file.close()


class ProgressBar(BaseCallback):
    """A tqdm progress bar over env steps (SB3's own needs ``rich``, which we do not depend on)."""

    def __init__(self, total: int, description: str):
        super().__init__()
        self.total, self.description = total, description

    def _on_training_start(self) -> None:
        from tqdm import tqdm

        self._bar = tqdm(total=self.total, desc=self.description, unit="step", unit_scale=True, dynamic_ncols=True)

    def _on_step(self) -> bool:
        self._bar.total = max(self._bar.total, self.num_timesteps)  # rollouts may overshoot the budget
        self._bar.update(self.num_timesteps - self._bar.n)
        return True

    def _on_training_end(self) -> None:
        self._bar.close()


def build_model(config: TrainConfig, venv: VecEnv, tensorboard_log: str | None = None):
    """The SB3 model of ``config`` on ``venv`` (its hyperparameters minus ``n_envs``)."""
    algorithm = get_algorithm(config.algo)
    params = hyperparameters(config.algo, config.setting, config.profile, config.overrides)
    params.pop("n_envs")
    return algorithm.sb3_class(algorithm.policy, venv, seed=config.seed, device="cpu", verbose=0, **params)


def greedy_returns(model, algo: str, setting: str, episodes: int, seed: int) -> list[float]:
    """Returns of ``episodes`` greedy (deterministic) episodes; episode e resets with ``seed + e``.
    Maskable algorithms act with the env's action mask, the others without."""
    from bimrobot.assembly import make_env

    env = make_env(setting)
    masked = get_algorithm(algo).uses_action_mask
    returns = []
    for episode in range(episodes):
        obs, info = env.reset(seed=seed + episode)
        total, done = 0.0, False
        while not done:
            kwargs = {"action_masks": info["action_mask"]} if masked else {}
            action, _ = model.predict(obs, deterministic=True, **kwargs)
            obs, reward, terminated, truncated, info = env.step(int(action))
            total += float(reward)
            done = terminated or truncated
        returns.append(total)
    env.close()
    return returns


def score(setting: str, mean_return: float | None) -> float | None:
    """Normalised score ``(return - random) / (optimal - random)`` from the planner's reference table."""
    if mean_return is None:
        return None
    try:
        from bimrobot.assembly.planner import reference_returns

        ref = reference_returns(setting)
    except ImportError as exc:  # the planner's table needs the assembly part's batched simulator
        log.warning("no normalised score for %s: %s", setting, exc)
        return None
    return (mean_return - ref["random"]) / (ref["optimal"] - ref["random"])


def _versions() -> dict[str, str]:
    import gymnasium
    import sb3_contrib
    import stable_baselines3

    from bimrobot import __version__

    return {
        "bimrobot": __version__,
        "stable_baselines3": stable_baselines3.__version__,
        "sb3_contrib": sb3_contrib.__version__,
        "gymnasium": gymnasium.__version__,
        "torch": th.__version__,
        "python": platform.python_version(),
    }


def free_run_dir(out_dir: Path, name: str) -> Path:
    """``out_dir/name``, or beside an earlier run of that name the first free ``name-2``, ``name-3``, ..."""
    run_dir, number = out_dir / name, 1
    while run_dir.exists() or run_dir.is_symlink():
        number += 1
        run_dir = out_dir / f"{name}-{number}"
    return run_dir


@contextlib.contextmanager
def private_temp_folder(prefix: str = "bimrobot-rl-"):
    """A temporary folder for what PyTorch caches during a run (``TORCHINDUCTOR_CACHE_DIR``, else
    ``<tmp>/torchinductor_<user>`` left behind after every run); removed, with the setting, at the end.
    A cache folder the user set is kept as it is."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    own = "TORCHINDUCTOR_CACHE_DIR" not in os.environ
    if own:
        os.environ["TORCHINDUCTOR_CACHE_DIR"] = str(folder / "torchinductor")
    try:
        yield folder
    finally:
        if own:
            os.environ.pop("TORCHINDUCTOR_CACHE_DIR", None)
        shutil.rmtree(folder, ignore_errors=True)


def train(config: TrainConfig, out_dir: str | Path, *, keep_earlier: bool = True) -> Path:
    """Train, checkpoint, evaluate and write the run dir ``out_dir/<setting>-<algo>-s<seed>``; returns it.

    ``out_dir`` is the parent: it may exist and hold other runs. With ``keep_earlier`` (the CLI's way) an
    earlier run of the same setting, algorithm and seed is never replaced: the new run is written beside
    it, as ``<name>-2``, ``<name>-3``, ... (:func:`free_run_dir`). Without it (the benchmark, which
    reuses finished runs) the run dir follows :mod:`bimrobot.core.io`'s policy (a run dir bimrobot wrote is
    replaced; anything else there is refused). The run dir appears only when the run completes: a
    failure or Ctrl-C leaves neither it nor a parent this call created, nor PyTorch's cache files in
    the temporary folder (:func:`private_temp_folder`).
    """
    config.validate()
    th.set_num_threads(config.threads)
    params = hyperparameters(config.algo, config.setting, config.profile, config.overrides)
    run_dir = Path(out_dir) / config.run_name
    if keep_earlier:
        run_dir = free_run_dir(Path(out_dir), config.run_name)
    with private_temp_folder(), atomic_output_dir(run_dir, kind=RUN_KIND, option="-o") as tmp:
        (tmp / "config.json").write_text(
            json.dumps({**asdict(config), "hyperparameters": params, "versions": _versions()}, indent=2)
        )
        venv = make_vec_env(config.setting, params["n_envs"], config.seed)
        if config.shaping > 0:
            from bimrobot.rl.shaping import DistanceShaping

            venv = DistanceShaping(venv, scale=config.shaping, metric=config.shaping_metric)
        model = build_model(config, venv)
        model.set_logger(configure(str(tmp), ["csv", "tensorboard"]))
        episode_log = EpisodeLog(tmp / "episodes.csv")
        callbacks = [
            episode_log,
            CheckpointCallback(max(config.checkpoint_every // params["n_envs"], 1), str(tmp / "checkpoints"), "model"),
        ]
        if config.progress_bar:
            callbacks.append(ProgressBar(config.timesteps, config.run_name))
        start = time.perf_counter()
        model.learn(total_timesteps=config.timesteps, callback=CallbackList(callbacks))
        train_seconds = time.perf_counter() - start
        model.save(tmp / "model.zip")
        venv.close()
        results = summarise(config, episode_log.returns, model, train_seconds)
        (tmp / "results.json").write_text(json.dumps(results, indent=2))
        from bimrobot.rl.plots import plot_run_curve

        plot_run_curve(episode_log.returns, tmp / "learning_curve.png", f"{config.run_name}: training return")
    log.info("%s: %s", config.run_name, results)
    return run_dir


def summarise(config: TrainConfig, train_returns: list[float], model, train_seconds: float) -> dict[str, Any]:
    """results.json of a run: last-100 training mean, greedy evaluation, normalised scores, throughput."""
    last = train_returns[-LAST_EPISODES:]
    train_mean = float(np.mean(last)) if last else None
    eval_returns = greedy_returns(model, config.algo, config.setting, config.eval_episodes, config.seed + EVAL_SEED_OFFSET)
    eval_mean = float(np.mean(eval_returns)) if eval_returns else None
    return {
        "setting": config.setting,
        "algo": config.algo,
        "seed": config.seed,
        "timesteps": int(model.num_timesteps),
        "train_episodes": len(train_returns),
        "train_last100_mean": train_mean,
        "train_last100_score": score(config.setting, train_mean),
        "eval_returns": eval_returns,
        "eval_mean": eval_mean,
        "eval_score": score(config.setting, eval_mean),
        "train_seconds": round(train_seconds, 2),
        "steps_per_second": round(model.num_timesteps / max(train_seconds, 1e-9), 1),
    }


def evaluate_run(run_dir: str | Path, episodes: int = 20, seed: int | None = None) -> dict[str, Any]:
    """Greedy evaluation of a finished run dir's model: returns, mean, normalised score."""
    from bimrobot.rl.policy import load_model

    model, config = load_model(run_dir)
    seed = config["seed"] + EVAL_SEED_OFFSET if seed is None else seed
    returns = greedy_returns(model, config["algo"], config["setting"], episodes, seed)
    mean = float(np.mean(returns))
    return {"setting": config["setting"], "algo": config["algo"], "episodes": episodes, "seed": seed,
            "returns": returns, "mean": mean, "score": score(config["setting"], mean)}
