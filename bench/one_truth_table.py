"""Issue 34's before/after table: what each shared model builds into, per version of bimrobot.

    .venv/bin/python bench/one_truth_table.py run MODEL_DIR --label after --out after.json
    PYTHONPATH=/tmp/wt34/src .venv/bin/python bench/one_truth_table.py run MODEL_DIR --label before \
        --out before.json                 # the version whose src/ is first on PYTHONPATH
    .venv/bin/python bench/one_truth_table.py table before.json after.json    # the Markdown table

``run`` takes every ``*.ifc``/``*.ifczip`` of MODEL_DIR, smallest file first, and runs on each, as a user
would (the CLI in a child process with this process's ``PYTHONPATH``, so the version under test):
``inspect --json`` (the units), ``simulate --fleet site-crane`` (again with ``--prebuilt
'IfcFooting,IfcSlab,IfcWall'`` when the fleet cannot build the model, as tests/test_real_models.py does),
``graph --schedule`` and ``rcan run --graph --backend sim`` on that schedule. From the outputs it records
per model: length and mass unit, components and assembly units built, assembly points by source (model
fasteners or assumed per joint), the bolting share of the work (the schedule's assemble durations over
all its durations, i.e. over the robots' total busy time), and the makespans of ``simulate`` and of
RCAN. A command that runs longer than ``--timeout`` seconds leaves the model as "not run (time)".
Results are written after each model (into ``--out``, replacing that model's earlier row and keeping
the others), so a long run can be stopped, resumed model by model (``--only``) and still tabled.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FLEET = "site-crane"
PREBUILT = "IfcFooting,IfcSlab,IfcWall"  # what tests/test_real_models.py falls back to
SIMULATE = ("--no-progress", "--no-gantt")


def bimrobot(args: list[str], cwd: Path, timeout_s: float) -> subprocess.CompletedProcess | None:
    """Run ``python -m bimrobot ARGS`` in ``cwd`` (this environment's PYTHONPATH); None past ``timeout_s``."""
    try:
        return subprocess.run([sys.executable, "-m", "bimrobot", *args], cwd=cwd, capture_output=True,
                              text=True, timeout=timeout_s, env=dict(os.environ))
    except subprocess.TimeoutExpired:
        return None


def bolting_share(schedule: Path) -> float:
    """Assemble rows' seconds over all rows' seconds of a schedule CSV (0..1): the share of the robots'
    busy time that is bolting (or welding)."""
    with open(schedule, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    total = sum(float(r["Duration"]) for r in rows)
    assemble = sum(float(r["Duration"]) for r in rows if r["Activity"] == "assemble")
    return assemble / total if total else 0.0


def points_by_source(smart: dict, summary: dict) -> dict:
    """{'model': points, 'assumed': points} from a simulate summary. Versions before issue 34 give no
    split: there a joint inferred from geometry got 4 points on each of its 2 connection nodes (reported
    here as assumed, ``derived``) and the rest came from the model's relations."""
    split = summary.get("assembly_points_by_source") or smart.get("assembly_points_by_source")
    if split:
        return {"model": split["model"]["points"], "assumed": split["assumed"]["points"], "derived": False}
    total = int(smart.get("assembly_points", 0))
    if "inferred" in str(smart.get("connection_source", "")) and "IfcRel" not in str(smart.get("connection_source")):
        assumed = total
    else:
        assumed = min(total, 8 * len(smart.get("inferred_joints", [])))
    return {"model": total - assumed, "assumed": assumed, "derived": True}


def one_model(model: Path, work: Path, timeout_s: float) -> dict:
    """Run the chain on ``model`` in ``work``; return its row (``status`` says how far it got)."""
    row: dict = {"model": model.name, "status": "ok"}
    started = time.perf_counter()
    inspected = bimrobot(["inspect", str(model), "--json", "--no-progress"], work, timeout_s)
    if inspected is None:
        return {**row, "status": "not run (time)"}
    if inspected.returncode == 0:
        units = json.loads(inspected.stdout).get("units", {})
        row["length_unit"], row["mass_unit"] = units.get("length"), units.get("mass")
    sim = ["simulate", str(model), "--fleet", FLEET, "-o", "sim", *SIMULATE]
    prebuilt: list[str] = []
    done = bimrobot(sim, work, timeout_s)
    if done is not None and done.returncode == 2 and "cannot build" in done.stderr:
        prebuilt = ["--prebuilt", PREBUILT]
        done = bimrobot([*sim, *prebuilt], work, timeout_s)
    if done is None:
        return {**row, "status": "not run (time)"}
    if done.returncode != 0:
        return {**row, "status": "simulate refused: " + done.stderr.strip().splitlines()[-1][:160]}
    summary = json.loads((work / "sim" / "summary.json").read_text())
    smart = summary["smart_components"]
    row.update(prebuilt=bool(prebuilt), components=smart["components"], units=smart.get("assembly_units", 0),
               points=points_by_source(smart, summary), connection_source=smart.get("connection_source"),
               bolting_share=bolting_share(work / "sim" / "schedule.csv"),
               simulate_makespan_s=summary["makespan_s"])
    graph = bimrobot(["graph", str(model), "--schedule", "sim/schedule.csv", "-o", "graph.ttl", *prebuilt], work, timeout_s)
    if graph is None or graph.returncode != 0:
        return {**row, "status": "graph: " + ("not run (time)" if graph is None else graph.stderr.strip()[-160:])}
    rcan = bimrobot(["rcan", "run", "--graph", "graph.ttl", "--capabilities", FLEET, "--backend", "sim", "--quiet",
                     "--report", "rcan.json"], work, timeout_s)
    if rcan is None:
        return {**row, "status": "rcan: not run (time)"}
    if (work / "rcan.json").exists():
        report = json.loads((work / "rcan.json").read_text())
        row["rcan_makespan_s"], row["rcan_status"] = report.get("makespan_s"), report.get("status")
    row["seconds"] = round(time.perf_counter() - started, 1)
    return row


def run(args: argparse.Namespace) -> None:
    """Every model of the folder, smallest first; the rows go to ``--out`` after each model."""
    models = sorted((p for p in Path(args.models).iterdir() if p.suffix in (".ifc", ".ifczip")),
                    key=lambda p: (p.stat().st_size, p.name))
    order = {p.name: k for k, p in enumerate(models)}
    if args.only:
        models = [p for p in models if p.name in args.only]
    out = Path(args.out)
    rows = json.loads(out.read_text())["rows"] if out.exists() else []  # earlier models' rows are kept
    for model in models:
        rows = [r for r in rows if r["model"] != model.name]
        with tempfile.TemporaryDirectory(prefix="one-truth-") as work:
            row = one_model(model, Path(work), args.timeout)
        rows = sorted([*rows, row], key=lambda r: order.get(r["model"], len(order)))  # smallest file first
        print(json.dumps(row), flush=True)
        out.write_text(json.dumps({"label": args.label, "rows": rows}, indent=1) + "\n")


def cell(row: dict | None, what: str) -> str:
    """One version's figure of ``what`` for a row, as it goes into the table."""
    if row is None or "simulate_makespan_s" not in row:
        if row is None or what != "build":
            return "-"
        return "refused" if row["status"].startswith("simulate refused") else row["status"]
    if what == "build":
        return f"{row['components']} / {row['units']}"
    if what == "points":
        p = row["points"]
        return f"{p['model']:,} / {p['assumed']:,}"
    if what == "bolting":
        return f"{100 * row['bolting_share']:.0f} %"
    if what == "simulate":
        return f"{row['simulate_makespan_s']:,.0f}"
    if what == "rcan":
        value = row.get("rcan_makespan_s")
        return row["status"] if value is None else f"{value:,.0f}"
    raise ValueError(what)


def table(args: argparse.Namespace) -> None:
    """Print the Markdown table: one line per model, each column 'before -> after'."""
    before = {r["model"]: r for r in json.loads(Path(args.before).read_text())["rows"]}
    after = {r["model"]: r for r in json.loads(Path(args.after).read_text())["rows"]}
    print("| model | length, mass unit | components / units built | assembly points, model / assumed "
          "| bolting share of the work | simulate makespan, s | RCAN makespan (sim), s |")
    print("|---|---|---|---|---|---|---|")
    for name in list(after) + [n for n in before if n not in after]:
        b, a = before.get(name), after.get(name)
        unit = next((f"{r['length_unit']}, {r['mass_unit']}" for r in (a, b) if r and r.get("length_unit")), "?")
        cells = [f"{cell(b, w)} -> {cell(a, w)}" for w in ("build", "points", "bolting", "simulate", "rcan")]
        prebuilt = " (prebuilt slabs, walls)" if any(r and r.get("prebuilt") for r in (a, b)) else ""
        print(f"| {name}{prebuilt} | {unit.lower()} | " + " | ".join(cells).replace("- -> -", "-") + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    go = commands.add_parser("run", help="run every model of a folder with the bimrobot on PYTHONPATH")
    go.add_argument("models", help="folder of IFC models (e.g. ../shared/data/ifc)")
    go.add_argument("--label", required=True, help="what this version is (before, after)")
    go.add_argument("--out", required=True, help="JSON file for the rows")
    go.add_argument("--only", nargs="*", help="only these model file names")
    go.add_argument("--timeout", type=float, default=300.0, help="seconds per command before 'not run (time)'")
    show = commands.add_parser("table", help="print the before/after Markdown table")
    show.add_argument("before")
    show.add_argument("after")
    args = parser.parse_args()
    (run if args.command == "run" else table)(args)


if __name__ == "__main__":
    main()
