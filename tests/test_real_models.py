"""Every shared real model through every command a user would run on it, as a new user would.

Each command exits 0 or 2; exit 2 is one sentence on stderr; no command prints a traceback. The chain
per model: inspect, convert, split, simulate (the heavy generic fleet ``site-crane``), graph and rcan run
(on the schedule that simulate wrote). Skipped when ../shared is absent.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from shared_data import SHARED_IFC, shared_models

SIMULATE = ("--no-progress", "--no-gantt")
PREBUILT = "IfcFooting,IfcSlab,IfcWall"
MODELS = [path.name for path in shared_models()]

pytestmark = [
    pytest.mark.slow,  # the chain per model: up to 228 s of set-up (AC20) on CI
    pytest.mark.skipif(not MODELS, reason=f"{SHARED_IFC} is absent: the shared real models live beside the repository"),
]


def bimrobot(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """Run the CLI as a user does, in ``cwd``; return the finished process (text output)."""
    return subprocess.run(
        [sys.executable, "-m", "bimrobot", *args], cwd=cwd, capture_output=True, text=True, timeout=900
    )


def assert_clean(result: subprocess.CompletedProcess, what: str) -> None:
    """Exit 0, or exit 2 with one sentence; never a traceback."""
    assert "Traceback" not in result.stderr, f"{what} printed a traceback:\n{result.stderr[-3000:]}"
    assert result.returncode in (0, 2), f"{what} exited {result.returncode}:\n{result.stderr[-3000:]}"
    if result.returncode == 2:
        errors = [line for line in result.stderr.splitlines() if "error:" in line]
        assert len(errors) == 1, f"{what}: expected one error sentence, got:\n{result.stderr}"


@pytest.fixture(scope="module", params=MODELS)
def pipeline(request, tmp_path_factory) -> dict:
    """Run the whole chain on one model; return {command: CompletedProcess} and the work folder."""
    model = SHARED_IFC / request.param
    work = tmp_path_factory.mktemp(Path(request.param).stem)
    runs = {
        "inspect": bimrobot("inspect", str(model), "--json", "--elements", "--no-progress", cwd=work),
        "convert": bimrobot("convert", str(model), "-o", "pkg", "--no-progress", cwd=work),
        "split": bimrobot("split", str(model), "-o", "parts", "--no-progress", cwd=work),
        "simulate": bimrobot("simulate", str(model), "--fleet", "site-crane", "-o", "sim", *SIMULATE, cwd=work),
    }
    if runs["simulate"].returncode == 2 and "cannot build" in runs["simulate"].stderr:
        # Cast-in-place slabs of 25-60 t are beyond a 20 t crane: what docs/coordination.md tells the user.
        runs["simulate prebuilt"] = bimrobot("simulate", str(model), "--fleet", "site-crane", "-o", "sim",
                                             "--prebuilt", PREBUILT, *SIMULATE, cwd=work)
    schedule = work / "sim" / "schedule.csv"
    if schedule.exists():  # RCAN generated from the graph, on the fleet's robots (what `bimrobot build` runs)
        prebuilt = ["--prebuilt", PREBUILT] if "simulate prebuilt" in runs else []
        runs["graph"] = bimrobot("graph", str(model), "--schedule", str(schedule), "-o", "graph.ttl", *prebuilt, cwd=work)
        runs["rcan"] = bimrobot("rcan", "run", "--graph", "graph.ttl", "--capabilities", "site-crane", "--backend", "sim",
                                "--quiet", "--report", "rcan.json", cwd=work)
    return {"model": model, "work": work, "runs": runs}


def test_every_command_exits_cleanly(pipeline):
    for command, result in pipeline["runs"].items():
        assert_clean(result, f"{command} on {pipeline['model'].name}")


def test_the_building_is_built_and_converted(pipeline):
    """The heavy fleet builds every model that has components, and convert writes every element."""
    runs, work = pipeline["runs"], pipeline["work"]
    assert runs["inspect"].returncode == 0
    summary = json.loads(runs["inspect"].stdout)
    assert runs["convert"].returncode == 0, runs["convert"].stderr
    report = json.loads((work / "pkg" / "report.json").read_text())
    counts = report["counts"]
    assert counts["converted"] + counts["skipped"] == summary["elements"] + len(summary["skipped"])
    assert len([p for p in (work / "pkg" / "models").iterdir() if p.is_dir()]) == counts["converted"]
    if report.get("unknown_weight", {}).get("count"):
        assert report["unknown_weight"]["rule"].startswith("assume volume x 2400")
    simulated = runs.get("simulate prebuilt", runs["simulate"])
    if simulated.returncode == 2:  # the pre-flight check: one message listing what no robot can handle
        assert "cannot build" in simulated.stderr, simulated.stderr
        return
    assert "graph" in runs and runs["graph"].returncode == 0, runs.get("graph", runs["simulate"]).stderr
    assert runs["rcan"].returncode == 0, runs["rcan"].stderr
    # RCAN ends every component the way the simulation does
    simulated_states = json.loads((work / "sim" / "states.json").read_text())
    rcan_states = json.loads((work / "rcan.json").read_text())["component_states"]
    final = {gid: history[-1][1] for gid, history in simulated_states.items()}
    assert rcan_states and {gid: final[gid] for gid in rcan_states} == rcan_states, runs["rcan"].stdout


def test_the_package_is_valid_and_names_nothing_generic(pipeline):
    """convert's package (default options) says what it wrote, passes bimrobot's own checks, and gives
    no world, model or map a tool-default name ("Undefined", "Default", "Topography : Surface")."""
    from bimrobot.export.gazebo.check import problems
    from bimrobot.export.gazebo.naming import GENERIC_SITE_NAMES

    out = pipeline["work"] / "pkg"
    report = json.loads((out / "report.json").read_text())
    assert report["counts"]["converted"] > 0
    assert problems(out) == []
    assert report["world"] not in GENERIC_SITE_NAMES
    assert not [p.name for p in out.rglob("*") if p.stem.lower() in {"undefined", "default", "topography_surface"}]
    if pipeline["model"].name == "MULTICOM-trappen_bordessen.ifc":  # Tekla: site and storey "Undefined"
        assert report["world_files"] == {"sim": "worlds/multicom_trappen_bordessen.sdf"}
        assert [(m["yaml"], m["storey_name"]) for m in report["maps"]] == [("maps/storey_1.yaml", "Undefined")]
    for entry in report["maps"]:
        assert (out / entry["image"]).stat().st_size > 0


@pytest.mark.sdf
def test_the_package_passes_the_sdformat_validator(pipeline):
    """The world and every distinct model of the package through `ign sdf -k` (SDF 1.6 is checked on the
    synthetic frame in tests/export)."""
    from bimrobot.export.gazebo.check import sdf_validator, validate_world

    if sdf_validator() is None:
        pytest.skip("`ign sdf` is not installed (ignition-tools)")
    out = pipeline["work"] / "pkg"
    report = json.loads((out / "report.json").read_text())
    for world in report["world_files"].values():
        result = validate_world(out / world, out / "models")
        assert result.valid, f"{pipeline['model'].name} {world}: {result.errors}"


def test_no_output_lands_outside_the_named_folders(pipeline):
    """Commands write only where they were told: the model's own folder is untouched."""
    assert not list(pipeline["model"].parent.glob(".*.tmp"))
    names = {p.name for p in pipeline["work"].iterdir()}
    assert names <= {"pkg", "parts", "sim", "graph.ttl", "rcan.json"}, names


