"""The benchmark grid: settings x algorithms x seeds, run in parallel, summarised like the thesis' Table 6.1.

``run_benchmark`` trains every (setting, algo, seed) not yet finished under ``out/runs/`` in a local
process pool (or, with ``ray_address``, on a Ray cluster through ``ray.util.multiprocessing.Pool``) and,
after every finished run, rewrites the summary in ``out/``:

* ``table.md`` / ``table.csv``: per setting and algorithm, mean +- standard error over seeds of (a) the mean
  return of the last 100 training episodes and (b) the mean return of 20 greedy evaluation episodes, each
  with its normalised score ``(return - random) / (optimal - random)``, and the env steps until the mean of
  the last 100 training episodes first reached a score of 0.9 (and the wall time of training until then);
* ``learning_curves.png``: one panel per setting (thesis fig. 6.15);
* ``grid.json``: the command line, the grid and every run's results.

Finished runs are skipped, so an interrupted benchmark continues where it stopped: the output folder is
therefore kept in place while the grid runs (:func:`benchmark_folder`), not built aside and renamed at the
end like other outputs; each run dir inside it is still written atomically. The folder's policy is
:mod:`bimrobot.rl.benchmark_folder`.
"""

from __future__ import annotations

import contextlib
import csv
import json
import logging
import multiprocessing
import os
import re
import shutil
import signal
import tempfile
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from bimrobot.core.errors import InputError
from bimrobot.core.io import signature
from bimrobot.rl.algorithms import ALGORITHMS, MAX_TIMESTEPS, get_algorithm
from bimrobot.rl.benchmark_folder import _LEGACY_HEADING, benchmark_folder
from bimrobot.rl.compare import SCORE_GOAL, THESIS_BEST_SCORE
from bimrobot.rl.train import LAST_EPISODES, TrainConfig, train

log = logging.getLogger(__name__)


def parse_settings(text: str) -> list[str]:
    """"all", "E1" (its four scenarios), "S2" (all envs' scenario 2) or a comma list, e.g. "E1S1,E3"."""
    from bimrobot.assembly import SETTINGS

    chosen: list[str] = []
    for item in (part.strip().upper() for part in text.split(",") if part.strip()):
        if item == "ALL":
            matches = list(SETTINGS)
        elif re.fullmatch(r"E[1-4]", item) or re.fullmatch(r"S[1-4]", item):
            matches = [s for s in SETTINGS if item in s]
        elif item in SETTINGS:
            matches = [item]
        else:
            raise InputError(f"--settings: unknown setting {item!r}; use all, E1..E4, S1..S4 or E1S1..E4S4")
        chosen += [s for s in matches if s not in chosen]
    if not chosen:
        raise InputError("--settings is empty")
    return chosen


def parse_algos(text: str) -> list[str]:
    """Comma list of algorithm names, or "all"."""
    names = list(ALGORITHMS) if text.strip() == "all" else [a.strip() for a in text.split(",") if a.strip()]
    for name in names:
        get_algorithm(name)
    if not names:
        raise InputError("--algos is empty")
    return names


#: Most seeds of one grid (each seed is a full row of runs).
MAX_SEEDS = 1000
#: Most parallel training processes (local or on a Ray cluster).
MAX_WORKERS = 1024


def parse_seeds(text: str) -> list[int]:
    """ "0-4" (inclusive range), "0,3,7" or a mix "0-2,9"; seeds 0..MAX_SEED, at most MAX_SEEDS of them."""
    from bimrobot.assembly.env import MAX_SEED

    seeds: list[int] = []
    for part in (p.strip() for p in text.split(",") if p.strip()):
        match = re.fullmatch(r"(\d{1,12})(?:-(\d{1,12}))?", part)
        if not match or (match[2] is not None and int(match[2]) < int(match[1])):
            raise InputError(f"--seeds: cannot read {part!r}; write e.g. 0-4 or 0,3,7")
        first = int(match[1])
        last = int(match[2]) if match[2] is not None else first
        if last > MAX_SEED:
            raise InputError(f"--seeds: {part!r} goes beyond the largest seed, {MAX_SEED}")
        if last - first + 1 + len(seeds) > MAX_SEEDS:
            raise InputError(f"--seeds: {text!r} asks for more than {MAX_SEEDS} seeds")
        known = set(seeds)
        seeds += [s for s in range(first, last + 1) if s not in known]
    if not seeds:
        raise InputError("--seeds is empty")
    return seeds


