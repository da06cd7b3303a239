"""What every skill of the MuJoCo site shares: its constants, its errors, and the records of a
robot, a component and a planned base path (units: metres, kg, seconds, radians; world frame, z up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bimrobot.physics import motion
from bimrobot.physics.robot import RobotModel

GRASP_POSITION_TOLERANCE_M = 0.005
GRASP_ANGLE_TOLERANCE_DEG = 2.0
# the weld's time constant (s): stiffer than MuJoCo's default 0.02 s, under which a 290 kg column held
# at its middle leans 0.16 degrees in the gripper (6 mm at its foot); twice the time step, the stiffest
# that stays stable
GRASP_TIME_CONSTANT_S = 0.004
FINGER_DEPTH_M = 0.03  # the tool centre point is this far below the top of the component when grasping
TRACKING_TOLERANCE_M = 0.01  # the tcp must end within this of its goal, else the arm could not follow
SETTLE_MAX_S = 8.0  # the longest wait for the arm to get in position after a move (while it still moves)
RECORD_HZ = 20.0
TURN_RATE_RAD_S = 1.0
JOINT_SPEED_RAD_S = 1.0
CLEARANCE_M = 0.05  # the base keeps this from obstacles on its path
REACH_PATH_FRACTIONS = (0.25, 0.5, 0.75, 1.0)  # where between two poses a stand's reach check looks for contacts
SHOVE_TOLERANCE_M = 0.005  # a component a robot touches may move this far before the motion fails
GRID_M = 0.05
PROP_CONTYPE = 8  # the collision bit of props: components meet them, robots (contype 2, conaffinity 1) do not
# robots meet each other by a collision bit of their own (robot k: 1 << (ROBOT_BIT_0 + k)) in every other
# robot's conaffinity; bit 30 is left free (ContactSkill._probe_model), so at most 26 robots have one
ROBOT_BIT_0 = 4
ROBOT_BITS = 26
TURNING_RADIUS_M = 0.1  # of the arcs of plan_poses' paths (a skid-steer base turns almost in place)
POSE_PLANS_PER_SEARCH = 3  # paths of plan_poses tried per search for a stand (each within planning.BASE_ITERATIONS)
PIT_DEPTH_M = 1.0  # thickness of the ground slab: the deepest pit
SITE_HALF_M = 200.0  # the ground slab spans +-200 m


READY_SEED = np.array([0.0, -1.5, -1.3, -1.9, 1.57, 0.0])  # elbow up, tool down in front (rad)
REACH_SEED = np.array([0.0, -1.9, -2.5, -0.3, 1.57, 0.0])  # elbow up, reaching down in front (rad)
# elbow-up seeds (shoulder lift, elbow, wrist 1, wrist 2; rad), tried when the seeds above give no
# solution clear of the ground
ELBOW_UP_SEEDS = [(lift, elbow, wrist_1, wrist_2) for lift in (-1.6, -1.2) for elbow in (-1.2, -1.8)
                  for wrist_1 in (-math.pi / 2, math.pi) for wrist_2 in (-math.pi / 2, math.pi / 2)]
# the arm folded for driving empty: upper arm up, forearm folded down behind it, within the chassis' turn
TUCK_POSTURE = np.array([0.0, -math.pi / 2, -2.9, math.pi / 2, -math.pi / 2, 0.0])


class MotionFailed(Exception):
    """An activity cannot be executed: the message says why (one sentence)."""


class Blocked(MotionFailed):
    """The robot cannot get where it must be now (no free path or stand): other robots' work may
    clear the way (a component lying in front of the one to fetch is taken away)."""


@dataclass
class PosePath:
    """A base path planned in the plane with the robot's whole body (see :meth:`MujocoSite.plan_poses`):
    poses (x, y, yaw; m, m, rad; world) about 2 cm apart, from where the base stands to its goal."""

    poses: list[np.ndarray]

    @property
    def end(self) -> np.ndarray:
        return self.poses[-1][:2]


@dataclass
class Component:
    """A box-shaped component: size (w, d, h) m, mass kg; its origin is its bottom face's centre."""

    global_id: str
    size: tuple[float, float, float]
    mass: float


@dataclass
class Robot:
    model: RobotModel
    speed_m_s: float
    arm_speed_m_s: float
    ik: motion.ArmIK
    q_ref: np.ndarray
    base_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    holding: str | None = None
    grip: np.ndarray | None = None  # the held component's pose in the gripper frame
    gains: tuple[np.ndarray, np.ndarray] | None = None
    held_gains: tuple[np.ndarray, np.ndarray] | None = None  # damped for the held component's inertia


def wrap_angle(angle: float) -> float:
    """``angle`` (rad) wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi
