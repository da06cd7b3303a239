"""The `mujoco` RCAN backend: robots of the family build the thesis' experiments physically in MuJoCo."""

import dataclasses
import importlib.util
import re
import time

import numpy as np
import pytest

# found, not imported: MuJoCo and mink cost about 1 s of imports, paid when the tests run, not at collection
MISSING = [name for name in ("mujoco", "mink", "pyastar2d") if importlib.util.find_spec(name) is None]
if MISSING:
    pytest.skip(f"{', '.join(MISSING)} not installed (the physics extra)", allow_module_level=True)

from bimrobot.physics.robot import robot_model  # noqa: E402
from bimrobot.rcan.activities import ActivityKind  # noqa: E402
from bimrobot.rcan.backends import create_backend  # noqa: E402
from bimrobot.rcan.generation import load_capabilities  # noqa: E402
from bimrobot.rcan.node import RcanNode  # noqa: E402
from bimrobot.rcan.plans import experiment  # noqa: E402
from bimrobot.rcan.system import run_plan  # noqa: E402


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """The MuJoCo site (MuJoCo, mink and trimesh: about 2 s of imports), imported when these tests run,
    not at collection."""
    global MujocoSite
    from bimrobot.physics.site import MujocoSite


PLACED = re.compile(r"placement error ([0-9.]+) mm, ([0-9.]+) degrees")


@pytest.mark.parametrize("number", [1, 2, 3])
def test_experiment_ends_assembled_at_the_bim_pose(number, tmp_path):
    lines = []
    state_db = tmp_path / "run.sqlite"
    report = run_plan(list(experiment(number).activities), load_capabilities(), backend="mujoco",
                      state_db=str(state_db), log=lines.append)
    assert report.status == "completed", lines[-5:]
    assert set(report.component_states.values()) == {"Assembled"}
    placed = [PLACED.search(line) for line in lines if "placement error" in line]
    assert placed, "the install reported no placement error"
    position_mm, angle_deg = map(float, placed[-1].groups())
    assert position_mm < 10.0 and angle_deg < 1.0
    trajectory = state_db.with_name("run.sqlite.trajectory.csv")
    rows = trajectory.read_text().splitlines()
    assert rows[0].startswith("# written by bimrobot") and rows[1].startswith("time_s,body,")
    assert any(",husky_ur5/base," in row for row in rows[2:200])  # every body at 20 Hz, the robot among them


def _nodes(number: int, **changes):
    return [RcanNode(f"rcan/{a.activity_id}", dataclasses.replace(a, **changes), "husky_ur5", "mujoco")
            for a in experiment(number).activities]


def test_over_weight_component_makes_pick_up_fail_naming_the_payload():
    backend = create_backend("mujoco", load_capabilities())
    try:
        results = []
        for node in _nodes(1, weight_kg=40.0):
            results.append(backend.execute(node))
            if not results[-1].success:
                break
        failed = results[-1]
        assert not failed.success and failed.activity_id.endswith(".3")  # the pick-up (E1.3)
        assert "weighs 40.0 kg" in failed.message and "rated payload 5.0 kg" in failed.message
        assert "torque limit" in failed.message
        assert backend.site.robots["husky_ur5"].holding is None  # the gripper let go
    finally:
        backend.close()


def test_the_rated_payload_is_lifted():
    backend = create_backend("mujoco", load_capabilities())
    try:
        results = [backend.execute(node) for node in _nodes(1, weight_kg=5.0)[:3]]
        assert all(r.success for r in results), results[-1].message
    finally:
        backend.close()