def parse_timesteps(text: str, option: str = "--timesteps") -> int:
    """A step count such as "1e6", "250000" or "250k", from 1 to MAX_TIMESTEPS; ``option`` names it in errors."""
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][0-9]+)?)\s*([kKmM]?)\s*", text)
    if not match:
        raise InputError(f"{option}: cannot read {text!r} as a number of env steps; write e.g. 1e6, 250k or 250000")
    value = float(match[1]) * {"": 1, "k": 1e3, "m": 1e6}[match[2].lower()]  # 1e400 is inf: refused below
    if not value >= 1:
        raise InputError(f"{option}: a number of env steps must be >= 1, got {text!r}")
    if value > MAX_TIMESTEPS:
        raise InputError(f"{option}: {text!r} env steps is more than the {MAX_TIMESTEPS:.0e} a run may take")
    return int(value)


def parse_timesteps_per_env(text: str | None) -> dict[str, int]:
    """ "E1=1e5,E4=2e6" -> {"E1": 100000, "E4": 2000000}; keys E1..E4 or a full setting like E3S2."""
    budgets: dict[str, int] = {}
    for part in (p.strip() for p in (text or "").split(",") if p.strip()):
        key, sep, value = part.partition("=")
        key = key.strip().upper()
        if not sep or not re.fullmatch(r"E[1-4](S[1-4])?", key):
            raise InputError(f"--timesteps-per-env: cannot read {part!r}; write e.g. E1=1e5,E4=2e6")
        budgets[key] = parse_timesteps(value, f"--timesteps-per-env {key}")
    return budgets


