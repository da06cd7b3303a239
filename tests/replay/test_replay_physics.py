"""`bimrobot replay` of an RCAN run with the mujoco backend: the recorded bodies on `physics_time`."""

from __future__ import annotations

import csv
import importlib.util

import numpy as np
import pytest

from bimrobot.cli import main

# found, not imported (tests/conftest.py): the extras these tests need
MISSING = [name for name in ("rerun", "datafusion", "mujoco") if importlib.util.find_spec(name) is None]
pytestmark = pytest.mark.skipif(bool(MISSING), reason=f"needs {', '.join(MISSING)}, not installed")


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """rerun (about 1 s of imports with its dataframe API), imported when these tests run, not at collection."""
    global rr
    import rerun as rr


COLUMN = "267VPu8ab9991QBA3MI3UN"  # the column of the thesis' RCAN experiment 1


@pytest.fixture(scope="module")
def experiment_run(tmp_path_factory):
    """An `rcan run --experiment 1 --backend mujoco` folder and the experiment's IFC model."""
    root = tmp_path_factory.mktemp("e1")
    run = root / "run"
    assert main(["rcan", "run", "--experiment", "1", "--backend", "mujoco", "-q", "--report", str(run / "report.json"),
                 "--state-db", str(run / "state.db")]) == 0
    assert main(["example", "rcan-experiment-1", "-o", str(root / "e1.ifc")]) == 0
    assert (run / "state.db.trajectory.csv").is_file()
    return run, root / "e1.ifc"


@pytest.fixture(scope="module")
def experiment_replay(experiment_run):
    run, model = experiment_run
    rrd = run.parent / "e1.rrd"
    assert main(["replay", str(run), "--model", str(model), "-o", str(rrd)]) == 0
    return rrd


def column_path(experiment_run) -> str:
    """The column's entity path: /building/<storey>/<class>/<name>, as the replay names it."""
    from bimrobot.replay.elements import element_paths
    from bimrobot.replay.inputs import load_rcan_alone

    run, model = experiment_run
    path = element_paths(load_rcan_alone(run, model))[COLUMN]
    assert path.startswith("/building/") and COLUMN not in path
    return path


def read_back(rrd, entities, index):
    from rerun.server import Server

    server = Server(host="127.0.0.1", datasets={"run": [str(rrd)]})
    with server:
        dataset = server.client().get_dataset("run")
        paths = {c.entity_path for c in dataset.schema().component_columns()}
        frame = dataset.filter_contents(entities).reader(index=index).to_pandas()
    return paths, frame


def last_rows(path):
    """body -> its last row (time_s, x, y, z, qw, qx, qy, qz) in the trajectory CSV."""
    with open(path, newline="") as handle:
        assert handle.readline().startswith("# written by bimrobot")
        last = {}
        for row in csv.DictReader(handle):
            last[row["body"]] = [float(row[k]) for k in ("time_s", "x", "y", "z", "qw", "qx", "qy", "qz")]
    return last


def transforms(frame, path):
    """(times s, translations (n, 3), quaternions xyzw (n, 4)) of the rows that set ``path``'s Transform3D."""
    rows = frame[frame[f"{path}:Transform3D:translation"].notna()]
    times = rows["physics_time"].map(lambda t: t.total_seconds()).to_numpy()
    xyz = np.array([list(v[0]) for v in rows[f"{path}:Transform3D:translation"]])
    quat = np.array([list(v[0]) for v in rows[f"{path}:Transform3D:quaternion"]])
    return times, xyz, quat


