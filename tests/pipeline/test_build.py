"""`bimrobot build`: the whole pipeline in one command, atomic and resumable after a kill."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from bimrobot.cli import main

BIMROBOT = [sys.executable, "-m", "bimrobot"]


@pytest.fixture(scope="module")
def frame(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("model") / "frame.ifc"
    assert main(["example", "steel-frame", "-o", str(path)]) == 0
    return path


#: What the `built` fixture's build read: the files ifcopenshell parsed, the geometry passes over them.
READS: dict[str, list] = {"parsed": [], "geometry": []}


@pytest.fixture(scope="module")
def built(frame, tmp_path_factory) -> Path:
    """The frame built with the defaults, every parse of an IFC file and every geometry pass counted
    (the real ifcopenshell.open and geometry pass, wrapped by a counter)."""
    import ifcopenshell

    import bimrobot.bim.reader as reader

    out = tmp_path_factory.mktemp("build") / "out"
    real_open, real_pass = ifcopenshell.open, reader._read_shares

    def counted_open(path, *args, **kwargs):
        READS["parsed"].append(Path(path).name)
        return real_open(path, *args, **kwargs)

    def counted_pass(read, *args, **kwargs):
        READS["geometry"].append(Path(str(read.shown)).name)
        return real_pass(read, *args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(ifcopenshell, "open", counted_open)
        patch.setattr(reader, "_read_shares", counted_pass)
        assert main(["build", str(frame), "-o", str(out), "--schedule-out", "plan.xml"]) == 0
    return out


def _outcome(out: Path) -> tuple[dict, dict]:
    """(activity id -> status, component -> final state) from a build's RCAN state database."""
    with sqlite3.connect(f"file:{out / 'rcan' / 'state.db'}?mode=ro", uri=True) as db:
        activities = dict(db.execute("SELECT activity_id, status FROM activity"))
        components = dict(db.execute("SELECT global_id, state FROM component"))
    return activities, components


def test_build_leaves_each_stage_its_progress_bar(frame, tmp_path):
    """On a terminal a stage shows its progress bar (issue 36: the build hid them all; the bars stay off
    where stderr is no terminal, as in a log or this test): no stage is run with --no-progress."""
    from bimrobot.cli import parser_for
    from bimrobot.pipeline import STAGES

    build = ["build", str(frame), "-o", str(tmp_path / "out")]
    args = parser_for(build).parse_args(build)
    args.unknown_weight_text = args.unknown_weight.text  # as build_command sets it for the stages
    for stage in STAGES:
        argv = stage.argv(args, tmp_path / "out")
        assert getattr(parser_for(argv).parse_args(argv), "no_progress", False) is False, stage.name


def test_build_writes_every_stage_and_says_what_each_file_is(built):
    for path in ("package/worlds/construction_site.sdf", "simulation/schedule.csv", "simulation/events.log",
                 "graph.ttl", "rcan/report.json", "rcan/state.db", "build.rrd", "README.md", "build.json"):
        assert (built / path).is_file(), path
    readme = (built / "README.md").read_text()
    for path in ("package/", "simulation/schedule.csv", "graph.ttl", "rcan/report.json"):
        assert f"`{path}`" in readme
    assert "`bimrobot replay --serve build.rrd`" in readme  # the web viewer on the recording, nothing written again
    assert not list(built.parent.glob(".out.*")), "no staging folder is left behind"
    assert not (built / ".stages.json").exists()


def test_build_reads_the_ifc_once_and_says_so(frame, built):
    """One model, read once (issue 34): the build parses the IFC file once and reads its geometry once for
    all its stages and the report, and build.json records it."""
    assert READS == {"parsed": [frame.name], "geometry": [frame.name]}
    record = json.loads((built / "build.json").read_text())
    assert (record["ifc_reads"], record["geometry_passes"]) == (1, 1)


