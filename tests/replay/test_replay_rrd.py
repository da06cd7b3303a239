"""`bimrobot replay`: the .rrd read back with Rerun's dataframe API agrees with the schedule."""

from __future__ import annotations

import csv
import importlib.util
import json

import numpy as np
import pytest

from bimrobot.cli import main

# found, not imported (tests/conftest.py): the extras these tests need
MISSING = [name for name in ("rerun", "datafusion") if importlib.util.find_spec(name) is None]
pytestmark = pytest.mark.skipif(bool(MISSING), reason=f"needs {', '.join(MISSING)}, not installed")


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """rerun (about 1 s of imports with its dataframe API), imported when these tests run, not at collection."""
    global rr, COLUMN_C1
    import rerun as rr

    #: Column C1 of the steel frame (GlobalId 3Ua8LTHWPNNemz8Gs8JfMy): named by storey, class and name.
    COLUMN_C1 = "/building/" + "/".join(rr.escape_entity_path_part(p) for p in ("Level 1", "IfcColumn", "Column C1"))


def read_back(rrd):
    """A Rerun catalog server on 127.0.0.1 holding only ``rrd``: its dataset (dataframe API)."""
    from rerun.server import Server

    server = Server(host="127.0.0.1", datasets={"build": [str(rrd)]})
    return server, server.client().get_dataset("build")


def column(frame, name):
    return frame.to_pandas()[name]


def test_replay_holds_every_element_robot_and_node(frame_build, frame_replay):
    rrd, summary = frame_replay
    report = json.loads((frame_build / "package" / "report.json").read_text())
    elements = {e["global_id"] for e in report["converted"]}
    server, dataset = read_back(rrd)
    with server:
        paths = {c.entity_path for c in dataset.schema().component_columns()}
        nodes = dataset.filter_contents(["/nodes"]).reader(index="sim_time").to_pandas()
    building = {p for p in paths if p.startswith("/building/")}
    assert len(building) == len(elements) == summary["pieces"] == 88
    assert COLUMN_C1 in building
    robots = {p.split("/")[2] for p in paths if p.startswith("/robots/")}
    assert robots == {"TransportRobot11", "TransportRobot12", "PositioningRobot21", "PositioningRobot22",
                      "AssemblyRobot31", "AssemblyRobot32"}
    # the connection nodes: one entity, a point per node (hover a point for its node)
    labels = nodes["/nodes:Points3D:labels"].dropna().iloc[0]
    assert len(labels) == len(set(labels)) == summary["nodes"] > 0
    colours = nodes["/nodes:Points3D:colors"].dropna()
    assert all(len(row) == summary["nodes"] for row in colours)  # every row colours every node


def test_installed_count_and_last_installation_match_the_schedule(frame_build, frame_replay):
    rrd, _ = frame_replay
    rows = list(csv.DictReader((frame_build / "simulation" / "schedule.csv").open()))
    components = {r["GlobalId"] for r in rows}
    last_finish = max(float(r["Finish"]) for r in rows)
    server, dataset = read_back(rrd)
    with server:
        frame = dataset.filter_contents(["/progress/Assembled"]).reader(index="sim_time").to_pandas()
    values = frame["/progress/Assembled:Scalars:scalars"].map(lambda v: float(v[0]))
    times = frame["sim_time"].map(lambda t: t.total_seconds())
    # every component the schedule builds is installed at the end, the last one when the schedule ends
    assert values.iloc[-1] == len(components) == 12
    first_full = times[values == len(components)].min()
    assert first_full == pytest.approx(last_finish, abs=1e-3)
    assert values.iloc[0] < len(components)


def test_component_state_and_properties_are_read_back(frame_replay):
    rrd, _ = frame_replay
    column_gid = COLUMN_C1
    server, dataset = read_back(rrd)
    with server:
        frame = dataset.filter_contents([column_gid]).reader(index="sim_time").to_pandas()
    first = {key: frame[f"{column_gid}:{key}"].dropna().iloc[0][0] for key in ("ifc_class", "name", "global_id", "storey")}
    assert first == {"ifc_class": "IfcColumn", "name": "Column C1", "global_id": "3Ua8LTHWPNNemz8Gs8JfMy", "storey": "Level 1"}
    states = [v[0] for v in frame[f"{column_gid}:state"].dropna()]
    assert states[0] == "OnYard" and states[-1] == "Assembled"
    assert "InTransit" in states and "WorkingInPositioning" in states


def test_cli_writes_and_refuses_a_foreign_file(frame_build, tmp_path, capsys):
    out = tmp_path / "b.rrd"
    assert main(["replay", str(frame_build), "-o", str(out), "--start", "2026-03-02T07:00"]) == 0
    assert "12 installed" in capsys.readouterr().out
    assert out.stat().st_size > 10_000
    foreign = tmp_path / "mine.rrd"
    foreign.write_text("not bimrobot's")
    assert main(["replay", str(frame_build), "-o", str(foreign)]) == 2
    assert foreign.read_text() == "not bimrobot's"
    assert "did not write" in capsys.readouterr().err


