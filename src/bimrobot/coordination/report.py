"""Outputs of a simulation run: event log (Listing 4.2 style and JSON lines), per-robot table (Table
4.2 style), summary, schedule CSV and a Gantt chart. Times in seconds."""

from __future__ import annotations

import csv
from collections import Counter
import json
from pathlib import Path

from bimrobot.coordination.schedule import write_schedule_csv
from bimrobot.coordination.run_state import SimulationResult

ACTIVITY_COLOURS = {"transport": "#4C72B0", "position": "#DD8452", "assemble": "#55A868"}


def robot_table_rows(result: SimulationResult) -> list[dict]:
    """One row per robot: tasks done (steps), busy/travel/handling time (s) and utilisation."""
    rows = []
    for robot in result.robots:
        rows.append({
            "robot": robot.name,
            "kind": robot.kind,
            "steps": robot.steps,
            "busy_time_s": round(robot.busy_time, 2),
            "travel_time_s": round(robot.travel_time, 2),
            "handling_time_s": round(robot.handling_time, 2),
            "utilisation": round(robot.busy_time / result.makespan, 4) if result.makespan > 0 else 0.0,
            "broken_at_s": "" if robot.broken_at is None else round(robot.broken_at, 2),
        })
    return rows


def request_rows(result: SimulationResult) -> list[dict]:
    """One row per task request: what it asks, why it was released (RCC / ACC / Arrived / PositionFixed),
    when it was published and which robot finished it when (times in s; re-auctioned requests keep their row)."""
    rows, by_id = [], {}
    for event in result.events:
        if event["event"] == "task_request":
            row = {"request": event["request"], "activity": event["activity"], "component": event["component"],
                   "node": event.get("node") or "", "joint": event.get("joint") or "", "release": event.get("release", ""),
                   "published_s": event["time"], "robot": "", "finished_s": ""}
            rows.append(row)
            by_id[row["request"]] = row
        elif event["event"] == "finish" and event.get("request") in by_id:
            by_id[event["request"]].update(robot=event["robot"], finished_s=event["time"])
    return rows


def summary(result: SimulationResult, unknown_weight: dict | None = None) -> dict:
    """Makespan, steps, utilisation and provenance (JSON-serialisable).

    ``unknown_weight``: what the ``--unknown-weight`` rule did
    (:meth:`bimrobot.bim.unknown_weight.UnknownWeights.as_dict`), reported as is.
    """
    from bimrobot.core.io import signature

    return {
        "generator": signature("simulate summary"),
        "model": result.model,
        "fleet": result.fleet,
        "evaluator": result.evaluator,
        "site": result.site_source,
        "model_offset_xy_m": list(result.model_offset),  # model frame -> site frame, as every output of the run
        "makespan_s": round(result.makespan, 3),
        "steps": result.steps,
        "work": "per-node" if result.per_node else "per-joint",
        "requests_by_release": dict(Counter(r["release"] for r in request_rows(result))),
        "activities": sum(1 for a in result.activities if not a.aborted),
        "aborted_activities": sum(1 for a in result.activities if a.aborted),
        "fleet_utilisation": round(result.utilisation, 4),
        "floor_finish_s": [round(t, 3) for t in result.floor_finish],
        "breakdowns": [{"robot": b[0], "time_s": b[1], "repair_s": b[2] if len(b) > 2 else None} for b in result.breakdowns],
        "robots": robot_table_rows(result),
        "unknown_weight": unknown_weight,
        "smart_components": result.smart_summary,
        "assembly_points_by_source": (result.smart_summary or {}).get("assembly_points_by_source"),  # model / assumed
    }


def format_robot_table(result: SimulationResult) -> str:
    """A plain-text table like the thesis' Table 4.2 (steps and time per robot, then the total)."""
    lines = [f"{'robot':<22} {'kind':<18} {'steps':>5} {'busy s':>10} {'util.':>6}"]
    for row in robot_table_rows(result):
        lines.append(
            f"{row['robot']:<22} {row['kind']:<18} {row['steps']:>5} {row['busy_time_s']:>10.1f} {row['utilisation']:>6.1%}"
        )
    lines.append(f"{'overview':<22} {'(allocation rounds)':<18} {result.steps:>5} {result.makespan:>10.1f} {result.utilisation:>6.1%}")
    return "\n".join(lines)