def test_component_ends_at_the_recorded_pose_and_the_robot_moved(experiment_run, experiment_replay):
    run, _ = experiment_run
    last = last_rows(run / "state.db.trajectory.csv")
    column = column_path(experiment_run)
    base = "/bodies/husky_ur5/base"
    paths, frame = read_back(experiment_replay, [column, base], "physics_time")
    assert {column, base, "/bodies/husky_ur5/gripper", "/bodies/husky_ur5/arm"} <= paths
    times, xyz, quat = transforms(frame, column)
    t, x, y, z, qw, qx, qy, qz = last[COLUMN]
    assert times[-1] == pytest.approx(t, abs=1e-6)
    assert np.linalg.norm(xyz[-1] - [x, y, z]) < 1e-3  # metres
    assert abs(abs(np.dot(quat[-1], [qx, qy, qz, qw])) - 1) < 1e-6
    # the column was carried: it moved from its pick-up stand to its target, 0.72 m away
    assert np.linalg.norm(xyz[0] - xyz[-1]) > 0.5
    # the robot drove to the column (3.3 m) before picking it up
    _, base_xyz, _ = transforms(frame, base)
    assert np.linalg.norm(base_xyz[0][:2] - base_xyz[-1][:2]) > 2.0
    # and its state ends as the run's report says
    states = [v[0] for v in frame[f"{column}:state"].dropna()]
    assert states[0] == "OnYard" and states[-1] == "Assembled" and "InTransit" in states


def test_the_installed_mesh_lies_at_its_ifc_placement(experiment_run, experiment_replay):
    """At the end the mesh (in the body frame) placed by the body's pose equals the IFC element's body."""
    from bimrobot.bim import load_model

    run, model_path = experiment_run
    element = load_model(model_path).elements[COLUMN]
    column = column_path(experiment_run)
    _, frame = read_back(experiment_replay, [column], "physics_time")
    _, xyz, quat = transforms(frame, column)
    from scipy.spatial.transform import Rotation

    vertices = np.array([list(v) for v in frame[f"{column}:Mesh3D:vertex_positions"].dropna().iloc[-1]])
    world = vertices @ Rotation.from_quat(quat[-1]).as_matrix().T + xyz[-1]
    ifc = element.vertices @ element.placement[:3, :3].T + element.placement[:3, 3]
    assert np.allclose(world.min(axis=0), ifc.min(axis=0), atol=1e-3)
    assert np.allclose(world.max(axis=0), ifc.max(axis=0), atol=1e-3)


def test_an_rcan_folder_without_its_model_is_refused(experiment_run, tmp_path, capsys):
    run, _ = experiment_run
    assert main(["replay", str(run), "-o", str(tmp_path / "x.rrd")]) == 2
    assert "give the IFC model with --model" in capsys.readouterr().err


def test_a_malformed_trajectory_is_refused_naming_its_line(experiment_run, tmp_path, capsys):
    import shutil

    run, model = experiment_run
    copy = tmp_path / "run"
    shutil.copytree(run, copy)
    trajectory = copy / "state.db.trajectory.csv"
    lines = trajectory.read_text().splitlines()
    lines[4] = lines[4].replace(lines[4].split(",")[2], "nan", 1)
    trajectory.write_text("\n".join(lines) + "\n")
    assert main(["replay", str(copy), "--model", str(model), "-o", str(tmp_path / "x.rrd")]) == 2
    assert "line 5" in capsys.readouterr().err


def test_the_rcan_activities_are_on_their_own_timelines(experiment_run, experiment_replay):
    import json

    run, _ = experiment_run
    report = json.loads((run / "report.json").read_text())
    paths, frame = read_back(experiment_replay, ["/rcan/**"], "rcan_time")
    assert "/rcan/husky_ur5" in paths
    texts = [v[0] for v in frame["/rcan/husky_ur5:TextLog:text"].dropna()]
    done = [a for ids, status in zip(frame["/rcan/husky_ur5:activity_id"].dropna(), frame["/rcan/husky_ur5:status"].dropna())
            for a, s in zip(ids, status) if s == "done"]
    assert done == report["done"] == ["E1.1", "E1.2", "E1.3", "E1.4", "E1.5"]
    assert texts[-1].startswith("husky_ur5: E1.5 Install")
    # the mujoco backend's activity times are its scene's seconds: the same lines on physics_time
    _, physics = read_back(experiment_replay, ["/rcan/**"], "physics_time")
    assert physics["/rcan/husky_ur5:TextLog:text"].dropna().map(lambda v: v[0]).tolist() == texts


