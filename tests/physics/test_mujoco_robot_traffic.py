"""Robots among robots in the MuJoCo site: they collide with each other (not with themselves), plan
their ways round each other, and an idle robot standing in the only way is sent back to its start.
On the chapter-4 frame the robots' chassis overlapped for 12,032 pair-seconds before."""

import importlib.util
import numpy as np

import pytest

# found, not imported: MuJoCo and mink cost about 1 s of imports, paid when the tests run, not at collection
MISSING = [name for name in ("mujoco", "mink", "pyastar2d") if importlib.util.find_spec(name) is None]
if MISSING:
    pytest.skip(f"{', '.join(MISSING)} not installed (the physics extra)", allow_module_level=True)

from bimrobot.rcan.activities import ActivityKind, Pose, RcanActivity  # noqa: E402
from bimrobot.rcan.backends.mujoco import chassis_overlaps  # noqa: E402
from bimrobot.rcan.node import RcanNode  # noqa: E402
from mujoco_helpers import ur5_robots_at  # noqa: E402


def _footprints(backend) -> dict[str, tuple[float, float]]:
    return {name: robot.model.footprint for name, robot in backend.site.robots.items()}


def _place(site, robot: str, xy) -> None:
    """Put a robot's base at ``xy`` (m) at once (a pose to test from, not a motion)."""
    site.data.qpos[site.idx[robot]["base_q"][:2]] = xy
    site.mj.mj_forward(site.model, site.data)


def test_robots_touch_each_other_but_a_robot_does_not_touch_itself(tmp_path):
    backend = ur5_robots_at(tmp_path, {"a": (0.0, 0.0), "b": (4.0, 0.0)})
    try:
        site = backend.site
        assert site.robot_contacts("a") == [] and site.robot_contacts("b") == []  # arm over its own chassis
        _place(site, "b", (0.8, 0.0))  # chassis 0.99 m long: 0.19 m into a's
        assert "a/base touches b/base" in site.robot_contacts("a")
        assert "b/base touches a/base" in site.robot_contacts("b")
    finally:
        backend.close()


def test_a_robot_drives_round_another_that_stands_on_its_straight_way(tmp_path):
    backend = ur5_robots_at(tmp_path, {"walker": (-3.0, 0.0), "stander": (0.0, 0.0)})
    try:
        site = backend.site
        site.drive("walker", (3.0, 0.0))
        assert np.linalg.norm(site.base_xy_yaw("walker")[:2] - (3.0, 0.0)) < 0.05
        assert chassis_overlaps(site.frames, _footprints(backend)) == {}
        assert np.linalg.norm(site.base_xy_yaw("stander")[:2]) < 0.005  # not pushed
        ys = [pose[names.index("walker/base"), 1] for _, names, pose in site.frames]
        assert max(np.abs(ys)) > 0.67  # it went round: the two chassis' half widths and more
    finally:
        backend.close()


def _pen_with_a_robot_in_its_opening(tmp_path):
    """'penned' stands in a pen of walls open to the east; 'idle' (home 4, 4) stands in the opening."""
    backend = ur5_robots_at(tmp_path, {"penned": (-4.0, 0.0), "idle": (4.0, 4.0)})
    site = backend.site
    for name, (x, y, hx, hy) in {"n": (-4.0, 1.5, 3.0, 0.2), "s": (-4.0, -1.5, 3.0, 0.2),
                                 "w": (-5.5, 0.0, 0.2, 1.3)}.items():
        site.add_support(f"wall/{name}", (x, y), 1.0, (hx, hy))
    site.drive("idle", (-1.2, 0.0))
    return backend


def _move(robot: str) -> RcanNode:
    move = RcanActivity("M1", component_id="0SteelPost000000000001", kind=ActivityKind.MOVE_TO_COMPONENT,
                        target=Pose(4.0, 0.0, 0.0), weight_kg=125.6, size_m=(0.1, 0.1, 1.6))
    return RcanNode("rcan/M1", move, robot, "mujoco")


def test_an_idle_robot_standing_in_the_only_way_out_drives_back_to_its_start(tmp_path):
    backend = _pen_with_a_robot_in_its_opening(tmp_path)
    try:
        site = backend.site
        result = backend.execute(_move("penned"))
        assert result.success, result.message
        assert result.message.startswith("made way (idle drove")
        assert np.linalg.norm(site.base_xy_yaw("idle")[:2] - (4.0, 4.0)) < 0.05
        assert np.linalg.norm(site.base_xy_yaw("penned")[:2] - (4.0, 0.0)) < 0.6  # at the stand-off point
        assert chassis_overlaps(site.frames, _footprints(backend)) == {}
    finally:
        backend.close()


def test_a_robot_in_the_only_way_out_that_is_at_work_is_not_moved(tmp_path):
    backend = _pen_with_a_robot_in_its_opening(tmp_path)
    try:
        site = backend.site
        backend.engaged["idle"] = "0SomethingElse00000000001"  # in the middle of another component's chain
        result = backend.execute(_move("penned"))
        assert not result.success and "no collision-free path for penned" in result.message
        assert np.linalg.norm(site.base_xy_yaw("idle")[:2] - (-1.2, 0.0)) < 0.05
    finally:
        backend.close()


def test_a_planned_way_does_not_depend_on_how_busy_the_machine_is():
    """Issue 35: a corridor test passed alone and failed under load: the planner had a wall-clock budget.
    It is bounded by iterations and seeded: a validity check ten times slower (as on a loaded machine)
    gives the same poses, and so does a second plan after another one."""
    import time

    from bimrobot.physics import planning

    pytest.importorskip("ompl")

    def wall(x, y, yaw):  # a wall across y = 0 with a 0.6 m gap at x in [1.7, 2.3]; the robot a 0.2 m disc
        return abs(y) > 0.3 or 1.9 <= x <= 2.1

    def slow_wall(x, y, yaw):
        time.sleep(0.0002)  # slower, not different
        return wall(x, y, yaw)

    start, goal, lower, upper = (0.0, -2.0, 0.0), (4.0, 2.0, 1.57), (-1.0, -3.0), (5.0, 3.0)
    fast = planning.base_path(wall, start, goal, lower, upper, iterations=planning.BASE_ITERATIONS)
    assert fast is not None and all(wall(*pose) for pose in fast)
    planning.joint_path(lambda q: True, [0.0, 0.0], [1.0, 1.0], [-3.0, -3.0], [3.0, 3.0])  # a plan between
    slow = planning.base_path(slow_wall, start, goal, lower, upper, iterations=planning.BASE_ITERATIONS)
    assert slow is not None and len(slow) == len(fast)
    assert np.array_equal(np.array(slow), np.array(fast))  # byte for byte the same way
    with pytest.raises(TypeError):
        planning.base_path(wall, start, goal, lower, upper, seconds=1.0)  # no time budget any more
