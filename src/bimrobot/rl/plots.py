"""Learning curves like the thesis' fig. 6.15: one panel per setting, one line per algorithm.

A line is the mean over seeds (their number per algorithm, in legend order, in the panel title) of each run's smoothed training return (mean of the last ``window`` finished
episodes at each point of a common env-step grid), the band its standard error over seeds; dashed lines
mark the planner's optimal return and the random policy's mean return.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bimrobot.core.io import signature  # noqa: E402

CURVE_POINTS = 60
WINDOW = 20


def smoothed_curve(episodes: list[tuple[int, float]], grid: np.ndarray, window: int = WINDOW) -> np.ndarray:
    """At each env step of ``grid``: mean return of the last ``window`` episodes finished by then (NaN before any)."""
    if not episodes:
        return np.full(len(grid), np.nan)
    steps = np.array([t for t, _ in episodes])
    returns = np.array([r for _, r in episodes], dtype=float)
    cumulative = np.concatenate([[0.0], np.cumsum(returns)])
    finished = np.searchsorted(steps, grid, side="right")  # episodes finished by each grid point
    first = np.maximum(finished - window, 0)
    counts = finished - first
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(counts > 0, (cumulative[finished] - cumulative[first]) / counts, np.nan)


def plot_learning_curves(results: list[dict[str, Any]], path: str | Path, settings: list[str] | None = None,
                         algos: list[str] | None = None) -> None:
    """Write a PNG with one panel per setting (rows E1..E4, columns S1..S4 when all 16 are present)."""
    settings = settings or sorted({r["setting"] for r in results})
    settings = [s for s in settings if any(r["setting"] == s for r in results)]
    algos = algos or sorted({r["algo"] for r in results})
    columns = min(4, len(settings))
    rows = int(np.ceil(len(settings) / columns))
    figure, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.2 * rows), squeeze=False)
    colours = dict(zip(algos, plt.rcParams["axes.prop_cycle"].by_key()["color"] * 2))
    for ax, setting in zip(axes.flat, settings):
        _plot_setting(ax, setting, [r for r in results if r["setting"] == setting], algos, colours)
    for ax in list(axes.flat)[len(settings):]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="lower center", ncol=min(len(labels), 8), frameon=False)
    figure.tight_layout(rect=(0, 0.05, 1, 1))
    # the signature in a PNG text chunk: how bimrobot knows later that the file is its own to replace
    figure.savefig(path, dpi=110, format="png", metadata={"Comment": signature("rl benchmark learning curves")})
    plt.close(figure)


def _plot_setting(ax, setting: str, runs: list[dict[str, Any]], algos: list[str], colours: dict) -> None:
    from bimrobot.assembly.planner import reference_returns

    horizon = max((r["timesteps"] for r in runs), default=1)
    grid = np.linspace(horizon / CURVE_POINTS, horizon, CURVE_POINTS)
    seed_counts = []
    for algo in algos:
        curves = np.array([smoothed_curve(r.get("episodes", []), grid) for r in runs if r["algo"] == algo])
        if len(curves) == 0:
            continue
        seed_counts.append(str(len(curves)))
        valid = ~np.isnan(curves).all(axis=0)
        mean = np.nanmean(curves[:, valid], axis=0)
        count = (~np.isnan(curves[:, valid])).sum(axis=0)
        se = np.nanstd(curves[:, valid], axis=0, ddof=0) / np.sqrt(np.maximum(count, 1))
        ax.plot(grid[valid], mean, color=colours[algo], label=algo, lw=1.4)
        ax.fill_between(grid[valid], mean - se, mean + se, color=colours[algo], alpha=0.2, lw=0)
    ref = reference_returns(setting)
    ax.axhline(ref["optimal"], color="black", ls="--", lw=0.8, label="optimal (planner)")
    ax.axhline(ref["random"], color="grey", ls=":", lw=0.8, label="random policy")
    ax.set_title(f"{setting} (seeds: {', '.join(seed_counts)})", fontsize=10)
    ax.set_xlabel("env steps")
    ax.set_ylabel("return")
    ax.ticklabel_format(axis="x", style="sci", scilimits=(0, 0))
    ax.grid(alpha=0.3)


def plot_run_curve(returns: list[float], path: str | Path, title: str, window: int = WINDOW) -> None:
    """A run's learning curve PNG: each training episode's return (dots) and the mean of the last
    ``window`` episodes (line), against the episode number."""
    figure, ax = plt.subplots(figsize=(7, 4))
    episodes = np.arange(1, len(returns) + 1)
    if len(returns):
        values = np.asarray(returns, dtype=float)
        cumulative = np.concatenate([[0.0], np.cumsum(values)])
        first = np.maximum(episodes - window, 0)
        ax.plot(episodes, values, ".", markersize=2, alpha=0.35, color="0.45", label="episode return")
        ax.plot(episodes, (cumulative[episodes] - cumulative[first]) / (episodes - first), color="C0",
                label=f"mean of the last {window} episodes")
        ax.legend(loc="lower right", fontsize=8)
    else:
        ax.text(0.5, 0.5, "no training episode finished", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("training episode")
    ax.set_ylabel("return")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    figure.tight_layout()
    figure.savefig(path, dpi=110, format="png", metadata={"Comment": signature("rl train learning curve")})
    plt.close(figure)