def test_a_folder_that_is_not_a_build_is_refused(tmp_path, capsys):
    assert main(["replay", str(tmp_path), "-o", str(tmp_path / "x.rrd")]) == 2
    assert "not a `bimrobot build` output folder" in capsys.readouterr().err


def test_a_simulate_and_convert_pair_replays_like_the_build(frame_build, frame_replay, tmp_path):
    from bimrobot.replay import write_replay

    summary = write_replay(frame_build / "package", tmp_path / "pair.rrd", simulation=frame_build / "simulation")
    # the same replay, without the build's RCAN run (rcan/ is not part of the pair)
    assert summary == {key: value for key, value in frame_replay[1].items() if not key.startswith("rcan")}


def test_the_builds_rcan_run_is_on_rcan_time(frame_build, frame_replay):
    """One line per activity RCAN finished, per robot, beside the simulated schedule: as many done as the
    RCAN report lists, each on the robot the report names."""
    rrd, summary = frame_replay
    report = json.loads((frame_build / "rcan" / "report.json").read_text())
    server, dataset = read_back(rrd)
    with server:
        frame = dataset.filter_contents(["/rcan/**"]).reader(index="rcan_time").to_pandas()
    done = {}
    for name in frame.columns:
        if name.endswith(":activity_id"):
            robot = name.split("/")[2].split(":")[0]
            statuses = frame[name.replace(":activity_id", ":status")]
            for ids, status in zip(frame[name].dropna(), statuses.dropna()):
                done.update({a: robot for a, s in zip(ids, status) if s == "done"})
    assert len(done) == len(report["done"]) == summary["rcan_done"] == 160
    assert done == {activity: report["robots"][activity] for activity in report["done"]}


def test_the_rcan_gantt_has_a_bar_per_done_activity_at_the_reports_times(frame_build, frame_replay):
    """RCAN's Gantt is drawn as bars, as the schedule's: one bar per done activity of the RCAN report, on
    its robot's row, from the report's start to its finish, and a time cursor on rcan_time."""
    from bimrobot.replay.gantt import chart_width

    rrd, _ = frame_replay
    report = json.loads((frame_build / "rcan" / "report.json").read_text())
    server, dataset = read_back(rrd)
    with server:
        static = dataset.filter_contents(["/rcan_gantt/**"]).reader(index=None).to_pandas()
        cursor = dataset.filter_contents(["/rcan_gantt/now"]).reader(index="rcan_time").to_pandas()
    robots = sorted({report["robots"][a] for a in report["activities"]} | set(report["robots"].values()))
    end = max(entry["finished_s"] for entry in report["activities"].values() if entry["result"] == "done")
    scale = chart_width(len(robots)) / end
    bars = {}
    for row, robot in enumerate(robots):
        path = "/rcan_gantt/" + rr.escape_entity_path_part(robot)
        if f"{path}:Boxes2D:centers" not in static:
            continue
        centres = np.array([list(v) for v in static[f"{path}:Boxes2D:centers"].iloc[0]])
        halves = np.array([list(v) for v in static[f"{path}:Boxes2D:half_sizes"].iloc[0]])
        labels = static[f"{path}:Boxes2D:labels"].iloc[0]
        assert np.allclose(centres[:, 1], row)  # the robot's row
        for label, centre, half in zip(labels, centres, halves):
            activity = label.split(": ", 1)[1].split()[0]
            bars[activity] = (robot, (centre[0] - half[0]) / scale, (centre[0] + half[0]) / scale)
    assert len(bars) == len(report["done"]) == 160
    for activity, (robot, start, finish) in bars.items():
        entry = report["activities"][activity]
        assert entry["result"] == "done" and robot == entry["robot"] == report["robots"][activity]
        assert start == pytest.approx(entry["started_s"], abs=0.01)
        # a bar shorter than 0.1 % of the chart is drawn that wide, to be seen
        assert finish == pytest.approx(max(entry["finished_s"], entry["started_s"] + 1e-3 * end), abs=0.01)
    times = cursor["rcan_time"].map(lambda t: t.total_seconds())
    assert times.min() == 0.0 and times.max() == pytest.approx(end, abs=1e-6)