def test_a_path_blocked_by_an_installed_column_is_driven_around():
    husky = robot_model("husky_ur5", 5.0, 0.85, 0.12)
    site = MujocoSite({"husky_ur5": (husky, 1.0, 0.5, (-3.0, 0.0))})
    site.add_support("column", (0.0, 0.0), 3.0, (0.125, 0.125))  # a W250 column, installed, in the way
    waypoints = site.plan_path("husky_ur5", (3.0, 0.0))
    assert len(waypoints) >= 2  # not straight through
    lateral = []
    original_step = site.step

    def step(seconds):
        original_step(seconds)
        lateral.append(abs(site.base_xy_yaw("husky_ur5")[1]))
        assert not site.robot_contacts("husky_ur5")

    site.step = step
    site.drive("husky_ur5", (3.0, 0.0))
    assert np.linalg.norm(site.base_xy_yaw("husky_ur5")[:2] - [3.0, 0.0]) < 0.01
    assert max(lateral) > 0.125 + husky.footprint[1] / 2  # it went around the column


def test_a_goal_too_near_a_column_whose_nearest_free_spot_is_where_the_robot_stands_gives_that_spot():
    """The grid path to a goal within a column's clearance ends at the nearest free cell; when that
    was the robot's own cell the path was empty, and the search for a stand failed with an
    IndexError on the frame's yard instead of trying the stand."""
    from bimrobot.physics.site import CLEARANCE_M

    husky = robot_model("husky_ur5", 5.0, 0.85, 0.12)
    site = MujocoSite({"husky_ur5": (husky, 1.0, 0.5, (0.0, 0.0))})
    site.add_support("column", (0.0, 0.0), 3.0, (0.125, 0.125))
    # 1 mm outside the column's clearance: exactly on its edge, whether the robot's cell counts free
    # is decided by the last bit of a float
    x = -(0.125 + site.sweep_radius("husky_ur5") + CLEARANCE_M + 0.001)
    site.data.qpos[site.idx["husky_ur5"]["base_q"]] = [x, 0.0, 0.0]
    site.mj.mj_forward(site.model, site.data)
    path = site.plan_path("husky_ur5", (x + 0.03, 0.0))  # 3 cm nearer: inside it
    assert len(path) == 1 and np.linalg.norm(path[0] - (x, 0.0)) < 0.03  # stay: the nearest free spot


def test_a_robot_whose_corner_is_where_a_component_is_about_to_be_laid_does_not_stay_there():
    """A robot at a good distance from its work stayed where it stood when a circle of its half
    width around its centre was clear of what was about to appear: on the frame a transport's corner
    was where it then laid a column down, which shoved the robot 0.2 m. Its chassis as it will stand
    (turned to its work) must be clear."""
    husky = robot_model("husky_ur5", 5.0, 0.85, 0.12)
    site = MujocoSite({"husky_ur5": (husky, 1.0, 0.5, (0.0, 0.0))})
    about_to_appear = (np.array([0.4, 0.46]), np.array([0.08, 0.14]))  # off the chassis' front left corner
    assert not site.near_box(np.zeros(2), [about_to_appear], husky.footprint[1] / 2)  # the circle misses it
    assert not site.footprint_clear("husky_ur5", np.zeros(2), 0.0, [about_to_appear], 0.0)  # the corner does not
    site.approach("husky_ur5", (0.6, 0.0), low_keep_out=[about_to_appear])
    x, y, yaw = site.base_xy_yaw("husky_ur5")
    assert site.footprint_clear("husky_ur5", (x, y), yaw, [about_to_appear], 0.0)


def test_heavy_variant_for_heavy_payloads_and_torque_limits_from_the_payload():
    ur5 = robot_model("husky_ur5", 5.0, 0.85, 0.12)
    assert ur5.family == "ur5"
    assert ur5.torque_limits[1] == pytest.approx(150, rel=0.05)  # UR5's published shoulder torque: 150 Nm
    heavy = robot_model("heavy_mobile_manipulator", 5000.0, 6.0, 1.5)
    assert heavy.family == "heavy" and heavy.scale == pytest.approx(6.0 / 0.85)
    assert heavy.torque_limits[1] > 5000 * 9.81 * 6.0  # holds its payload at full reach


