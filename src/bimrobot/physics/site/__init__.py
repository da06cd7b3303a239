"""A construction site in MuJoCo where robots of the family act: drive, reach, grasp, place.

:class:`MujocoSite` holds one MuJoCo model: ground, the robots at their homes, and the components and
supports added as they become known (``MjSpec.recompile`` keeps the state). It is made of skills, one
module each, every one with its public methods listed in its docstring; they share the site's state
(the model and data, the robots, the components), which :mod:`.world` builds:

=================  ===============================================================================
:mod:`.world`      the model: ground slab and pits, robots, components, supports; poses
:mod:`.control`    simulated time: the arms' PD + gravity-compensation torques, the bases' velocities,
                   the recorded frames
:mod:`.contacts`   what a robot touches, would touch at other joints or stands, and has pushed
:mod:`.clearance`  what a base keeps away from (boxes in plan view), sweep radius, footprint checks
:mod:`.paths`      the base's paths: occupancy grid + A*, or OMPL in the plane with its whole body
:mod:`.base`       driving, turning in place, backing out, facing the work
:mod:`.stands`     where the base stands to work (path, turn and the arm's reach checked first)
:mod:`.arm`        inverse kinematics, joint-space and Cartesian moves, resting and carry postures
:mod:`.grasp`      the weld grasp and letting go
=================  ===============================================================================

Each robot's arm is torque controlled by a joint-space PD law plus gravity compensation of its links
and of the component it holds (the robot knows the component's BIM weight), every torque clipped to
the joint's limit: an arm asked to lift more than its limits allow sags, and the motion fails.

Grasp: a weld constraint between the gripper and the component, switched on only when the tool
centre point is within :data:`GRASP_POSITION_TOLERANCE_M` and :data:`GRASP_ANGLE_TOLERANCE_DEG` of the
grasp pose. Trajectories: the pose of every body at :data:`RECORD_HZ`, simulated time.

Robots collide with the building, the components and each other (a collision bit per robot), not
with their own links; the other robots, as they stand, are obstacles of every robot's paths and
stands (:meth:`MujocoSite.obstacles`). A held component collides with the ground and the supports only.
The site knows nothing of RCAN: its callers (:mod:`bimrobot.rcan.backends.mujoco`) use its public
methods only. Units: metres, kg, seconds, radians; world frame, z up.
"""

from __future__ import annotations

from bimrobot.physics.site.arm import ArmSkill
from bimrobot.physics.site.base import BaseSkill
from bimrobot.physics.site.clearance import ClearanceSkill
from bimrobot.physics.site.common import (CLEARANCE_M, ELBOW_UP_SEEDS, FINGER_DEPTH_M, GRASP_ANGLE_TOLERANCE_DEG,
                                          GRASP_POSITION_TOLERANCE_M, GRASP_TIME_CONSTANT_S, GRID_M,
                                          JOINT_SPEED_RAD_S, PIT_DEPTH_M, POSE_PLANS_PER_SEARCH, PROP_CONTYPE,
                                          REACH_PATH_FRACTIONS, REACH_SEED, READY_SEED, RECORD_HZ, ROBOT_BIT_0,
                                          ROBOT_BITS, SETTLE_MAX_S, SHOVE_TOLERANCE_M, SITE_HALF_M,
                                          TRACKING_TOLERANCE_M, TUCK_POSTURE, TURN_RATE_RAD_S, TURNING_RADIUS_M,
                                          Blocked, Component, MotionFailed, PosePath, Robot, wrap_angle)
from bimrobot.physics.site.contacts import ContactSkill
from bimrobot.physics.site.control import ControlSkill
from bimrobot.physics.site.grasp import GraspSkill
from bimrobot.physics.site.paths import PathSkill
from bimrobot.physics.site.stands import StandSkill
from bimrobot.physics.site.world import WorldSkill, ready_joints

__all__ = [
    "MujocoSite", "Component", "Robot", "PosePath", "MotionFailed", "Blocked", "ready_joints", "wrap_angle",
    "WorldSkill", "ControlSkill", "ContactSkill", "ClearanceSkill", "PathSkill", "BaseSkill", "StandSkill",
    "ArmSkill", "GraspSkill",
    "CLEARANCE_M", "ELBOW_UP_SEEDS", "FINGER_DEPTH_M", "GRASP_ANGLE_TOLERANCE_DEG", "GRASP_POSITION_TOLERANCE_M",
    "GRASP_TIME_CONSTANT_S", "GRID_M", "JOINT_SPEED_RAD_S", "PIT_DEPTH_M", "POSE_PLANS_PER_SEARCH", "PROP_CONTYPE",
    "REACH_PATH_FRACTIONS", "REACH_SEED", "READY_SEED", "RECORD_HZ", "ROBOT_BIT_0", "ROBOT_BITS", "SETTLE_MAX_S",
    "SHOVE_TOLERANCE_M", "SITE_HALF_M", "TRACKING_TOLERANCE_M", "TUCK_POSTURE", "TURN_RATE_RAD_S",
    "TURNING_RADIUS_M",
]


class MujocoSite(WorldSkill, ControlSkill, ContactSkill, ClearanceSkill, PathSkill, BaseSkill, StandSkill,
                 ArmSkill, GraspSkill):
    """Robots, components and supports in one MuJoCo model (see the module docstring): the skills
    together on one state, built by :class:`WorldSkill`'s constructor
    (``MujocoSite(robots, ground_z)``: ``robots`` name -> (family model, base speed m/s, arm speed m/s,
    home (x, y) m); ``ground_z`` m)."""