def test_a_stage_run_as_its_sub_command_writes_what_the_build_wrote(frame, built, tmp_path):
    """The stages are the sub-commands' own functions: `simulate` and `convert --layout yard` run alone
    (each reading the file itself) give the build's schedule and the build's package components."""
    from bimrobot.core.names import ros_package_name

    assert main(["simulate", str(frame), "--fleet", "fleet2", "-o", str(tmp_path / "sim"), "--no-progress"]) == 0
    assert (tmp_path / "sim" / "schedule.csv").read_text() == (built / "simulation" / "schedule.csv").read_text()
    assert main(["convert", str(frame), "-o", str(tmp_path / "pkg"), "--layout", "yard", "--no-progress", "--no-preview",
                 "--site", str(built / "site.yaml"), "--package-name", ros_package_name(built.name)]) == 0
    alone = json.loads((tmp_path / "pkg" / "report.json").read_text())
    in_build = json.loads((built / "package" / "report.json").read_text())
    assert alone["converted"] == in_build["converted"] and alone["counts"] == in_build["counts"]


def test_build_executes_the_simulated_schedule_through_rcan(built):
    report = json.loads((built / "rcan" / "report.json").read_text())
    rows = (built / "simulation" / "schedule.csv").read_text().splitlines()[1:]
    activities, components = _outcome(built)
    assert len(activities) >= len(rows)  # each schedule row becomes one or more RCAN activities
    assert set(activities.values()) == {"done"}
    assert set(components.values()) == {"Assembled"}
    assert report["status"] == "completed" and len(report["done"]) == len(activities) and not report["escalations"]


def test_rcan_executes_each_activity_on_the_robot_the_schedule_assigned(built):
    assigned = {row["Identification"]: row["Robot"]
                for row in csv.DictReader((built / "simulation" / "schedule.csv").open())}
    with sqlite3.connect(f"file:{built / 'rcan' / 'state.db'}?mode=ro", uri=True) as db:
        executed = dict(db.execute("SELECT activity_id, robot FROM activity"))
    assert executed and all(robot == assigned[activity.split(".")[0]] for activity, robot in executed.items())
    assert set(executed.values()) == set(assigned.values())  # the fleet's robots, not the built-in table's
    report = json.loads((built / "rcan" / "report.json").read_text())
    assert report["robots"] == executed  # the report lists each activity with its robot


def _moved(model: Path, out: Path, east_m: float, north_m: float) -> Path:
    """``model`` with its site (the root of every placement) moved by (east, north) metres, as a
    georeferenced export puts a building at its map coordinates."""
    import ifcopenshell

    ifc = ifcopenshell.open(str(model))
    (root,) = [p for p in ifc.by_type("IfcLocalPlacement") if p.PlacementRelTo is None]
    x, y, z = root.RelativePlacement.Location.Coordinates
    root.RelativePlacement.Location = ifc.createIfcCartesianPoint((x + east_m, y + north_m, z))
    ifc.write(str(out))
    return out


def test_rcan_robot_times_do_not_change_when_the_model_is_georeferenced(frame, built, tmp_path):
    """The fleet's homes are site positions: RCAN puts them beside the building whatever the IFC's
    coordinates (before, the robots of a model at map coordinates started 488 km away: 610,309 s for
    the first drive instead of 5.9 s)."""
    far = _moved(frame, tmp_path / "frame-georeferenced.ifc", 155_000.0, 463_000.0)
    out = tmp_path / "out"
    assert main(["build", str(far), "-o", str(out)]) == 0
    near = json.loads((built / "rcan" / "report.json").read_text())
    moved = json.loads((out / "rcan" / "report.json").read_text())
    assert moved["status"] == "completed"
    # RCAN's times are simulated seconds from the one time model, whatever the threads do: activity by
    # activity the same as the build near the origin (before: makespans 681 s against 701 s in one run)
    assert moved["activities"].keys() == near["activities"].keys()
    for activity_id, timing in near["activities"].items():
        assert moved["activities"][activity_id]["started_s"] == pytest.approx(timing["started_s"], abs=1e-3)
        assert moved["activities"][activity_id]["finished_s"] == pytest.approx(timing["finished_s"], abs=1e-3)
    assert moved["makespan_s"] == pytest.approx(near["makespan_s"], abs=1e-3)
    # the same site placement, seen from the moved model frame
    assert moved["model_offset_xy_m"] == pytest.approx(
        [near["model_offset_xy_m"][0] - 155_000.0, near["model_offset_xy_m"][1] - 463_000.0], abs=1e-6)