def test_rcan_executes_the_schedule_in_the_time_simulate_planned(pipeline):
    """One time model: RCAN's sim robots, generated from the graph alone, take the schedule's time — the
    makespan within 0.5 %, every row's start within 1 s (issue 34)."""
    import csv

    work = pipeline["work"]
    if not (work / "rcan.json").exists():
        pytest.skip(f"{pipeline['model'].name}: nothing was simulated (the fleet cannot build it)")
    with open(work / "sim" / "schedule.csv", newline="", encoding="utf-8") as handle:
        rows = {row["Identification"]: row for row in csv.DictReader(handle)}
    report = json.loads((work / "rcan.json").read_text())
    simulated = json.loads((work / "sim" / "summary.json").read_text())["makespan_s"]
    assert report["makespan_s"] == pytest.approx(simulated, rel=0.005)
    starts: dict[str, float] = {}
    for activity_id, timing in report["activities"].items():
        row = activity_id.rpartition(".")[0]
        starts[row] = min(starts.get(row, float("inf")), timing["started_s"])
    late = {row: round(start - float(rows[row]["Start"]), 3) for row, start in starts.items()
            if abs(start - float(rows[row]["Start"])) > 1.0}
    assert not late, f"rows starting more than 1 s from the schedule: {dict(list(late.items())[:5])}"