def meshes_on_the_timeline(frame) -> set[str]:
    """The entities with a mesh in ``frame`` (read on one timeline: the columns of others are empty)."""
    return {c.split(":")[0] for c in frame.columns if c.endswith("Mesh3D:vertex_positions") and frame[c].notna().any()}


@pytest.fixture(scope="module")
def physics_build(frame_build, experiment_run, tmp_path_factory):
    """A build whose rcan/ holds a trajectory CSV (experiment 1's run put in place of the frame's) and
    its replays: {draw: (rrd, summary)} for "meshes" and "boxes"."""
    import shutil

    from bimrobot.replay import write_replay

    run, _ = experiment_run
    build = tmp_path_factory.mktemp("physics-build") / "out"
    shutil.copytree(frame_build, build)
    shutil.rmtree(build / "rcan")
    shutil.copytree(run, build / "rcan")
    replays = {}
    for draw in ("meshes", "boxes"):
        rrd = build.parent / f"{draw}.rrd"
        replays[draw] = rrd, write_replay(build, rrd, model=frame_build.parent / "frame.ifc", draw=draw)
    return build, replays


def test_a_builds_rcan_folder_with_a_trajectory_adds_the_physics(physics_build):
    """A build whose rcan/ holds a trajectory CSV (here experiment 1's run put in place of the frame's):
    the schedule's replay is unchanged and the physics robots join it on physics_time."""
    _, replays = physics_build
    rrd, summary = replays["meshes"]
    assert summary["installed"] == 12 and summary["rcan_done"] == 5
    # the experiment's column is no element of the frame: only the robots are drawn from the physics
    assert summary["physics_robots"] == 3 and summary["physics_components"] == 0
    paths, _ = read_back(rrd, ["/bodies/husky_ur5/base"], "physics_time")
    assert "/bodies/husky_ur5/base" in paths and "/robots/TransportRobot11" in paths


def test_on_a_large_model_what_the_physics_did_not_move_is_one_entity(physics_build):
    """A large model's physics (``--draw boxes``, the default on MULTICOM-Prefab): the web viewer's time
    to open grows with the entities on a timeline, so only the components the physics moved keep an
    entity of their own; the elements it did not move (here all 88 of the frame: experiment 1's column is
    none of them) stand in one mesh, ``/building/not moved by the physics``, with the same triangles at
    the same places as the meshes replay's one entity each."""
    from bimrobot.replay.elements import entity
    from bimrobot.replay.record_rcan import UNMOVED

    _, replays = physics_build
    unmoved = entity("building", UNMOVED)
    _, each = read_back(replays["meshes"][0], ["/building/**"], "physics_time")
    _, one = read_back(replays["boxes"][0], ["/building/**"], "physics_time")
    drawn = meshes_on_the_timeline(each)
    assert len(drawn) == 88 and unmoved not in drawn
    assert meshes_on_the_timeline(one) == {unmoved}
    gids = one[f"{unmoved}:global_id"].dropna().iloc[0].tolist()
    assert sorted(gids) == sorted(each[f"{path}:global_id"].dropna().iloc[0][0] for path in drawn)
    vertices = np.array(one[f"{unmoved}:Mesh3D:vertex_positions"].dropna().iloc[0].tolist())
    placed = []
    for gid in gids:
        path = next(p for p in drawn if each[f"{p}:global_id"].dropna().iloc[0][0] == gid)
        local = np.array(each[f"{path}:Mesh3D:vertex_positions"].dropna().iloc[0].tolist())
        turn = np.array(each[f"{path}:Transform3D:mat3x3"].dropna().iloc[0][0]).reshape(3, 3)  # column by column
        placed.append(local @ turn + np.array(each[f"{path}:Transform3D:translation"].dropna().iloc[0][0]))
    assert np.allclose(vertices, np.concatenate(placed), atol=1e-4)