def test_build_graph_is_the_hub_rcan_runs_from_and_the_ifc_carries_the_work_schedule(built):
    """RCAN is generated from graph.ttl (no CSV, no IFC); the graph has the joints the simulation used and
    the components' pick-up positions on the package's yard; the IFC copy re-opens with one IfcTask per
    activity of the simulated schedule."""
    import ifcopenshell

    from bimrobot.lbd.graph import ConstructionGraph

    log = json.loads((built / "build.json").read_text())
    assert set(log["stages"]) == {"package", "simulation", "graph", "rcan", "replay"}
    rows = list(csv.DictReader((built / "simulation" / "schedule.csv").open()))
    graph = ConstructionGraph.open(built / "graph.ttl")
    column = next(r["GlobalId"] for r in rows if r["Activity"] == "assemble")
    joints = graph.query("connected_elements", globalId=column)
    assert joints and {j["provenance"] for j in joints} == {"ifc-relation"}
    picks = graph.query("SELECT (COUNT(?p) AS ?n) WHERE { ?e <https://bimrobot.example/ns#pickUpPosition> ?p }")
    transported = {r["GlobalId"] for r in rows if r["Activity"] == "transport"}
    assert int(picks[0]["n"]) >= len(transported) > 0
    after = ConstructionGraph.open(built / "rcan" / "graph-after-rcan.ttl")
    assert {after.activity_state(r["Identification"]) for r in rows} == {"Completed"}
    ifc = ifcopenshell.open(str(built / "model-with-schedule.ifc"))
    tasks = [t for t in ifc.by_type("IfcTask") if not t.IsNestedBy]  # leaves: one per activity
    assert len(tasks) == len(rows)
    assert len(ifc.by_type("IfcWorkSchedule")) == 1 and all(t.TaskTime for t in tasks)
    assert "`model-with-schedule.ifc`" in (built / "README.md").read_text()
    # --schedule-out plan.xml (issue 36): the same tasks for Microsoft Project, listed in the README
    project = ET.parse(built / "plan.xml").getroot()
    assert len(project.findall("{http://schemas.microsoft.com/project}Tasks/*")) == len(ifc.by_type("IfcTask"))
    assert "`plan.xml` | the same work schedule as Microsoft Project XML" in (built / "README.md").read_text()