#: What each shared model builds into with `site-crane` (components, of them assembly units, makespan in s
#: as measured when pinned): a model that stops building, or whose work changes by more than a quarter,
#: fails here and the change is looked at. A new model is added with its figures.
PINNED = {
    "AC20-FZK-Haus.ifc": (66, 0, 61_207.2),
    "GEELEN-Breedplaat_V1.ifc": (25, 25, 8_594.9),
    "IfcOpenHouse_IFC4.ifc": (8, 0, 1_252.0),
    "MULTICOM-Prefab.ifc": (118, 118, 29_097.6),
    "MULTICOM-trappen_bordessen.ifc": (9, 9, 3_026.4),
    "ROOT-staal.ifczip": (78, 0, 27_602.8),
    "column-extruded-solid.ifc": (1, 0, 749.5),
    "construction-scheduling-task.ifc": (5, 0, 3_438.9),
    "ifcColumn.ifc": (2, 0, 1_122.7),
    "ifcUnit.ifc": (8, 0, 5_528.5),
}


def test_each_model_still_builds_as_pinned(pipeline):
    name, work = pipeline["model"].name, pipeline["work"]
    if name not in PINNED:
        pytest.skip(f"{name} has no pinned outcome (the fleet cannot build it, or it is new)")
    components, units, makespan = PINNED[name]
    summary = json.loads((work / "sim" / "summary.json").read_text())
    built = summary["smart_components"]
    assert (built["components"], built["assembly_units"]) == (components, units)
    assert 0.75 * makespan <= summary["makespan_s"] <= 1.25 * makespan, summary["makespan_s"]


def test_the_market_played_in_the_dispatching_environment_is_the_schedule_simulate_wrote(pipeline):
    """Issue 38: the dispatching environment, driven by the market's own awards, gives the schedule that
    simulate wrote above, row for row (identification, robot, start, finish); the model is read once more
    in this process, nothing is simulated again by the CLI."""
    import csv

    from bimrobot.planning.dispatch import DispatchEnv, MarketPolicy, play, simulate_problem

    schedule = pipeline["work"] / "sim" / "schedule.csv"
    if not schedule.exists():
        pytest.skip(f"{pipeline['model'].name}: nothing was simulated (the fleet cannot build it)")
    prebuilt = ["--prebuilt", PREBUILT] if "simulate prebuilt" in pipeline["runs"] else []
    problem = simulate_problem([str(pipeline["model"]), "--fleet", "site-crane", *prebuilt])
    total, result = play(DispatchEnv(problem, max_tasks=4096, max_edges=16384), MarketPolicy())
    with schedule.open(newline="", encoding="utf-8") as handle:
        written = [(r["Identification"], r["Robot"], float(r["Start"]), float(r["Finish"])) for r in csv.DictReader(handle)]
    assert written == [(a.id, a.robot, round(a.start, 3), round(a.finish, 3)) for a in result.activities]
    assert total == pytest.approx(-result.makespan, abs=1e-6)