def test_backend_is_registered_and_refuses_an_unknown_component_shape():
    backend = create_backend("mujoco", load_capabilities())
    try:
        node = _nodes(1, component_id="0Unknown00000000000000", size_m=None)[1]  # a plan without sizes
        assert node.kind is ActivityKind.POSITION_FOR_PICKING_UP
        result = backend.execute(node)
        assert not result.success and "shape of 0Unknown00000000000000 is unknown" in result.message
    finally:
        backend.close()


@pytest.fixture(scope="module")
def frame_starts(tmp_path_factory):
    """The chapter-4 frame's first two activities (fleet 2's schedule): two robots' *move to
    component*, both ready at 0 s."""
    from bimrobot.bim import load_model
    from bimrobot.bim.examples import steel_frame
    from bimrobot.site.fleet import load_fleet
    from bimrobot.coordination.schedule import write_schedule_csv
    from bimrobot.coordination.simulation import simulate
    from bimrobot.schedule.csv import load_schedule_csv
    from bimrobot.rcan.plans import plan_from_schedule
    from bimrobot.sco import build_smart_model

    folder = tmp_path_factory.mktemp("frame")
    model = load_model(steel_frame(folder / "frame.ifc"))
    result = simulate(build_smart_model(model), load_fleet("fleet2"), storey_elevations=[s.elevation for s in model.storeys])
    schedule = load_schedule_csv(write_schedule_csv(result.activities, folder / "schedule.csv"), model)
    first, second = [a for a in plan_from_schedule(schedule, model) if not a.predecessors][:2]
    assert first.robot != second.robot and first.kind is second.kind is ActivityKind.MOVE_TO_COMPONENT
    return first, second


@pytest.mark.slow
def test_two_robots_ready_at_once_act_in_the_plans_order_whichever_thread_comes_first(frame_starts, tmp_path, monkeypatch):
    """Robots share one physical world and act one at a time. Which of two activities ready at the
    same simulated time acts first must not depend on which executor thread reaches the world first
    (it did: runs of the same frame differed); here the plan's first activity arrives 0.5 s late."""
    from bimrobot.rcan.backends.mujoco import MujocoBackend

    first, second = frame_starts

    execute, arrived = MujocoBackend.execute, []

    def late_first(self, node, *args, **kwargs):
        if node.activity_id == first.activity_id:
            time.sleep(0.5)  # the first activity's thread is slow to reach the world
        arrived.append(node.activity_id)
        return execute(self, node, *args, **kwargs)

    monkeypatch.setattr(MujocoBackend, "execute", late_first)
    report = run_plan([first, second], load_capabilities("fleet2"), backend="mujoco", state_db=str(tmp_path / "run.db"))
    assert arrived == [second.activity_id, first.activity_id]
    assert report.status == "completed"
    times = {a: (row["started_s"], row["finished_s"]) for a, row in report.activities.items()}
    assert times[first.activity_id][0] == 0.0  # it acted first, although its thread came second
    assert times[second.activity_id][0] == times[first.activity_id][1] > 0.0