def test_killed_build_resumes_to_the_result_of_an_uninterrupted_one(frame, built, tmp_path):
    out = tmp_path / "out"
    partial = tmp_path / ".out.partial"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    process = subprocess.Popen([*BIMROBOT, "build", str(frame), "-o", str(out), "--time-scale", "0.003"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    state_db = partial / "rcan" / "state.db"
    done, deadline = 0, time.monotonic() + 120
    try:
        while time.monotonic() < deadline and process.poll() is None:
            if state_db.exists():
                try:
                    with sqlite3.connect(f"file:{state_db}?mode=ro", uri=True) as db:
                        done = db.execute("SELECT COUNT(*) FROM activity WHERE status='done'").fetchone()[0]
                except sqlite3.OperationalError:
                    done = 0
            if done >= 30:
                break
            time.sleep(0.02)
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait()
    assert done >= 30, "the build reached its RCAN stage and executed work before the kill"
    assert not out.exists() and partial.is_dir(), "a killed build leaves only its resumable partial folder"

    rerun = subprocess.run([*BIMROBOT, "build", str(frame), "-o", str(out)], capture_output=True, text=True, env=env)
    assert rerun.returncode == 0, rerun.stderr
    assert "resuming" in rerun.stderr
    assert rerun.stdout.count("done in an earlier run") == 3  # package, simulation, graph kept
    assert not partial.exists()
    assert _outcome(out) == _outcome(built)
    assert json.loads((out / "build.json").read_text())["resumed"] is True


def test_a_failed_build_leaves_nothing_behind(frame, tmp_path, capsys):
    fleet = tmp_path / "fleet.yaml"
    fleet.write_text("robots:\n  - name: R\n    kind: transport\n    speed: 0.5\n    carry_load: 1\n    platform_size: [1, 1]\n")
    out = tmp_path / "out"
    # every component outweighs the 1 kg carrier: the simulation stage refuses the fleet
    assert main(["build", str(frame), "--fleet", str(fleet), "-o", str(out)]) == 2
    assert "fleet" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fleet.yaml"]


def test_build_refuses_a_foreign_output_folder(frame, tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    assert main(["build", str(frame), "-o", str(out)]) == 2
    assert "did not write" in capsys.readouterr().err
    assert (out / "notes.txt").read_text() == "keep me"


def test_no_written_file_names_the_partial_folder_the_build_was_made_in(built):
    """The build is written in .out.partial and renamed to out: a path into the partial folder (e.g.
    package/report.json's site file, report.html's `bimrobot report` line) would name nothing afterwards."""
    for path in built.rglob("*"):
        if path.is_file() and path.suffix in {".json", ".md", ".yaml", ".html", ".xml", ".txt", ".csv", ".sdf", ".py"}:
            assert "out.partial" not in path.read_text(encoding="utf-8", errors="replace"), path
    site = json.loads((built / "package" / "report.json").read_text())["options"]["site"]["source"]
    assert Path(site) == built / "site.yaml" and Path(site).is_file()


#: What may differ between two builds of the same model with the same options: times of the run. Files
#: compared as JSON have these keys removed; the IFC copy has IfcWorkSchedule.CreationDate (a time stamp).
TIMED_FILES = {".bimrobot-output.json", "package/.bimrobot-output.json", "simulation/.bimrobot-output.json",
               "README.md", "build.rrd", "rcan/state.db", "report.html"}
TIMED_KEYS = {"build.json": ("stages", "generator"), "package/report.json": ("timings_s",),
              "rcan/report.json": ("wall_s", "latencies_s")}


@pytest.mark.slow  # a second build of the frame: 11 s of CPU, 43 s of wall time on the loaded 2-core machine
def test_a_second_build_writes_the_same_bytes_but_its_times(frame, built, tmp_path):
    import re

    again = tmp_path / "out"  # the same folder name: the package is named after it
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["build", str(frame), "-o", str(again), "--schedule-out", "plan.xml"]) == 0
    names = _written(built)
    assert names == _written(again)
    creation = re.compile(rb"(IFCWORKSCHEDULE\('[^']*',[^,]*,'[^']*',[^,]*,[^,]*,'[^']*',)'[^']*'")
    for name in names:
        # paths into the output folder (package/report.json's site file) name each build's own folder
        first, second = (built / name).read_bytes(), (again / name).read_bytes().replace(bytes(again), bytes(built))
        if name in TIMED_FILES:
            continue
        if name in TIMED_KEYS:
            first, second = (_without(json.loads(b), TIMED_KEYS[name]) for b in (first, second))
        elif name.endswith(".ifc"):
            first, second = (creation.sub(rb"\1''", b) for b in (first, second))
        assert first == second, name


def _written(folder: Path) -> list[str]:
    """The files of an output folder, without SQLite's ``-shm``/``-wal`` side files: other tests of this
    module open ``rcan/state.db`` of the shared build, and SQLite leaves them beside it while they do."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")
                  if p.is_file() and not p.name.endswith(("-shm", "-wal")))


def _without(data: dict, keys) -> dict:
    return {k: v for k, v in data.items() if k not in keys}
