"""The mobile manipulator family in MJCF: a wheeled base, a 6-axis arm of the UR5's kinematics, a gripper.

**Base.** A box of the robot's footprint (Clearpath Husky: 0.99 x 0.67 x 0.39 m, 50 kg, when the fleet
gives none) on three joints: slide x, slide y (world frame) and hinge yaw, each driven by a velocity
actuator (the base is velocity controlled, as a skid-steer base's controller is). Its wheels are drawn,
not simulated: the base does not tip and does not slip, and it collides with the building and the
components (not with the ground, which it rides on).

**Arm.** The UR5's published Denavit-Hartenberg parameters (Universal Robots, "DH parameters for
calculations of kinematics and dynamics"): d1 = 0.089159, a2 = -0.425, a3 = -0.39225, d4 = 0.10915,
d5 = 0.09465, d6 = 0.0823 m, alpha = (pi/2, 0, 0, pi/2, -pi/2, 0); link masses 3.7, 8.393, 2.275,
1.219, 1.219, 0.1879 kg with the centres of mass of the same table; joint range +-2 pi (the elbow
+-pi: it cannot fold through its own upper arm). Each joint is a torque-limited motor. The **torque
limits come from the payload**: 1.5 x the static torque each joint needs to hold the arm stretched
horizontally with the rated payload at the tool centre point (1.5: headroom to accelerate). For the UR5
with 5 kg this gives 151/151/56 Nm for base/shoulder/elbow (UR publishes 150/150/150) and 30 Nm at
the wrists (published 28): the model lifts what the rating says and not much more.

**Gripper.** Two parallel fingers on slide joints (position actuators), opening up to the fleet
entry's gripper opening; its tool centre point (site ``tcp``) is :data:`GRIPPER_LENGTH_M` beyond
the flange, between the finger tips. The fingers do not collide: a grasp is a weld constraint (see
:mod:`bimrobot.physics.motion`).

**Family.** A fleet entry becomes ``ur5`` when its payload is at most 5 kg and its reach at most
0.85 m (the Husky + UR5 of the thesis); any other becomes ``heavy``: the UR5 geometry scaled by
reach / 0.85 (link lengths, footprint), link masses by payload / 5, and torque limits recomputed from
its payload and reach by the rule above (masses x lever arms: payload x reach). See :func:`family_of`.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

UR5_REACH_M = 0.85
UR5_PAYLOAD_KG = 5.0
UR5_DH_A = (0.0, -0.425, -0.39225, 0.0, 0.0, 0.0)
UR5_DH_D = (0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823)
UR5_DH_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
UR5_MASSES = (3.7, 8.393, 2.275, 1.219, 1.219, 0.1879)
# centres of mass in each DH link frame (UR's dynamics table), metres
UR5_COMS = ((0.0, -0.02561, 0.00193), (0.2125, 0.0, 0.11336), (0.15, 0.0, 0.0265),
            (0.0, -0.0018, 0.01634), (0.0, 0.0018, 0.01634), (0.0, 0.0, -0.001159))
JOINT_NAMES = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
TORQUE_HEADROOM = 1.5
GRIPPER_LENGTH_M = 0.16
GRIPPER_MASS_KG = 1.0
HUSKY_FOOTPRINT_M = (0.99, 0.67)
HUSKY_HEIGHT_M = 0.39
HUSKY_MASS_KG = 50.0
GRAVITY = 9.81


@dataclass(frozen=True)
class RobotModel:
    """One robot of the family, in SI units. ``scale``: lengths x scale of the UR5's; ``mass_scale``:
    link masses x of the UR5's; ``torque_limits``: Nm per arm joint; ``footprint``: base (length, width)."""

    name: str
    family: str
    payload_kg: float
    reach_m: float
    scale: float
    mass_scale: float
    torque_limits: tuple[float, ...]
    footprint: tuple[float, float]
    base_height: float
    base_mass: float
    gripper_opening: float

    @property
    def dh(self) -> list[tuple[float, float, float]]:
        """(a, d, alpha) per joint, metres and radians."""
        return [(a * self.scale, d * self.scale, alpha) for a, d, alpha in zip(UR5_DH_A, UR5_DH_D, UR5_DH_ALPHA)]

    @property
    def link_masses(self) -> list[float]:
        return [m * self.mass_scale for m in UR5_MASSES]

    @property
    def arm_mount(self) -> np.ndarray:
        """Arm base in the base frame: on top, a quarter of the length forward (m)."""
        return np.array([self.footprint[0] / 4, 0.0, self.base_height])


