"""Market vs baselines vs an optimal CP-SAT schedule on the same build (makespans in seconds)."""

from __future__ import annotations

import csv
import json
import logging
import statistics
from pathlib import Path
from typing import Callable

from bimrobot.site.fleet import Fleet
from bimrobot.site.site import Site
from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import BimrobotError
from bimrobot.sco.build import SmartModel

log = logging.getLogger(__name__)

#: The largest build given to CP-SAT by default (tasks; `allocators --max-tasks`): every shared real model (at
#: most 344 tasks per joint) gets CP-SAT's best schedule and lower bound within the time limit, as in `plan
#: benchmark`; far larger builds overrun the limit (a 1,000-component frame: 629 s of wall for 60 s), so they
#: get no CP-SAT row.
ALLOCATORS_MAX_TASKS = 400


def compare_allocators(
    smart_model: Callable[[], SmartModel],
    fleet: Fleet,
    site: Site | None,
    elevations: list[float],
    seeds: int = 5,
    optimal: bool = True,
    time_limit_s: float = 60.0,
    max_tasks: int = ALLOCATORS_MAX_TASKS,
    **solver_limits,
) -> list[dict]:
    """One row per allocator: makespan (s) and its gap to the CP-SAT optimum (%) when that is known, else
    to CP-SAT's lower bound. ``solver_limits``: more of :func:`~bimrobot.planning.optimal.solve_optimal`'s
    limits (``workers``, ``deterministic_limit``: a solve bounded by CP-SAT's own work, not wall time).

    The market runs with per-component / per-joint tasks (``per_node=False``), the task graph the CP-SAT
    optimum is built on, so that the gaps compare like with like.

    ``smart_model`` builds the SmartModel, once: every run works on its own copy (:func:`simulate`).
    """
    smart = smart_model()
    rows = []
    for name in ("least-cost", "quickest-finish", "greedy-nearest"):
        result = simulate(smart, fleet, site, name, 0, (), elevations, per_node=False)
        rows.append({"allocator": name, "makespan_s": round(result.makespan, 2), "runs": 1, "steps": result.steps})
    randoms = [simulate(smart, fleet, site, "random", seed, (), elevations, per_node=False).makespan for seed in range(seeds)]
    rows.append({
        "allocator": f"random (mean of {seeds} seeds)",
        "makespan_s": round(statistics.fmean(randoms), 2),
        "runs": seeds,
        "min_s": round(min(randoms), 2),
        "max_s": round(max(randoms), 2),
    })
    best = None
    if optimal:
        from bimrobot.planning.optimal import solve_optimal

        try:
            schedule = solve_optimal(smart, fleet, site, elevations, time_limit_s=time_limit_s, max_tasks=max_tasks,
                                     **solver_limits)
        except BimrobotError as exc:
            log.warning("no CP-SAT optimum: %s", exc)
            rows.append({"allocator": "optimal (CP-SAT)", "makespan_s": None, "note": str(exc)})
        else:
            proven = schedule.status == "OPTIMAL"
            rows.append({
                "allocator": "optimal (CP-SAT)" if proven else "best found (CP-SAT, not proven)",
                "makespan_s": round(schedule.makespan, 2),
                "lower_bound_s": round(schedule.lower_bound, 2),
                "status": schedule.status,
                "tasks": schedule.tasks,
            })
            best = schedule.lower_bound if not proven else schedule.makespan
    if best:  # the proven optimum, or else CP-SAT's lower bound (then gaps are upper bounds of the true gaps)
        for row in rows:
            if row.get("makespan_s") is not None:
                row["gap_pct"] = round(100.0 * (row["makespan_s"] - best) / best, 2)
    return rows


def format_markdown(rows: list[dict], title: str) -> str:
    """A Markdown table of the comparison."""
    lines = [f"### {title}", "", "| allocator | makespan (s) | gap to optimum / bound |", "|---|---:|---:|"]
    for row in rows:
        makespan = "-" if row.get("makespan_s") is None else f"{row['makespan_s']:.1f}"
        if "min_s" in row:
            makespan += f" ({row['min_s']:.0f}-{row['max_s']:.0f})"
        gap = f"{row['gap_pct']:+.1f} %" if "gap_pct" in row else "-"
        if "lower_bound_s" in row and row.get("status") != "OPTIMAL":
            gap = f"lower bound {row['lower_bound_s']:.1f} s"
        lines.append(f"| {row['allocator']} | {makespan} | {gap} |")
    return "\n".join(lines)


def write_outputs(rows: list[dict], table: str, folder: Path) -> list[Path]:
    """allocators.csv, allocators.md and allocators.json in ``folder`` (a fresh folder from
    :func:`bimrobot.core.io.atomic_output_dir`, which owns the output policy); returns the paths."""
    folder = Path(folder)
    write_csv(rows, folder / "allocators.csv")
    (folder / "allocators.md").write_text(table + "\n", encoding="utf-8")
    (folder / "allocators.json").write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
    plot_makespans(rows, table.splitlines()[0].lstrip("# "), folder / "allocators.png")
    return [folder / name for name in ("allocators.csv", "allocators.md", "allocators.json", "allocators.png")]


def plot_makespans(rows: list[dict], title: str, path: Path) -> None:
    """allocators.png: one bar per allocator, its makespan (s; the min-max of repeated runs as an error
    bar), the proven optimum or CP-SAT's lower bound as a dashed line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bimrobot.core.io import signature

    shown = [r for r in rows if r.get("makespan_s") is not None]
    figure, ax = plt.subplots(figsize=(8, 1.0 + 0.45 * max(len(shown), 1)))
    names = [r["allocator"] for r in shown]
    values = [r["makespan_s"] for r in shown]
    errors = [[r["makespan_s"] - r.get("min_s", r["makespan_s"]) for r in shown],
              [r.get("max_s", r["makespan_s"]) - r["makespan_s"] for r in shown]]
    ax.barh(names, values, xerr=errors, color="C0", capsize=3)
    bounds = [r["lower_bound_s"] for r in shown if r.get("lower_bound_s") is not None]
    if bounds:
        ax.axvline(max(bounds), color="0.3", linestyle="--", linewidth=1, label="optimum / lower bound")
        ax.legend(loc="lower right", fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("makespan (s)")
    ax.set_title(title, fontsize=10)
    ax.grid(axis="x", alpha=0.3)
    figure.tight_layout()
    figure.savefig(path, dpi=110, format="png", metadata={"Comment": signature("allocators makespans")})
    plt.close(figure)


def write_csv(rows: list[dict], path: Path) -> None:
    fields = ["allocator", "makespan_s", "gap_pct", "runs", "min_s", "max_s", "lower_bound_s", "status", "tasks", "steps", "note"]
    with open(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