@dataclass
class BenchmarkSpec:
    """The grid and how to run it. ``timesteps`` is the default budget; ``budgets`` per env or setting."""

    settings: list[str]
    algos: list[str]
    seeds: list[int]
    timesteps: int
    budgets: dict[str, int] = field(default_factory=dict)
    profile: str = "thesis"
    eval_episodes: int = 20
    threads: int = 1
    shaping: float = 0.0
    shaping_metric: str = "path"
    overrides: dict[str, dict[str, Any]] = field(default_factory=dict)  # per algorithm

    def budget(self, setting: str) -> int:
        return self.budgets.get(setting, self.budgets.get(setting[:2], self.timesteps))

    def configs(self) -> list[TrainConfig]:
        """Every run of the grid, seed by seed (all settings and algorithms of the first seed, then the next)
        and the cheapest settings first, so that an interrupted grid still covers every cell."""
        return [
            TrainConfig(setting, algo, self.budget(setting), seed, self.profile, dict(self.overrides.get(algo, {})),
                        self.eval_episodes, checkpoint_every=max(self.budget(setting) // 4, 1), threads=self.threads,
                        shaping=self.shaping, shaping_metric=self.shaping_metric)
            for seed in self.seeds
            for setting in self.settings
            for algo in self.algos
        ]


def _run_one(config: TrainConfig, runs_dir: str) -> dict[str, Any]:
    """Worker: train one run (or read it when already finished); its results and learning curve."""
    run_dir = Path(runs_dir) / config.run_name
    if not (run_dir / "results.json").is_file():
        train(config, runs_dir, keep_earlier=False)
    results = json.loads((run_dir / "results.json").read_text())
    results["episodes"] = read_episodes(run_dir)
    results["episode_wall_s"] = read_episode_wall_seconds(run_dir)
    return results


def _check_same_run(config: TrainConfig, run_dir: Path) -> None:
    """A finished run is reused only if it was trained as ``config`` asks; otherwise a clear error."""
    stored = json.loads((run_dir / "config.json").read_text())
    stored.setdefault("shaping_metric", "manhattan")  # run dirs from before the path metric existed
    for key in ("timesteps", "profile", "shaping", "shaping_metric", "overrides"):
        if key == "shaping_metric" and not config.shaping:
            continue
        if stored.get(key) != getattr(config, key):
            raise InputError(
                f"{run_dir} was trained with {key}={stored.get(key)!r}, not {getattr(config, key)!r}: "
                "use another output folder (-o) or remove that run dir"
            )


def read_episodes(run_dir: Path) -> list[tuple[int, float]]:
    """(timestep, return) of every training episode of a run dir."""
    with open(run_dir / "episodes.csv", newline="") as handle:
        return [(int(row["timestep"]), float(row["return"])) for row in csv.DictReader(handle)]


def read_episode_wall_seconds(run_dir: Path) -> list[float]:
    """Wall-clock seconds since the start of training at which each training episode ended."""
    with open(run_dir / "episodes.csv", newline="") as handle:
        return [float(row["wall_s"]) for row in csv.DictReader(handle)]


def _exit_on_sigterm(signum: int, frame: Any) -> None:
    raise SystemExit(128 + signum)


def _worker_exits_on_sigterm() -> None:
    """Pool initializer: a terminated worker unwinds, so its unfinished run dir is removed, not left half-written."""
    signal.signal(signal.SIGTERM, _exit_on_sigterm)


@contextlib.contextmanager
def _sigterm_stops_the_pool():
    """While the grid runs, SIGTERM leaves the ``with pool`` block like Ctrl-C does, which terminates the
    workers too; by default SIGTERM kills only this process and the spawned workers would train on."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _exit_on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


RAY_SOCKET_ROOM = 66
"""Bytes Ray adds to its temporary folder for a socket: ``/session_<date>_<time>_<us>_<pid>/sockets/plasma_store``
(63 with a 5-digit pid, 65 with a 7-digit one; a byte of margin)."""


@contextlib.contextmanager
def _pool(workers: int, ray_address: str | None):
    if ray_address is None:
        with multiprocessing.get_context("spawn").Pool(
            processes=workers, initializer=_worker_exits_on_sigterm, maxtasksperchild=1
        ) as pool:
            yield pool
        return
    from bimrobot.core.errors import require_extra

    ray = require_extra("ray", "ray")
    from ray.util.multiprocessing import Pool as RayPool

    if ray_address != "local":  # "auto" or host:port joins a running cluster (its session folder is its own)
        with RayPool(processes=workers, ray_address=ray_address) as pool:
            yield pool
        return
    # "local" starts a Ray instance on this machine: its session folder (logs, sockets) goes to a temporary
    # folder of this benchmark, removed when the instance stops, not to <tmp>/ray where it would stay
    # (issue 35: in the command's own temporary folder, one level deeper than /tmp, Ray's plasma_store socket
    # took 112 bytes, over the 107 a Unix socket's path may have, and `--ray local` failed)
    from bimrobot.core.cores import socket_folder

    folder = socket_folder(RAY_SOCKET_ROOM)
    try:
        ray.init(_temp_dir=folder, include_dashboard=False, log_to_driver=False)
        with RayPool(processes=workers) as pool:
            yield pool
    finally:
        ray.shutdown()
        shutil.rmtree(folder, ignore_errors=True)


def run_benchmark(spec: BenchmarkSpec, out: str | Path, workers: int = 1, ray_address: str | None = None,
                  command: str = "") -> list[dict[str, Any]]:
    """Run the grid (finished runs are reused) and keep ``out``'s summary up to date; all runs' results."""
    configs = spec.configs()
    for config in configs:  # bad options fail here, not in a worker after the folder exists
        config.validate()
    with _sigterm_stops_the_pool(), benchmark_folder(out) as folder:
        runs_dir = folder / "runs"
        for config in configs:
            if (runs_dir / config.run_name / "results.json").is_file():
                _check_same_run(config, runs_dir / config.run_name)
        results: list[dict[str, Any]] = []
        start = time.perf_counter()
        log.info("benchmark: %d runs on %d workers -> %s", len(configs), workers, out)
        with _pool(workers, ray_address) as pool:
            pending = [pool.apply_async(_run_one, (config, str(runs_dir))) for config in configs]
            for config, job in zip(configs, pending):
                results.append(job.get())
                log.info("finished %s (%d/%d, %.0f s)", config.run_name, len(results), len(configs),
                         time.perf_counter() - start)
                write_summary(folder, spec, results, command)
            # a clean shutdown: leaving the block would terminate() the workers, and a SIGTERM reaching one
            # that is already exiting prints a spurious SystemExit traceback from its atexit handlers
            pool.close()
            pool.join()
    return results


def summarise_finished(spec: BenchmarkSpec, out: str | Path, command: str = "") -> list[dict[str, Any]]:
    """Rewrite ``out``'s summary from the grid's runs that have finished, training nothing. The command
    line shown stays the one that trained the grid (from ``grid.json``) when there is one."""
    for config in spec.configs():
        config.validate()
    with benchmark_folder(out, create=False) as folder:
        previous = folder / "grid.json"
        if previous.is_file():
            try:
                command = json.loads(previous.read_text()).get("command") or command
            except (ValueError, AttributeError):
                pass  # a damaged grid.json is rewritten below
        results = []
        for config in spec.configs():
            run_dir = folder / "runs" / config.run_name
            if (run_dir / "results.json").is_file():
                _check_same_run(config, run_dir)
                results.append(_run_one(config, str(folder / "runs")))
        if not results:
            raise InputError(f"{Path(out) / 'runs'} holds no finished run of this grid")
        write_summary(folder, spec, results, command)
    return results


def time_to_score(episodes: list[tuple[int, float]], setting: str, goal: float = SCORE_GOAL,
                  window: int = LAST_EPISODES) -> int | None:
    """Env steps until the mean of the last ``window`` training episodes first reached a score of ``goal``."""
    index = episode_reaching_score(episodes, setting, goal, window)
    return None if index is None else int(episodes[index][0])


def episode_reaching_score(episodes: list[tuple[int, float]], setting: str, goal: float = SCORE_GOAL,
                           window: int = LAST_EPISODES) -> int | None:
    """Index of the training episode after which the mean of the last ``window`` first scored ``goal``."""
    from bimrobot.assembly.planner import reference_returns

    ref = reference_returns(setting)
    threshold = ref["random"] + goal * (ref["optimal"] - ref["random"])
    returns = np.array([r for _, r in episodes], dtype=float)
    if len(returns) < window:
        return None
    rolling = np.convolve(returns, np.ones(window) / window, mode="valid")
    reached = np.flatnonzero(rolling >= threshold)
    return int(reached[0] + window - 1) if len(reached) else None


def _mean_se(values: Iterable[float | None]) -> tuple[float, float, int] | None:
    data = np.array([v for v in values if v is not None], dtype=float)
    if len(data) == 0:
        return None
    se = float(data.std(ddof=1) / np.sqrt(len(data))) if len(data) > 1 else None  # undefined for one seed
    return float(data.mean()), se, len(data)


def aggregate(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (setting, algo): mean +- SE over seeds of the train and eval returns and their scores."""
    from bimrobot.rl.train import score

    cells: dict[tuple[str, str], list[dict]] = {}
    for result in results:
        cells.setdefault((result["setting"], result["algo"]), []).append(result)
    rows = []
    for (setting, algo), runs in sorted(cells.items()):
        train_stats = _mean_se(r["train_last100_mean"] for r in runs)
        eval_stats = _mean_se(r["eval_mean"] for r in runs)
        indices = [episode_reaching_score(r.get("episodes", []), setting) for r in runs]
        reached = [r["episodes"][i][0] for r, i in zip(runs, indices) if i is not None]
        reached_wall = [r["episode_wall_s"][i] for r, i in zip(runs, indices) if i is not None and r.get("episode_wall_s")]
        rows.append({
            "setting": setting,
            "algo": algo,
            "seeds": len(runs),
            "timesteps": int(np.mean([r["timesteps"] for r in runs])),
            "train_mean": train_stats[0] if train_stats else None,
            "train_se": train_stats[1] if train_stats else None,
            "train_score": score(setting, train_stats[0]) if train_stats else None,
            "eval_mean": eval_stats[0] if eval_stats else None,
            "eval_se": eval_stats[1] if eval_stats else None,
            "eval_score": score(setting, eval_stats[0]) if eval_stats else None,
            "seeds_reaching_0.9": len(reached),
            "median_steps_to_0.9": int(np.median(reached)) if reached else None,
            "median_wall_s_to_0.9": float(np.median(reached_wall)) if reached_wall else None,
            "train_hours": sum(r["train_seconds"] for r in runs) / 3600,
        })
    return rows


def _fmt(mean: float | None, se: float | None, score: float | None) -> str:
    if mean is None:
        return "n/a"
    spread = f" ± {se:.2f}" if se is not None else ""
    return f"{mean:.2f}{spread} ({score:.2f})"


def markdown_table(rows: list[dict[str, Any]], spec: BenchmarkSpec, command: str) -> str:
    """Table 6.1's layout (settings x algorithms) twice, for training and greedy evaluation, plus the goal check."""
    by_cell = {(r["setting"], r["algo"]): r for r in rows}
    lines = _table_preamble(rows, spec, command)
    for title, key in (("Last 100 training episodes", "train"), ("20 greedy evaluation episodes", "eval")):
        lines += _score_table(title, key, by_cell, spec)
    lines += _goal_check(by_cell, spec)
    return "\n".join(lines)


def _table_preamble(rows: list[dict[str, Any]], spec: BenchmarkSpec, command: str) -> list[str]:
    """The lines above the tables: heading, command, profile, shaping, seeds, budgets, runs finished."""
    finished = sum(r["seeds"] for r in rows)
    total = len(spec.settings) * len(spec.algos) * len(spec.seeds)
    return [
        f"<!-- {signature('rl benchmark table')} -->",
        _LEGACY_HEADING,
        "",
        f"Command: `{command}`" if command else "",
        "",
        f"Hyperparameter profile `{spec.profile}`"
        + (f", overrides {spec.overrides}" if spec.overrides else "")
        + (f"; potential-based distance shaping of the training reward ({spec.shaping_metric} distance), scale "
           f"{spec.shaping:g} (reported returns "
           "are the environment's own)" if spec.shaping else "; no reward shaping")
        + f"; seeds {spec.seeds}; env steps per run: " + ", ".join(f"{s} {spec.budget(s):,}" for s in spec.settings) + ".",
        f"Finished runs: {finished} of {total}"
        + ("." if finished == total else "; cells marked [n/m seeds] have fewer seeds, 'not run' cells none."),
        "Cells: mean ± standard error over seeds of the mean return, (normalised score "
        "`(return - random) / (optimal - random)` of that mean). Best per row in bold.",
        "",
    ]


def _score_table(title: str, key: str, by_cell: dict, spec: BenchmarkSpec) -> list[str]:
    """One settings x algorithms table of ``key`` (train or eval) returns and scores, the best per row in bold."""
    algos = list(spec.algos)
    lines = [f"## {title}", "", "| setting | " + " | ".join(algos) + " |", "|---" * (len(algos) + 1) + "|"]
    for setting in spec.settings:
        cells = [by_cell.get((setting, a)) for a in algos]
        scores = [c[f"{key}_score"] if c and c[f"{key}_score"] is not None else -np.inf for c in cells]
        best = int(np.argmax(scores))
        texts = []
        for i, cell in enumerate(cells):
            text = _fmt(cell[f"{key}_mean"], cell[f"{key}_se"], cell[f"{key}_score"]) if cell else "not run"
            if cell and i == best and scores[i] > -np.inf:
                text = f"**{text}**"
            if cell and cell["seeds"] < len(spec.seeds):
                text += f" [{cell['seeds']}/{len(spec.seeds)} seeds]"
            texts.append(text)
        lines.append(f"| {setting} | " + " | ".join(texts) + " |")
    lines.append("")
    return lines


def _goal_check(by_cell: dict, spec: BenchmarkSpec) -> list[str]:
    """The best algorithm per setting against the goal score and the thesis' best cell."""
    lines = [
        "## Goal check: best algorithm per setting against the thesis' best cell",
        "",
        "| setting | best algorithm | score (train, last 100) | score (greedy eval) | thesis best | >= 0.9 | beats thesis "
        "| seeds reaching 0.9 | median env steps to 0.9 | median wall time to 0.9 |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for setting in spec.settings:
        candidates = [by_cell[(setting, a)] for a in spec.algos if (setting, a) in by_cell]
        if not candidates:
            lines.append(f"| {setting} | not run | | | {THESIS_BEST_SCORE[setting]:.2f} | | | | | |")
            continue
        best = max(candidates, key=lambda c: max(c["train_score"] or -np.inf, c["eval_score"] or -np.inf))
        best_score = max(best["train_score"] or -np.inf, best["eval_score"] or -np.inf)
        thesis = THESIS_BEST_SCORE[setting]
        steps, wall = best["median_steps_to_0.9"], best["median_wall_s_to_0.9"]
        lines.append(
            f"| {setting} | {best['algo']} | {_num(best['train_score'])} | {_num(best['eval_score'])} | {thesis:.2f} "
            f"| {'yes' if best_score >= SCORE_GOAL else 'no'} | {'yes' if best_score > thesis else 'no'} "
            f"| {best['seeds_reaching_0.9']}/{best['seeds']} | {f'{steps:,}' if steps is not None else '-'} "
            f"| {f'{wall:.0f} s' if wall is not None else '-'} |"
        )
    lines.append("")
    return lines


def _num(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2f}"


def write_summary(out: Path, spec: BenchmarkSpec, results: list[dict[str, Any]], command: str = "") -> None:
    """Rewrite table.md, table.csv, grid.json and learning_curves.png from the results so far."""
    from bimrobot.rl.plots import plot_learning_curves

    rows = aggregate(results)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)

    def write_csv(tmp: Path) -> None:
        with open(tmp, "w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)

    runs = [{k: v for k, v in r.items() if k not in ("episodes", "episode_wall_s")} for r in results]
    grid = {"generator": signature("rl benchmark"), "command": command, "spec": asdict(spec), "runs": runs}
    _replace_file(out / "table.md", lambda tmp: tmp.write_text(markdown_table(rows, spec, command)))
    _replace_file(out / "table.csv", write_csv)
    _replace_file(out / "grid.json", lambda tmp: tmp.write_text(json.dumps(grid, indent=2)))
    _replace_file(out / "learning_curves.png",
                  lambda tmp: plot_learning_curves(results, tmp, settings=spec.settings, algos=spec.algos))


def _replace_file(path: Path, write: Callable[[Path], Any]) -> None:
    """Write ``path`` through a temporary sibling renamed onto it. The summary files are part of the
    benchmark folder, which :func:`benchmark_folder` has checked to be bimrobot's, so they are replaced
    after every finished run without a line each on stderr."""
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        write(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