def family_of(payload_kg: float, reach_m: float) -> str:
    """``ur5`` for payload <= 5 kg and reach <= 0.85 m, else ``heavy`` (see the module docstring)."""
    return "ur5" if payload_kg <= UR5_PAYLOAD_KG + 1e-9 and reach_m <= UR5_REACH_M + 1e-9 else "heavy"


def robot_model(name: str, payload_kg: float, reach_m: float, gripper_opening_m: float | None = None,
                footprint_m: tuple[float, float] | None = None) -> RobotModel:
    """The family member for a fleet robot (payload kg, horizontal reach m)."""
    family = family_of(payload_kg, reach_m)
    scale = 1.0 if family == "ur5" else max(reach_m / UR5_REACH_M, 1.0)
    mass_scale = 1.0 if family == "ur5" else max(payload_kg / UR5_PAYLOAD_KG, 1.0)
    rated = UR5_PAYLOAD_KG if family == "ur5" else payload_kg
    footprint = footprint_m or (HUSKY_FOOTPRINT_M[0] * max(scale / 2, 1), HUSKY_FOOTPRINT_M[1] * max(scale / 2, 1))
    opening = gripper_opening_m or 0.12 * scale
    model = RobotModel(name, family, float(payload_kg), float(reach_m), scale, mass_scale, (), tuple(footprint),
                       HUSKY_HEIGHT_M * max(scale / 2, 1), HUSKY_MASS_KG * mass_scale, float(opening))
    return RobotModel(**{**model.__dict__, "torque_limits": torque_limits(model, rated)})


def torque_limits(model: RobotModel, payload_kg: float) -> tuple[float, ...]:
    """Per joint: TORQUE_HEADROOM x the static torque to hold the arm stretched horizontally with
    ``payload_kg`` at the tool centre point (the base joint gets the shoulder's)."""
    a = [abs(v) for v, _, _ in model.dh]
    d = [v for _, v, _ in model.dh]
    # horizontal distance from the shoulder-lift axis of each link's centre and of the tcp, stretched
    reach = [0.0, a[1] / 2, a[1] + a[2] / 2, a[1] + a[2], a[1] + a[2], a[1] + a[2]]
    tcp = a[1] + a[2]
    masses = model.link_masses
    gripper = GRIPPER_MASS_KG * model.mass_scale

    def held_from(joint: int, start: float) -> float:
        links = sum(m * (r - start) for m, r in zip(masses[joint:], reach[joint:]) if r > start)
        return GRAVITY * (links + (gripper + payload_kg) * (tcp - start))

    shoulder = held_from(1, 0.0)
    elbow = held_from(2, a[1])
    wrist = GRAVITY * (gripper + payload_kg) * (d[4] + d[5] + GRIPPER_LENGTH_M * model.scale)
    return tuple(round(TORQUE_HEADROOM * t, 3) for t in (shoulder, shoulder, elbow, wrist, wrist, wrist))


