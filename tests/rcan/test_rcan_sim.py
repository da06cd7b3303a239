"""The sim backend: kinematic robots with travel and handling time, checks and seeded failures."""

from __future__ import annotations

import pytest

from bimrobot.rcan.activities import ActivityKind as K, Pose, RcanActivity
from bimrobot.rcan.backends.sim import SimBackend
from bimrobot.rcan.generation import load_capabilities
from bimrobot.rcan.node import RcanNode


def node(activity_id, kind, pose, weight=2.0, robot="husky_ur5", component="COL"):
    return RcanNode(f"rcan/{activity_id}", RcanActivity(activity_id, component, kind, Pose(*pose), weight), robot, "sim")


@pytest.fixture
def sim():
    backend = SimBackend(load_capabilities())
    yield backend
    backend.close()


def test_travel_and_handling_times_follow_speed_and_table(sim):
    # husky home (-3, 0, 0), 1 m/s: 3 m takes 3 s; arm from stow (0, 0, 0.5) to (0, -0.75, 0.45) at 0.5 m/s
    moved = sim.execute(node("A.1", K.MOVE_TO_COMPONENT, (0, 0, 0)))
    assert moved.success and moved.duration_s == pytest.approx(3.0)
    positioned = sim.execute(node("A.2", K.POSITION_FOR_PICKING_UP, (0, -0.75, 0.45)))
    assert positioned.duration_s == pytest.approx((0.75**2 + 0.05**2) ** 0.5 / 0.5)
    picked = sim.execute(node("A.3", K.PICK_UP, (0, -0.75, 0.45)))
    assert picked.success and picked.duration_s == pytest.approx(3.0)  # handling_s.pick_up
    assert picked.started_s == pytest.approx(positioned.finished_s)
    state = sim.site.robot_state("husky_ur5")
    assert state["holding"] == "COL" and state["base"] == Pose(0.0, 0.0, 0.0)


def test_robot_refuses_what_a_real_robot_cannot_do(sim):
    out_of_reach = sim.execute(node("B.1", K.POSITION_FOR_PICKING_UP, (0.0, 0.0, 0.0)))  # 3 m from home
    assert not out_of_reach.success and "beyond its 0.85 m reach" in out_of_reach.message
    not_at_pose = sim.execute(node("B.2", K.PICK_UP, (-3.0, 0.5, 0.2)))
    assert not not_at_pose.success and "is not at the pick up pose" in not_at_pose.message
    sim.execute(node("B.3", K.POSITION_FOR_PICKING_UP, (-3.0, 0.5, 0.2)))
    heavy = sim.execute(node("B.4", K.PICK_UP, (-3.0, 0.5, 0.2), weight=12.0))
    assert not heavy.success and "12.0 kg, over the 5.0 kg payload" in heavy.message
    wide = RcanNode("rcan/B.6", RcanActivity("B.6", "COL", K.PICK_UP, Pose(-3.0, 0.5, 0.2), 2.0, section_m=(0.3, 0.3)),
                    "husky_ur5", "sim")
    too_wide = sim.execute(wide)
    assert not too_wide.success and "the 0.300 x 0.300 m section of COL does not fit the gripper of husky_ur5" in too_wide.message
    transport = sim.execute(node("B.5", K.TRANSPORT, (2.0, 0.0, 0.0)))
    assert not transport.success and "does not hold COL" in transport.message


def test_same_goal_twice_runs_once(sim):
    first = sim.execute(node("C.1", K.MOVE_TO_COMPONENT, (1, 0, 0)))
    again = sim.execute(node("C.1", K.MOVE_TO_COMPONENT, (1, 0, 0)))
    assert again == first
    assert sim.site.executions() == [("C.1", 1, True)]
    assert sim.site.robot_state("husky_ur5")["clock_s"] == pytest.approx(4.0)


def test_failures_are_seeded_per_activity_and_attempt():
    caps = load_capabilities()
    outcomes = []
    for _ in range(2):
        sim = SimBackend(caps, failure_probability=0.5, seed=11)
        outcomes.append([sim.execute(node(f"D.{i}", K.MOVE_TO_COMPONENT, (-3, 0, 0))).success for i in range(40)])
        sim.close()
    assert outcomes[0] == outcomes[1]
    assert 8 < outcomes[0].count(False) < 32  # about half of 40 fail


def test_time_scale_sleeps_scaled_robot_time():
    import time

    sim = SimBackend(load_capabilities(), time_scale=0.05)
    started = time.perf_counter()
    result = sim.execute(node("E.1", K.MOVE_TO_COMPONENT, (1.0, 0.0, 0.0)))  # 4 s of robot time
    assert result.duration_s == pytest.approx(4.0)
    assert time.perf_counter() - started >= 0.2
    sim.close()