def plot_gantt(result: SimulationResult, path: Path) -> None:
    """Gantt chart PNG: one row per robot, bars coloured by activity, aborted work hatched."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    scale, unit = time_unit(result.makespan)
    names = [r.name for r in result.robots]
    row_of = {name: i for i, name in enumerate(names)}
    fig, ax = plt.subplots(figsize=(11, 1.2 + 0.55 * len(names)))
    for activity in result.activities:
        ax.barh(
            row_of[activity.robot],
            activity.duration / scale,
            left=activity.start / scale,
            height=0.6,
            color=ACTIVITY_COLOURS[activity.activity],
            edgecolor="black" if activity.aborted else "white",
            hatch="//" if activity.aborted else None,
            alpha=0.5 if activity.aborted else 1.0,
            linewidth=0.3,
        )
    for robot in result.robots:
        if robot.broken_at is not None:
            ax.plot([robot.broken_at / scale], [row_of[robot.name]], marker="x", color="red", markersize=10)
    ax.set_yticks(range(len(names)), names)
    ax.invert_yaxis()
    # floor boundaries: when each floor (but the last) was complete, the next one could start
    for floor, finish in enumerate(result.floor_finish[:-1], start=1):
        ax.axvline(finish / scale, color="0.3", linestyle="--", linewidth=0.8)
        ax.annotate(f"floor {floor} done", (finish / scale, -0.6), fontsize=7, ha="left", va="bottom",
                    xytext=(2, 0), textcoords="offset points", annotation_clip=False)
    ax.set_xlabel(f"time from the start of the build ({unit})")
    makespan = f"{result.makespan:.0f} s" if unit == "s" else f"{result.makespan / scale:.1f} {unit}"
    ax.set_title(f"{Path(result.model).name}: fleet {result.fleet}, {result.evaluator}, makespan {makespan}")
    handles = [Patch(color=c, label=a) for a, c in ACTIVITY_COLOURS.items()]
    if any(a.aborted for a in result.activities):
        handles.append(Patch(facecolor="white", edgecolor="black", hatch="//", label="aborted (breakdown)"))
    ax.legend(handles=handles, loc="lower right", fontsize=8)
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def time_unit(seconds: float) -> tuple[float, str]:
    """(seconds per unit, unit) for a time axis reaching ``seconds``: s up to 2 h, h up to 3 days, else d."""
    if seconds <= 2 * 3600:
        return 1.0, "s"
    if seconds <= 3 * 86400:
        return 3600.0, "h"
    return 86400.0, "d"


def write_outputs(result: SimulationResult, out_dir: Path, gantt: bool = True, unknown_weight: dict | None = None) -> list[Path]:
    """Write every output file into ``out_dir``; returns the paths written.

    ``out_dir`` is a fresh folder from :func:`bimrobot.core.io.atomic_output_dir`, which applies the output
    policy (nothing here replaces a file bimrobot did not write). ``unknown_weight``: see :func:`summary`.
    """
    out_dir = Path(out_dir)
    (out_dir / "events.log").write_text("\n".join(result.log_lines) + "\n", encoding="utf-8")
    with open(out_dir / "events.jsonl", "w", encoding="utf-8") as handle:
        for event in result.events:
            handle.write(json.dumps(event) + "\n")
    with open(out_dir / "robots.csv", "w", newline="", encoding="utf-8") as handle:
        rows = robot_table_rows(result)
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    (out_dir / "summary.json").write_text(json.dumps(summary(result, unknown_weight), indent=2) + "\n", encoding="utf-8")
    (out_dir / "robots.txt").write_text(format_robot_table(result) + "\n", encoding="utf-8")
    (out_dir / "states.json").write_text(
        json.dumps({gid: [[round(t, 3), s] for t, s in h] for gid, h in result.state_history.items()}, indent=1) + "\n",
        encoding="utf-8",
    )
    write_schedule_csv(result.activities, out_dir / "schedule.csv")
    fields = ["request", "activity", "component", "node", "joint", "release", "published_s", "robot", "finished_s"]
    with open(out_dir / "requests.csv", "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=fields)
        writer.writeheader()
        writer.writerows(request_rows(result))
    paths = [out_dir / n for n in ("events.log", "events.jsonl", "robots.csv", "robots.txt", "summary.json", "states.json",
                                   "schedule.csv", "requests.csv")]
    if gantt:
        plot_gantt(result, out_dir / "gantt.png")
        paths.append(out_dir / "gantt.png")
    return paths