@pytest.mark.slow
def test_a_blocked_activity_gives_its_turn_away_and_fails_at_once_when_nothing_can_clear_its_way(frame_starts, tmp_path,
                                                                                               monkeypatch):
    """The first activity finds its way blocked until the second is done: it acts again after it and
    succeeds. Blocked for good, with nothing else under way, it fails at once (it used to wait real
    seconds for work that could not come) and RCAN escalates it after its retries."""
    from bimrobot.physics.site import Blocked
    from bimrobot.rcan.backends.mujoco import MujocoBackend

    first, second = frame_starts
    drive, tries = MujocoBackend._move_to_component, []

    def blocked_until_second_done(self, node):
        tries.append(node.activity_id)
        if node.activity_id == first.activity_id and (second.activity_id, 1) not in self._results:
            raise Blocked(f"{node.robot}: the way is blocked by the other robot")
        return drive(self, node)

    monkeypatch.setattr(MujocoBackend, "_move_to_component", blocked_until_second_done)
    report = run_plan([first, second], load_capabilities("fleet2"), backend="mujoco", state_db=str(tmp_path / "a.db"))
    assert report.status == "completed"
    assert tries == [first.activity_id, second.activity_id, first.activity_id]
    assert report.activities[first.activity_id]["started_s"] == 0.0  # its first try
    assert report.activities[first.activity_id]["finished_s"] > report.activities[second.activity_id]["finished_s"]

    def always_blocked(self, node):
        tries.append(node.activity_id)
        if node.activity_id == first.activity_id:
            raise Blocked(f"{node.robot}: the way is blocked by a wall")
        return drive(self, node)

    monkeypatch.setattr(MujocoBackend, "_move_to_component", always_blocked)
    tries.clear()
    report = run_plan([first, second], load_capabilities("fleet2"), backend="mujoco", state_db=str(tmp_path / "b.db"),
                      max_attempts=2)
    assert report.status == "escalated" and [e.activity_id for e in report.escalations] == [first.activity_id]
    assert "blocked by a wall" in report.escalations[0].message
    assert second.activity_id in report.done
    # attempt 1: blocked, the second acts, blocked again, then it fails (nothing else can change the
    # world); attempt 2: blocked, fails. No try is repeated while nothing changed.
    assert tries == [first.activity_id, second.activity_id, first.activity_id, first.activity_id]


def test_the_run_reports_how_long_two_robots_chassis_overlapped():
    """Robots collide and plan round each other; should two chassis overlap anyway (a fleet of more
    robots than the scene has collision bits), the summary says for how long each pair did, from the
    recorded frames (20 Hz)."""
    from bimrobot.rcan.backends.mujoco import chassis_overlaps

    names = ["a/base", "a/arm_base", "b/base"]
    footprints = {"a": (2.0, 1.0), "b": (2.0, 1.0)}

    def frame(t, bx, b_yaw=0.0):
        poses = np.zeros((3, 7))
        poses[:, 3] = 1.0
        poses[2, 0] = bx
        poses[2, 3], poses[2, 6] = np.cos(b_yaw / 2), np.sin(b_yaw / 2)
        return (t, names, poses)

    # b drives towards a along x: the boxes overlap once their centres are nearer than 2 m
    frames = [frame(k / 20, 4.0 - 0.1 * k) for k in range(30)]
    assert chassis_overlaps(frames, footprints) == {"a & b": 0.45}  # 1.9 m down to 1.1 m apart (at 2.0 they touch): 9 frames
    # turned by 90 degrees at 1.4 m, b's 1 m wide side faces a: 0.5 + 1.0 = 1.5 > 1.4, they overlap
    assert chassis_overlaps([frame(0.0, 1.4, np.pi / 2)], footprints) == {"a & b": 0.05}
    assert chassis_overlaps([frame(0.0, 1.6, np.pi / 2)], footprints) == {}