def test_the_web_viewer_is_served_on_127_0_0_1_and_stopped_with_every_process_it_started(frame_pair_replay):
    """`rerun` is a launcher that starts the viewer binary as a child: stopping the viewer must stop both
    (a leftover viewer keeps serving and uses a core)."""
    import os
    import urllib.request

    from bimrobot.replay.serve import CONTENT_SECURITY_POLICY, serve_web

    rrd, _ = frame_pair_replay
    with serve_web(rrd) as viewer:
        assert viewer.url.startswith("http://127.0.0.1:")
        with urllib.request.urlopen(viewer.url, timeout=30) as page:
            assert page.status == 200 and page.headers["Content-Security-Policy"] == CONTENT_SECURITY_POLICY
        group = viewer.process.pid
        os.killpg(group, 0)  # the launcher's group is alive while serving
    with pytest.raises(ProcessLookupError):
        os.killpg(group, 0)  # no process of it is left


def test_the_state_plot_and_robot_labels_read_back_as_the_build_has_them(frame_build, frame_replay):
    """The plot of components per state is logged only where a count changes (a lighter recording) and
    drawn as steps: read back and drawn as Rerun draws it (StepAfter: each value holds until the next
    row), it gives every state's count at every time a component changes state; each robot's hover
    label is its activity from each start on."""
    from bimrobot.replay.inputs import STATES, load_build
    from bimrobot.replay.motion import robot_tracks
    from bimrobot.replay.record import _state_counts

    rrd, _ = frame_replay
    record = load_build([frame_build])
    times, counts, _ = _state_counts(record)
    robot = "TransportRobot11"
    server, dataset = read_back(rrd)
    with server:
        frame = dataset.filter_contents(["/progress/**", f"/robots/{robot}"]).reader(index="sim_time").to_pandas()
        static = dataset.filter_contents(["/progress/**"]).reader(index=None).to_pandas()
    seconds = frame["sim_time"].map(lambda t: round(t.total_seconds(), 6)).to_numpy()  # ns on the timeline
    times = np.round(times, 6)
    logged = 0
    for index, state in enumerate(STATES):
        mode = static[f"/progress/{state}:SeriesLines:interpolation_mode"].iloc[0][0]
        assert mode == rr.components.InterpolationMode.StepAfter.value, state
        values = frame[f"/progress/{state}:Scalars:scalars"]
        rows = values.notna().to_numpy()
        logged += rows.sum()
        at, drawn = seconds[rows], values[rows].map(lambda v: float(v[0])).to_numpy()
        held = drawn[np.searchsorted(at, times, side="right") - 1]  # the last row at or before each time
        assert np.array_equal(held, counts[:, index]), state
    assert logged < counts.size / 2  # far fewer rows than one per state and time
    labels = frame[f"/robots/{robot}:Boxes3D:labels"]
    read = [(t, v[0]) for t, v in zip(seconds, labels) if v is not None and not (np.isscalar(v) and np.isnan(v))]
    expected = {}  # at a time with two labels (a task given as the last ends) the later one shows
    for t, label, _ in robot_tracks(record)[robot].activities:
        expected[round(t, 3)] = f"{robot}: {label}"
    assert [(round(t, 3), text) for t, text in read] == list(expected.items())


def test_a_real_models_replay_is_recognised_as_bimrobots_and_another_programs_is_refused(shared_ifc, tmp_path, capsys):
    """ROOT-staal's recording keeps its signature only LZ4-compressed (rerun 0.41: no plain copy in its
    1.2 MB), which made `bimrobot build` fail at its last stage. Its recording properties, read by Rerun,
    say it is bimrobot's: a second replay replaces it, and another program's recording is kept."""
    from bimrobot.replay.record import is_replay_recording

    model, sim, pkg = shared_ifc("ROOT-staal.ifczip"), tmp_path / "sim", tmp_path / "pkg"
    assert main(["simulate", str(model), "--fleet", "site-crane", "-o", str(sim), "--no-gantt", "--no-progress"]) == 0
    assert main(["convert", str(model), "-o", str(pkg), "--layout", "yard", "--site", str(sim / "site.yaml"),
                 "--no-preview", "--no-maps", "--no-progress"]) == 0
    rrd = tmp_path / "root.rrd"
    for _ in range(2):  # written, then replaced
        assert main(["replay", str(pkg), str(sim), "-o", str(rrd)]) == 0, capsys.readouterr().err
        assert "78 components (78 installed" in capsys.readouterr().out
    assert is_replay_recording(rrd)

    foreign = tmp_path / "theirs.rrd"
    other = rr.RecordingStream("someone-else", recording_id="theirs")
    other.save(str(foreign))
    other.log("points", rr.Points3D([[0.0, 0.0, 0.0]]))
    other.flush()
    other.disconnect()
    before = foreign.read_bytes()
    assert not is_replay_recording(foreign)
    assert main(["replay", str(pkg), str(sim), "-o", str(foreign)]) == 2
    assert foreign.read_bytes() == before and "did not write" in capsys.readouterr().err