def _num(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


def _rx_quat(alpha: float) -> str:
    return _num([math.cos(alpha / 2), math.sin(alpha / 2), 0, 0])


def _cylinder_inertia(mass: float, radius: float, length: float) -> str:
    side = mass * (3 * radius**2 + length**2) / 12
    return _num([max(side, 1e-6), max(side, 1e-6), max(mass * radius**2 / 2, 1e-6)])


def add_arm(parent: ET.Element, robot: RobotModel, prefix: str) -> None:
    """The arm chain, gripper and tcp site under ``parent`` (the arm base frame: z up, x forward).

    Body ``i`` holds joint ``i`` about its z axis; its child sits at Tz(d) Tx(a) Rx(alpha) (DH)."""
    s = robot.scale
    radius = 0.06 * s
    body = parent
    for i, ((a, d, alpha), mass, com, name) in enumerate(zip(robot.dh, robot.link_masses, UR5_COMS, JOINT_NAMES)):
        frame = ET.SubElement(body, "body", name=f"{prefix}{name}_link",
                              pos=_num([0, 0, 0]) if i == 0 else _num(pending[0]), quat=pending[1] if i else "1 0 0 0")
        limit = math.pi if name == "elbow" else 2 * math.pi
        ET.SubElement(frame, "joint", name=f"{prefix}{name}", type="hinge", axis="0 0 1", range=_num([-limit, limit]),
                      damping=f"{2.0 * robot.mass_scale * s:.6g}", armature=f"{0.1 * robot.mass_scale * s * s:.6g}")
        # the link's body lies between this joint and the next: from z = 0 up by d, then along x by a
        # (in this frame, before the joint's own rotation is applied: it rotates with the joint)
        length = max(math.hypot(a, d), radius)
        ET.SubElement(frame, "inertial", pos=_num(np.array([a, 0, d]) / 2), mass=f"{mass:.6g}",
                      diaginertia=_cylinder_inertia(mass, radius, length))
        if abs(d) > 1e-9:
            ET.SubElement(frame, "geom", name=f"{prefix}{name}_d", type="capsule", fromto=_num([0, 0, 0, 0, 0, d]),
                          size=f"{radius:.6g}", rgba="0.7 0.75 0.8 1", contype="2", conaffinity="1")
        if abs(a) > 1e-9:
            ET.SubElement(frame, "geom", name=f"{prefix}{name}_a", type="capsule", fromto=_num([0, 0, d, a, 0, d]),
                          size=f"{radius * 0.85:.6g}", rgba="0.3 0.55 0.75 1", contype="2", conaffinity="1")
        pending = ([a, 0, d], _rx_quat(alpha))
        body = frame
    flange = ET.SubElement(body, "body", name=f"{prefix}gripper", pos=_num(pending[0]), quat=pending[1])
    length = GRIPPER_LENGTH_M * s
    gripper_mass = GRIPPER_MASS_KG * robot.mass_scale
    ET.SubElement(flange, "inertial", pos=_num([0, 0, length / 3]), mass=f"{gripper_mass:.6g}",
                  diaginertia=_cylinder_inertia(gripper_mass, 0.04 * s, length))
    ET.SubElement(flange, "geom", name=f"{prefix}palm", type="box", pos=_num([0, 0, 0.3 * length]),
                  size=_num([0.03 * s, robot.gripper_opening / 2 + 0.02 * s, 0.3 * length]), rgba="0.2 0.2 0.2 1",
                  contype="2", conaffinity="1")
    ET.SubElement(flange, "site", name=f"{prefix}tcp", pos=_num([0, 0, length]), size=f"{0.01 * s:.6g}", rgba="1 0 0 1")
    for side, sign in (("left", 1), ("right", -1)):
        finger = ET.SubElement(flange, "body", name=f"{prefix}finger_{side}", pos=_num([0, 0, 0.6 * length]))
        ET.SubElement(finger, "joint", name=f"{prefix}finger_{side}", type="slide", axis=_num([0, sign, 0]),
                      range=_num([0, robot.gripper_opening / 2]), damping="5")
        ET.SubElement(finger, "inertial", pos="0 0 0", mass="0.1", diaginertia="1e-4 1e-4 1e-4")
        ET.SubElement(finger, "geom", name=f"{prefix}finger_{side}", type="box",
                      pos=_num([0, 0, 0.25 * length]), size=_num([0.02 * s, 0.006 * s, 0.22 * length]),
                      rgba="0.15 0.15 0.15 1", contype="0", conaffinity="0")


def add_robot(world: ET.Element, actuators: ET.Element, robot: RobotModel, home_xy, ground_z: float) -> None:
    """The mobile manipulator ``robot.name`` on the ground: base joints ``<name>/x``, ``<name>/y``
    (world position, m: set them to ``home_xy`` after compiling), ``<name>/yaw``, with velocity
    actuators; the arm's motors; the gripper."""
    p = f"{robot.name}/"
    length, width = robot.footprint
    height = robot.base_height
    # the base frame's joints measure from the world origin (set qpos x, y to the home position)
    base = ET.SubElement(world, "body", name=f"{p}base", pos=_num([0.0, 0.0, ground_z]))
    ET.SubElement(base, "joint", name=f"{p}x", type="slide", axis="1 0 0", damping="0")
    ET.SubElement(base, "joint", name=f"{p}y", type="slide", axis="0 1 0", damping="0")
    ET.SubElement(base, "joint", name=f"{p}yaw", type="hinge", axis="0 0 1", damping="0")
    izz = robot.base_mass * (length**2 + width**2) / 12
    ET.SubElement(base, "inertial", pos=_num([0, 0, height / 2]), mass=f"{robot.base_mass:.6g}",
                  diaginertia=_num([izz, izz, izz]))
    wheel = 0.165 * max(robot.scale / 2, 1)
    # the chassis sits above the wheels' axles: it collides with the building (contype 2), not the ground
    ET.SubElement(base, "geom", name=f"{p}chassis", type="box", pos=_num([0, 0, (height + wheel) / 2]),
                  size=_num([length / 2, width / 2, (height - wheel) / 2]), rgba="0.95 0.75 0.1 1",
                  contype="2", conaffinity="1")
    for k, (x, y) in enumerate([(1, 1), (1, -1), (-1, 1), (-1, -1)]):
        ET.SubElement(base, "geom", name=f"{p}wheel{k}", type="cylinder", size=_num([wheel, 0.06]),
                      pos=_num([x * length / 3, y * (width / 2 + 0.04), wheel]), quat=_rx_quat(math.pi / 2),
                      rgba="0.1 0.1 0.1 1", contype="0", conaffinity="0")
    mount = ET.SubElement(base, "body", name=f"{p}arm_base", pos=_num(robot.arm_mount))
    add_arm(mount, robot, p)
    gain = 20.0  # 1/s: the base reaches a commanded speed within about 50 ms
    for joint, inertia in (("x", robot.base_mass), ("y", robot.base_mass), ("yaw", izz)):
        ET.SubElement(actuators, "velocity", name=f"{p}{joint}", joint=f"{p}{joint}", kv=f"{gain * inertia * 10:.6g}",
                      forcelimited="false")
    for name, limit in zip(JOINT_NAMES, robot.torque_limits):
        ET.SubElement(actuators, "motor", name=f"{p}{name}", joint=f"{p}{name}", ctrlrange=_num([-limit, limit]))
    for side in ("left", "right"):
        ET.SubElement(actuators, "position", name=f"{p}finger_{side}", joint=f"{p}finger_{side}", kp="200",
                      ctrlrange=_num([0, robot.gripper_opening / 2]))


def arm_only_xml(robot: RobotModel) -> str:
    """An MJCF of the arm alone on a fixed base at the origin (for inverse kinematics)."""
    root = ET.Element("mujoco", model=f"{robot.name}_arm")
    ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false", autolimits="true")
    world = ET.SubElement(root, "worldbody")
    add_arm(world, robot, "")
    return ET.tostring(root, encoding="unicode")
