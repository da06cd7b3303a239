"""One time model: RCAN's sim backend executing a simulated schedule takes the time `simulate` planned.

The schedule `simulate` writes carries the work of each row (where the robot began and ended it, the
nodes it positioned, the points it made); RCAN breaks each row into its activities and the sim backend
charges them by :mod:`bimrobot.sco.timing`, so every row starts and finishes when the schedule says, and
the same command gives the same times however the executor threads interleave.
"""

from __future__ import annotations

import csv
import json

import pytest

from bimrobot.cli import main


def _rows_by_id(schedule_csv) -> dict[str, dict]:
    with open(schedule_csv, newline="", encoding="utf-8") as handle:
        return {row["Identification"]: row for row in csv.DictReader(handle)}


def _row_times(report: dict) -> dict[str, tuple[float, float]]:
    """(start, finish) in seconds of each schedule row, from the RCAN activities it was broken into."""
    spans: dict[str, list[float]] = {}
    for activity_id, timing in report["activities"].items():
        row = activity_id.rpartition(".")[0]
        assert timing["result"] == "done", f"{activity_id} was not done: {timing}"
        spans.setdefault(row, []).extend((timing["started_s"], timing["finished_s"]))
    return {row: (min(times), max(times)) for row, times in spans.items()}


@pytest.fixture(scope="module")
def frame_run(tmp_path_factory):
    """The chapter-4 steel frame simulated by fleet 2 (per node, the CLI's default), its graph, and the folder."""
    folder = tmp_path_factory.mktemp("one-time-model")
    assert main(["example", "steel-frame", "-o", str(folder / "frame.ifc")]) == 0
    assert main(["simulate", str(folder / "frame.ifc"), "--fleet", "fleet2", "-o", str(folder / "sim"),
                 "--no-progress", "--no-gantt"]) == 0
    return folder


def _rcan(folder, name: str, *source: str, fleet: bool = True) -> dict:
    report = folder / f"{name}.json"
    code = main(["rcan", "run", *source, *(["--fleet", "fleet2"] if fleet else []), "-q", "--report", str(report)])
    assert code == 0
    return json.loads(report.read_text())


@pytest.mark.parametrize("source", ["schedule", "graph"])
def test_rcan_executes_the_simulated_schedule_in_its_time(frame_run, source):
    folder = frame_run
    schedule = folder / "sim" / "schedule.csv"
    if source == "schedule":
        report = _rcan(folder, "from-schedule", "--schedule", str(schedule), "--model", str(folder / "frame.ifc"))
    else:
        assert main(["graph", str(folder / "frame.ifc"), "--schedule", str(schedule), "-o", str(folder / "graph.ttl")]) == 0
        # the graph alone: it holds the fleet (brc:fleetDescription: the fleet.yaml simulate wrote beside the
        # schedule) and the site, so no --fleet
        report = _rcan(folder, "from-graph", "--graph", str(folder / "graph.ttl"), fleet=False)
    rows = _rows_by_id(schedule)
    simulated = json.loads((folder / "sim" / "summary.json").read_text())["makespan_s"]
    assert report["makespan_s"] == pytest.approx(simulated, rel=0.005)
    times = _row_times(report)
    assert set(times) == set(rows)
    for row_id, (start, finish) in times.items():
        assert start == pytest.approx(float(rows[row_id]["Start"]), abs=1.0), row_id
        assert finish == pytest.approx(float(rows[row_id]["Finish"]), abs=1.0), row_id


def test_the_same_run_gives_the_same_times(frame_run):
    """Simulated seconds, not threads: two runs of one schedule give every activity the same times."""
    folder = frame_run
    args = ("--schedule", str(folder / "sim" / "schedule.csv"), "--model", str(folder / "frame.ifc"))
    first, second = _rcan(folder, "first", *args), _rcan(folder, "second", *args)
    assert first["activities"] == second["activities"]
    assert first["makespan_s"] == second["makespan_s"]


def test_the_schedule_says_the_work_of_each_row(frame_run):
    """Transports carry from the yard to the component; positionings say their nodes; assemblies their
    points, which add up to the model's bolts (the frame has 64)."""
    rows = list(_rows_by_id(frame_run / "sim" / "schedule.csv").values())
    transports = [r for r in rows if r["Activity"] == "transport"]
    assert all(r["FromX"] and r["ToX"] and (r["FromX"], r["FromY"]) != (r["ToX"], r["ToY"]) for r in transports)
    assert all(r["Nodes"] == "1" for r in rows if r["Activity"] == "position")  # per node
    assert sum(int(r["Points"]) for r in rows if r["Activity"] == "assemble") == 64