def test_the_trajectory_file_keeps_only_what_moved_and_every_pose_can_be_read_back_from_it():
    """Written at 20 Hz for every body, a frame run's trajectory was 726 MB. Only groups that moved are
    written (a robot's links together, so its arm is drawn whole), with the frame before a move starts:
    every body's pose at every frame is still the last row at or before it, and linear interpolation
    between rows gives it too."""
    from bimrobot.rcan.backends.mujoco import TRAJECTORY_POSITION_M, trajectory_rows

    def pose(x, y=0.0):
        return [x, y, 0.0, 1.0, 0.0, 0.0, 0.0]

    frames = []
    before, after = ("r/base", "r/arm", "c"), ("r/base", "r/arm", "c", "s")  # a support appears at frame 25
    for k in range(40):
        robot_x = 0.1 * min(max(k - 10, 0), 10)  # drives from frame 10 to 20
        component_y = 0.2 * min(max(k - 30, 0), 5)  # pushed from frame 30 to 35
        rows = [pose(robot_x), pose(robot_x + 0.3, 0.5), pose(5.0, component_y)]
        names = before if k < 25 else after
        frames.append((k / 20, names, np.array(rows + ([pose(9.0)] if k >= 25 else []))))
    written = list(trajectory_rows(frames))
    tracks = {}
    for t, names, poses in written:
        for name, row in zip(names, poses):
            tracks.setdefault(name, []).append((t, row))
    assert sum(len(names) for _, names, _ in written) < 0.5 * sum(len(f[1]) for f in frames)
    assert [len(tracks[n]) for n in ("r/base", "r/arm")] == [len(tracks["r/base"])] * 2  # the robot's links together
    for t, names, poses in frames:
        for name, row in zip(names, poses):
            times = np.array([s for s, _ in tracks[name]])
            values = np.array([r for _, r in tracks[name]])
            latest = values[np.searchsorted(times, t, side="right") - 1]
            interpolated = [np.interp(t, times, values[:, i]) for i in range(7)]
            assert np.abs(latest - row).max() <= TRAJECTORY_POSITION_M, (name, t)
            assert np.abs(interpolated - row).max() <= TRAJECTORY_POSITION_M, (name, t)
    assert {n for n in tracks if tracks[n][-1][0] == frames[-1][0]} == set(after)  # all at the last frame


def test_robots_that_share_a_home_start_side_by_side_further_from_the_work():
    """Fleet 2's six robots share the site's four homes: two pairs started inside each other. The
    later robot of a pair starts clear of the first, on the line from the work through the home."""
    from bimrobot.rcan.backends.mujoco import START_GAP_M, starts_apart

    heavy, light = (2.33, 1.58), (1.16, 0.79)
    starts = starts_apart({"transport": ((18.5, 4.0), light), "other": ((18.5, 6.0), light),
                           "assembly": ((18.5, 4.0), heavy)}, work_xy=(3.0, 4.0))
    assert starts["transport"] == (18.5, 4.0) and starts["other"] == (18.5, 6.0)  # their own homes
    x, y = starts["assembly"]
    assert y == 4.0 and x > 18.5  # behind the transport, away from the work at x = 3
    assert x - 18.5 >= (heavy[0] + light[0]) / 2 + START_GAP_M  # chassis clear of each other
    assert x - 18.5 < (heavy[0] + light[0]) / 2 + START_GAP_M + 0.25  # and no further than a step past that


def test_a_robot_whose_home_the_yard_covers_starts_clear_of_the_components_lying_there():
    """The yard's rows may reach over a home: the robot starts beyond the component lying there, on the
    line from the work through its home, instead of inside it."""
    from bimrobot.rcan.activities import ActivityKind as K, Pose, RcanActivity
    from bimrobot.rcan.backends.mujoco import START_GAP_M, starts_apart, yard_footprints

    # a 4 m column lying along x on the yard, centred on (13, 1), as the package lays it
    column = [RcanActivity("A1.2", "C", K.POSITION_FOR_PICKING_UP, Pose(13.0, 1.0, 0.127), weight_kg=290.0,
                           size_m=(0.254, 0.254, 4.0)),
              RcanActivity("A1.4", "C", K.POSITION_FOR_INSTALLING, Pose(0.0, 0.0, 0.0), weight_kg=290.0,
                           size_m=(0.254, 0.254, 4.0))]
    (lying,) = yard_footprints(column, shapes={})
    assert lying == ((13.0, 1.0), pytest.approx((4.0, 0.254)))
    light = (1.16, 0.79)
    starts = starts_apart({"transport": ((13.2, 1.0), light)}, work_xy=(1.4, 1.0), obstacles=[lying])
    x, y = starts["transport"]
    assert y == 1.0 and x - 13.0 >= (4.0 + light[0]) / 2 + START_GAP_M  # beyond the column's end
    assert x - 13.0 < (4.0 + light[0]) / 2 + START_GAP_M + 0.25
