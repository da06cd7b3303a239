"""A construction site in MuJoCo where robots of the family act: drive, reach, grasp, place.

:class:`MujocoSite` holds one MuJoCo model: ground, the robots at their homes, and the components and
supports added as they become known (``MjSpec.recompile`` keeps the state). Each robot's arm is
torque controlled by a joint-space PD law plus gravity compensation of its links and of the
component it holds (the robot knows the component's BIM weight), every torque clipped to the joint's
limit: an arm asked to lift more than its limits allow sags, and the motion fails.

Grasp: a weld constraint between the gripper and the component, switched on only when the tool
centre point is within :data:`GRASP_POSITION_TOLERANCE_M` and :data:`GRASP_ANGLE_TOLERANCE_DEG` of the
grasp pose. Trajectories: the pose of every body at :data:`RECORD_HZ`, simulated time.

Robots collide with the building, the components and each other (a collision bit per robot), not
with their own links; the other robots, as they stand, are obstacles of every robot's paths and
stands (:meth:`MujocoSite.obstacles`). A held component collides with the ground and the supports only.
"""

from __future__ import annotations

import itertools
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from bimrobot.frames import quat_wxyz, yaw_of
from bimrobot.physics import motion, planning
from bimrobot.physics.robot import JOINT_NAMES, RobotModel, add_robot
from bimrobot.physics.scene import scene_root

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
# robot's conaffinity; bit 30 is left free (MujocoSite._probe_model), so at most 26 robots have one
ROBOT_BIT_0 = 4
ROBOT_BITS = 26
TURNING_RADIUS_M = 0.1  # of the arcs of plan_poses' paths (a skid-steer base turns almost in place)
POSE_PLANS_PER_SEARCH = 3  # paths of plan_poses tried per search for a stand (each up to a second)
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


class MujocoSite:
    """Robots, components and supports in one MuJoCo model (see the module docstring)."""

    def __init__(self, robots: dict[str, tuple[RobotModel, float, float, tuple[float, float]]], ground_z: float = 0.0):
        """``robots``: name -> (family model, base speed m/s, arm speed m/s, home (x, y) m)."""
        import mujoco

        self.mj = mujoco
        # the ground is a slab (top at ground_z, PIT_DEPTH_M thick, on a plane) so that pits can be cut
        # into it where a component is installed below the surface (a footing)
        root, _, world = scene_root("rcan_site", ground_z - PIT_DEPTH_M)
        actuators = ET.SubElement(root, "actuator")
        for model, _, _, home in robots.values():
            add_robot(world, actuators, model, home, ground_z)
        self.ground_z = ground_z
        self.spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
        _robots_meet(self.spec, list(robots))
        self.model = self.spec.compile()
        self.data = mujoco.MjData(self.model)
        self.robots: dict[str, Robot] = {}
        for name, (model, speed, arm_speed, home) in robots.items():
            ready = self._ready_posture(model)
            self.data.joint(f"{name}/x").qpos[0], self.data.joint(f"{name}/y").qpos[0] = home
            self.robots[name] = Robot(model, speed, arm_speed, motion.ArmIK(model), ready)
            for joint, angle in zip(JOINT_NAMES, ready):
                self.data.joint(f"{name}/{joint}").qpos[0] = angle
        self.pits: list[tuple[np.ndarray, np.ndarray]] = []  # (lower xy, upper xy)
        self._slabs: list = []
        self._cut_slabs()
        self._sweep: dict[tuple[str, tuple], float] = {}  # (robot, driving posture) -> m
        self.components: dict[str, Component] = {}
        self.supports: list[tuple[np.ndarray, np.ndarray]] = []  # static boxes (centre, half size)
        self.props: list[tuple[np.ndarray, np.ndarray]] = []  # the same, that only components meet
        self.time_s = 0.0
        self.frames: list[tuple[float, np.ndarray]] = []
        self._next_frame = 0.0
        self._reindex()
        mujoco.mj_forward(self.model, self.data)

    # --- building the model ------------------------------------------------------------------------
    def _ready_posture(self, model: RobotModel) -> np.ndarray:
        """Joint angles with the tool down above the base's front (the arm's rest and carry pose)."""
        ik = motion.ArmIK(model)
        s = model.scale
        q, _, _ = ik.solve(motion.pose(motion.tool_down(0.0), (0.35 * s, 0.0, 0.45 * s)),
                           READY_SEED)
        return q

    def _reindex(self) -> None:
        m = self.model
        self._names = tuple(m.body(b).name for b in range(1, m.nbody))  # recorded with every frame
        self.idx = {}
        for name in self.robots:
            joints = [m.joint(f"{name}/{j}") for j in JOINT_NAMES]
            base = [m.joint(f"{name}/{j}") for j in ("x", "y", "yaw")]
            self.idx[name] = {
                "q": np.array([j.qposadr[0] for j in joints]),
                "v": np.array([j.dofadr[0] for j in joints]),
                "base_q": np.array([j.qposadr[0] for j in base]),
                "base_v": np.array([j.dofadr[0] for j in base]),
                "arm_act": np.array([m.actuator(f"{name}/{j}").id for j in JOINT_NAMES]),
                "base_act": np.array([m.actuator(f"{name}/{j}").id for j in ("x", "y", "yaw")]),
                "fingers": np.array([m.actuator(f"{name}/finger_{s}").id for s in ("left", "right")]),
                "limits": np.array([m.actuator(f"{name}/{j}").ctrlrange[1] for j in JOINT_NAMES]),
                "gripper": m.body(f"{name}/gripper").id,
                "robot_bodies": {b for b in range(m.nbody) if m.body(b).name.startswith(f"{name}/")},
            }
            self.idx[name]["geom_bodies"] = np.array(sorted(self.idx[name]["robot_bodies"]))
            self.idx[name]["geoms"] = np.flatnonzero(np.isin(m.geom_bodyid, self.idx[name]["geom_bodies"]))
        for name, robot in self.robots.items():
            if robot.gains is None:
                self.mj.mj_forward(self.model, self.data)
                full = np.zeros((m.nv, m.nv))
                self.mj.mj_fullM(m, self.data, full)
                dofs = self.idx[name]["v"]
                inertia = np.maximum(np.diag(full)[dofs], 1e-3)
                kp = 40.0 * self.idx[name]["limits"]
                robot.gains = (kp, 2.0 * np.sqrt(kp * inertia))

    def _recompile(self) -> None:
        self.model, self.data = self.spec.recompile(self.model, self.data)
        self._reindex()
        for name, robot in self.robots.items():  # a recompiled model forgets the grasps' relative poses
            if robot.holding:
                self._weld(name, robot.holding, robot.grip)
        self.mj.mj_forward(self.model, self.data)

    def add_component(self, component: Component, placement: np.ndarray) -> None:
        """Put a component (free body) with its origin at ``placement`` (4x4, world), with a weld to
        each robot's gripper, off until a grasp."""
        mj = self.mj
        w, d, h = component.size
        body = self.spec.worldbody.add_body(name=component.global_id, pos=placement[:3, 3], quat=quat_wxyz(placement[:3, :3]))
        body.add_freejoint(name=f"{component.global_id}/free")
        body.explicitinertial = True
        body.mass = component.mass
        body.ipos = [0, 0, h / 2]
        body.inertia = [component.mass / 12 * (d * d + h * h), component.mass / 12 * (w * w + h * h),
                        component.mass / 12 * (w * w + d * d)]
        # components collide with the ground, the supports and the robots (contype 4, conaffinity
        # 1 | 2), and the props (PROP_CONTYPE), not with each other: their BIM boxes meet or overlap at
        # the connections (a beam's end in its column), which the scene does not model; each rests on
        # its own support instead
        body.add_geom(name=f"{component.global_id}/box", type=mj.mjtGeom.mjGEOM_BOX, size=[w / 2, d / 2, h / 2],
                      pos=[0, 0, h / 2], rgba=[0.85, 0.45, 0.2, 1], friction=[1.0, 0.005, 0.0001],
                      contype=4, conaffinity=3 | PROP_CONTYPE)
        for name in self.robots:
            self.spec.add_equality(name=f"{name}/grasp/{component.global_id}", type=mj.mjtEq.mjEQ_WELD,
                                   objtype=mj.mjtObj.mjOBJ_BODY, name1=f"{name}/gripper", name2=component.global_id,
                                   active=False, solref=[GRASP_TIME_CONSTANT_S, 1.0])
        self.components[component.global_id] = component
        self._recompile()

    def add_support(self, name: str, centre_xy, top_z: float, half_xy, prop: bool = False) -> None:
        """A fixed box from the ground (or a pit's floor) up to ``top_z`` (a stand on the yard, the
        structure a component is installed on). ``prop``: it holds components only, and robots pass
        through it (it stands for the connections a beam hangs from, which are not modelled: robots
        drive under the beam; solid, the props closed the frame's bays to them for good)."""
        floor = self.ground_z if top_z >= self.ground_z else self.ground_z - PIT_DEPTH_M
        half = np.array([half_xy[0], half_xy[1], (top_z - floor) / 2])
        centre = np.array([centre_xy[0], centre_xy[1], floor + half[2]])
        collides = dict(contype=PROP_CONTYPE, conaffinity=0) if prop else {}
        self.spec.worldbody.add_geom(name=name, type=self.mj.mjtGeom.mjGEOM_BOX, size=half, pos=centre,
                                     rgba=[0.6, 0.6, 0.62, 0.35 if prop else 1], friction=[1.0, 0.005, 0.0001],
                                     **collides)
        (self.props if prop else self.supports).append((centre, half))
        self._recompile()

    def _cut_slabs(self) -> None:
        """(Re)build the ground slab as boxes around the pits."""
        for geom in self._slabs:
            self.spec.delete(geom)
        xs = sorted({-SITE_HALF_M, SITE_HALF_M, *(float(v) for lo, hi in self.pits for v in (lo[0], hi[0]))})
        ys = sorted({-SITE_HALF_M, SITE_HALF_M, *(float(v) for lo, hi in self.pits for v in (lo[1], hi[1]))})
        self._slabs = []
        for x0, x1 in zip(xs, xs[1:]):
            for y0, y1 in zip(ys, ys[1:]):
                centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
                if any(np.all(centre > lo) and np.all(centre < hi) for lo, hi in self.pits):
                    continue
                self._slabs.append(self.spec.worldbody.add_geom(
                    name=f"ground/{len(self._slabs)}", type=self.mj.mjtGeom.mjGEOM_BOX,
                    size=[(x1 - x0) / 2, (y1 - y0) / 2, PIT_DEPTH_M / 2],
                    pos=[centre[0], centre[1], self.ground_z - PIT_DEPTH_M / 2], rgba=[0.42, 0.45, 0.4, 1],
                    friction=[0.8, 0.005, 0.0001]))

    def add_pit(self, centre_xy, half_xy) -> None:
        """Cut a pit through the ground slab (a footing is installed in it)."""
        centre, half = np.asarray(centre_xy, float), np.asarray(half_xy, float)
        self.pits.append((centre - half, centre + half))
        self._cut_slabs()
        self._recompile()

    # --- state -------------------------------------------------------------------------------------
    def body_pose(self, name: str) -> np.ndarray:
        body = self.data.body(name)
        return motion.pose(body.xmat.reshape(3, 3).copy(), body.xpos.copy())

    def tcp_pose(self, robot: str) -> np.ndarray:
        site = self.data.site(f"{robot}/tcp")
        return motion.pose(site.xmat.reshape(3, 3).copy(), site.xpos.copy())

    def base_xy_yaw(self, robot: str) -> np.ndarray:
        return self.data.qpos[self.idx[robot]["base_q"]].copy()

    def arm_q(self, robot: str) -> np.ndarray:
        return self.data.qpos[self.idx[robot]["q"]].copy()

    # --- simulation --------------------------------------------------------------------------------
    def step(self, seconds: float) -> None:
        """Advance ``seconds`` with every robot's controllers running."""
        for _ in range(max(1, int(round(seconds / self.model.opt.timestep)))):
            self._control()
            self.mj.mj_step(self.model, self.data)
            self.time_s += self.model.opt.timestep
            if self.time_s >= self._next_frame:
                self._record()

    def _control(self) -> None:
        data = self.data
        for name, robot in self.robots.items():
            idx = self.idx[name]
            kp, kd = robot.held_gains if robot.holding and robot.held_gains is not None else robot.gains
            q, v = data.qpos[idx["q"]], data.qvel[idx["v"]]
            torque = kp * (robot.q_ref - q) - kd * v + data.qfrc_bias[idx["v"]]
            if robot.holding:
                torque += self._payload_torque(name, robot.holding)
            data.ctrl[idx["arm_act"]] = np.clip(torque, -idx["limits"], idx["limits"])
            data.ctrl[idx["base_act"]] = robot.base_velocity  # world-frame x, y speeds and yaw rate

    def _payload_torque(self, robot: str, component: str) -> np.ndarray:
        """Joint torques that hold the held component's weight (J^T m g at its centre of mass)."""
        body = self.data.body(component)
        jacp = np.zeros((3, self.model.nv))
        self.mj.mj_jac(self.model, self.data, jacp, None, body.xipos, self.idx[robot]["gripper"])
        mass = self.components[component].mass
        return jacp[:, self.idx[robot]["v"]].T @ np.array([0.0, 0.0, mass * 9.81])

    def saturated(self, robot: str) -> list[str]:
        """Arm joints whose motor is at its torque limit now."""
        idx = self.idx[robot]
        at_limit = np.abs(self.data.ctrl[idx["arm_act"]]) >= idx["limits"] * 0.999
        return [j for j, hit in zip(JOINT_NAMES, at_limit) if hit]

    def _record(self) -> None:
        self.frames.append((round(self.time_s, 6), self._names,
                            np.concatenate([self.data.xpos[1:], self.data.xquat[1:]], axis=1).copy()))
        self._next_frame += 1.0 / RECORD_HZ

    def body_names(self) -> list[str]:
        return [self.model.body(b).name for b in range(1, self.model.nbody)]

    # --- contacts ----------------------------------------------------------------------------------
    def arm_contacts_at(self, robot: str, q: np.ndarray, scratch=None, besides=(), stand=None) -> list[str]:
        """What the robot would touch with its arm at joints ``q``, everything else where it is now
        (a check of positions only, on a scratch copy of the state: :meth:`scratch_state`);
        ``stand``: (xy, yaw) of its base instead of where it stands (m, rad)."""
        scratch = self.scratch_state() if scratch is None else scratch
        if stand is None:
            return self._contacts_at(robot, scratch, self.idx[robot]["q"], q, besides)
        where = np.concatenate([self.idx[robot]["base_q"], self.idx[robot]["q"]])
        return self._contacts_at(robot, scratch, where, np.concatenate([stand[0][:2], [stand[1]], q]), besides)

    def scratch_state(self):
        """A copy of the positions of everything, to try poses on without touching the simulation."""
        scratch = self.mj.MjData(self.model)
        scratch.qpos[:] = self.data.qpos
        return scratch

    def _contacts_at(self, robot: str, scratch, addresses, values, besides=()) -> list[str]:
        """The robot's contacts in ``scratch`` with its coordinates ``addresses`` (qpos) set to ``values``."""
        scratch.qpos[addresses] = values
        self.mj.mj_fwdPosition(self.model, scratch)
        return self.robot_contacts(robot, scratch, besides)

    def seated(self, robot: str) -> bool:
        """Whether the component the robot holds rests on something: it touches a support or the
        ground (components do not collide with each other or, held, with robots)."""
        held = self.robots[robot].holding
        if held is None:
            return False
        box = self.model.geom(f"{held}/box").id
        m = self.model
        for contact in self.data.contact[: self.data.ncon]:
            if box in (contact.geom1, contact.geom2):
                other = contact.geom2 if contact.geom1 == box else contact.geom1
                if m.geom_bodyid[other] == 0:  # a static geom: a support, the ground slab
                    return True
        return False

    def robot_contacts(self, robot: str, data=None, besides=()) -> list[str]:
        """What the robot's arm, gripper or chassis touches other than the component it holds (in
        ``data``, default the simulation's), leaving out the contacts ``besides`` (those it had
        already: a robot may move away from what it touches)."""
        data = self.data if data is None else data
        m = self.model
        found = []
        for own, other, geom in self._contact_pairs(robot, data):
            # a static geom (body 0, "world") by its own name: a support, a stand, the ground slab
            other_name = (m.geom(geom).name or "the ground") if other == 0 else m.body(other).name
            found.append(f"{m.body(own).name} touches {other_name}")
        return sorted(set(found) - set(besides))

    def _contact_pairs(self, robot: str, data):
        """(own body, other body, other geom) of each contact of the robot in ``data`` with anything but
        itself and the component it holds."""
        m, idx = self.model, self.idx[robot]
        held = m.body(self.robots[robot].holding).id if self.robots[robot].holding else -1
        for contact in data.contact[: data.ncon]:
            bodies = (m.geom_bodyid[contact.geom1], m.geom_bodyid[contact.geom2])
            mine = [b in idx["robot_bodies"] for b in bodies]
            if mine[0] == mine[1]:
                continue
            other = bodies[1] if mine[0] else bodies[0]
            if other != held:
                yield (bodies[0] if mine[0] else bodies[1]), other, (contact.geom2 if mine[0] else contact.geom1)

    def component_poses(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """Body id -> (centre of mass, m, world; rotation matrix) of every component's body now."""
        ids = [self.model.body(gid).id for gid in self.components]
        return {b: (self.data.xipos[b].copy(), self.data.xmat[b].reshape(3, 3).copy()) for b in ids}

    def shoved(self, robot: str, before: dict) -> list[str]:
        """The components the robot touches now that have moved more than SHOVE_TOLERANCE_M since
        ``before`` (:meth:`component_poses`), with how far: their farthest corner's displacement
        bound, so that a tall column tilting about its foot counts by its top (the robot pushes what
        it touched already, which the contact check lets it move away from)."""
        out = []
        m = self.model
        for other in {other for _, other, _ in self._contact_pairs(robot, self.data)}:
            if other not in before:
                continue
            centre, rotation = before[other]
            turned = motion.angle_between(rotation, self.data.xmat[other].reshape(3, 3))
            reach = float(np.linalg.norm(self.components[m.body(other).name].size))  # > centre to corner
            moved = float(np.linalg.norm(self.data.xipos[other] - centre)) + turned * reach
            if moved > SHOVE_TOLERANCE_M:
                out.append(f"{m.body(other).name} by {moved * 1000:.0f} mm")
        return sorted(out)

    # --- base --------------------------------------------------------------------------------------
    def obstacles(self, robot: str, split: bool = False):
        """Boxes (centre xy, half size xy) the base must keep away from: supports, the components
        that rest on the ground or that another robot holds (a column held upright while it is
        fixed), not the robot's own, and the other robots (:meth:`robot_boxes`). ``split``: (low,
        tall) lists: low boxes (below the top of the chassis: a component lying on the ground) meet
        only the chassis, tall ones the arm too, which reaches out further."""
        low, tall = [], []
        chassis_top = self.ground_z + self.robots[robot].model.base_height
        for c, h in self.supports:
            if c[2] + h[2] > self.ground_z + 0.01:  # not one in a pit (under a footing: driven over)
                (low if c[2] + h[2] < chassis_top else tall).append((c[:2], h[:2]))
        for gid in self.components:
            if gid == self.robots[robot].holding:
                continue
            centre, half = self.component_box(gid)
            bottom, top = centre[2] - half[2], centre[2] + half[2]
            # not one that lies flush with or under the ground (a footing: driven over)
            if bottom < chassis_top and top > self.ground_z + 0.01:
                (low if top < chassis_top else tall).append((centre[:2], half[:2]))
        for other in self.robots:
            if other != robot:
                chassis, arm = self.robot_boxes(other)
                low.append(chassis)
                if arm is not None:
                    tall.append(arm)
        return (low, tall) if split else low + tall

    def robot_boxes(self, robot: str):
        """The robot as an obstacle to the others' bases: (chassis, arm), each (centre xy, half xy), m,
        world: the box around its chassis' footprint as it stands now (low: another robot's arm passes
        over it), and the box around its arm and gripper (each geom's bounding sphere) when they
        reach out beyond that (tall), else None."""
        length, width = self.robots[robot].model.footprint
        x, y, yaw = self.base_xy_yaw(robot)
        c, s_ = abs(math.cos(yaw)), abs(math.sin(yaw))
        chassis = (np.array([x, y]), np.array([c * length + s_ * width, s_ * length + c * width]) / 2)
        m = self.model
        base = m.body(f"{robot}/base").id
        arm = self._box_around(np.isin(m.geom_bodyid, [b for b in self.idx[robot]["robot_bodies"] if b != base])
                               & (m.geom_contype != 0))
        if np.all(np.abs(arm[0] - chassis[0]) + arm[1] <= chassis[1] + 0.01):
            return chassis, None
        return chassis, arm

    def component_box(self, gid: str) -> tuple[np.ndarray, np.ndarray]:
        """(centre xyz, half size xyz), m, world: the axis-aligned box around the component as it is now."""
        geom = self.data.geom(f"{gid}/box")
        half = np.abs(geom.xmat.reshape(3, 3)) @ (np.array(self.components[gid].size) / 2)
        return geom.xpos.copy(), half

    def robot_extent(self, robot: str) -> tuple[np.ndarray, np.ndarray]:
        """(centre xy, half size xy), m: the box around everything of the robot as it stands now
        (chassis, arm, gripper; each geom's bounding sphere)."""
        return self._box_around(np.isin(self.model.geom_bodyid, list(self.idx[robot]["robot_bodies"])))

    def _box_around(self, geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(centre xy, half size xy), m: the box around the geoms selected by the mask ``geoms`` as
        they are now (each geom's bounding sphere)."""
        xy, radius = self.data.geom_xpos[geoms, :2], self.model.geom_rbound[geoms][:, None]
        lower, upper = (xy - radius).min(axis=0), (xy + radius).max(axis=0)
        return (lower + upper) / 2, (upper - lower) / 2

    def arm_within(self, robot: str, centre_xy, half_xy, top_z: float, clearance: float = CLEARANCE_M) -> bool:
        """Whether the robot's arm or gripper (the world box around each geom, the chassis and
        wheels left out) comes within ``clearance`` (m) of the box standing on the ground under
        ``top_z`` (m) around ``centre_xy`` (half size ``half_xy``): something put there would meet it."""
        m, data = self.model, self.data
        base = m.body(f"{robot}/base").id
        bodies = [b for b in self.idx[robot]["robot_bodies"] if b != base]
        for g in np.flatnonzero(np.isin(m.geom_bodyid, bodies)):
            rotation = data.geom_xmat[g].reshape(3, 3)
            centre = data.geom_xpos[g] + rotation @ m.geom_aabb[g, :3]
            half = np.abs(rotation) @ m.geom_aabb[g, 3:] + clearance
            if np.all(np.abs(centre[:2] - np.asarray(centre_xy, float)) < half[:2] + np.asarray(half_xy, float)) \
                    and centre[2] - half[2] < top_z:
                return True
        return False

    def stow_arm(self, robot: str) -> None:
        """An empty arm to the posture it drives in: tucked (the heavy variant's metres long arm), or
        the ready posture (the UR5); its base joint turned the short way (checked for contacts)."""
        goal = self._stowed_posture(robot)
        if np.abs(goal - self.robots[robot].q_ref).max() > 0.05:
            self.move_arm(robot, goal)

    def _stowed_posture(self, robot: str) -> np.ndarray:
        """The joints (rad) :meth:`stow_arm` moves an empty arm to, its base joint turned the short way."""
        r = self.robots[robot]
        posture = TUCK_POSTURE if r.model.family == "heavy" else self._ready_posture_cached(robot)
        return motion.wrap_near(posture, r.q_ref, np.array([True, True, False, True, True, True]))

    def _clear(self, robot: str, xy, low, tall) -> bool:
        """Whether the robot may stand (and turn) at ``xy`` with these obstacles (see obstacles())."""
        base = math.hypot(*self.robots[robot].model.footprint) / 2 + CLEARANCE_M
        return not self._blocked(xy, low, base) and not self._blocked(xy, tall, self.sweep_radius(robot) + CLEARANCE_M)

    def _footprint_clear(self, robot: str, xy, yaw: float, boxes, clearance: float = CLEARANCE_M) -> bool:
        """Whether the chassis at ``xy`` heading ``yaw`` keeps ``clearance`` (m) from every box
        (separating axes of the chassis' rectangle and each axis-aligned box)."""
        length, width = self.robots[robot].model.footprint
        c, s_ = math.cos(yaw), math.sin(yaw)
        axes = (np.array([c, s_]), np.array([-s_, c]), np.array([1.0, 0.0]), np.array([0.0, 1.0]))
        halves = (length / 2 + clearance, width / 2 + clearance)
        for centre, half in boxes:
            offset = np.asarray(centre, float) - np.asarray(xy, float)
            separated = False
            for axis in axes:
                mine = halves[0] * abs(axis @ axes[0]) + halves[1] * abs(axis @ axes[1])
                theirs = half[0] * abs(axis[0]) + half[1] * abs(axis[1])
                if abs(axis @ offset) > mine + theirs:
                    separated = True
                    break
            if not separated:
                return False
        return True

    def _blocked(self, xy: np.ndarray, boxes, radius: float) -> bool:
        for centre, half in boxes:
            gap = np.maximum(np.abs(xy - centre) - half, 0.0)
            if np.linalg.norm(gap) < radius:
                return True
        return False

    def plan_path(self, robot: str, goal_xy) -> list[np.ndarray]:
        """Waypoints (xy, m) from the base to ``goal_xy`` on an occupancy grid of :data:`GRID_M` cells
        whose obstacles are grown by half the base's width plus :data:`CLEARANCE_M` (A* search by
        pyastar2d, then straightened; grown by half the base's diagonal, so that it may turn anywhere
        on the path). The grid covers the start, the goal and every obstacle with
        3 m around them. A base that stands within the grown obstacles (it has just worked beside
        one) may leave them: cells within that distance of it count free, unless the chassis would
        touch an obstacle there (obstacles grown by half the chassis' width and the clearance). A goal within the grown obstacles is replaced by the nearest free
        cell (the goal of *move to component* is a stand-off point, and the next activity finds its
        own stand). MotionFailed when no path exists."""
        model = self.robots[robot].model
        start = self.base_xy_yaw(robot)[:2]
        goal = np.asarray(goal_xy, float)
        low, tall = self.obstacles(robot, split=True)
        boxes = low + tall
        # the robot turns in place at each waypoint: it needs its sweep radius all around (its chassis'
        # half diagonal for what is lower than the chassis)
        radius = self.sweep_radius(robot) + CLEARANCE_M
        radii = [math.hypot(*model.footprint) / 2 + CLEARANCE_M] * len(low) + [radius] * len(tall)
        blocked = lambda p: not self._clear(robot, p, low, tall)  # noqa: E731
        if not boxes or (not blocked(goal) and not _line_blocked(start, goal, blocked)):
            return [goal]
        corners = [start, goal] + [c - h for c, h in boxes] + [c + h for c, h in boxes]
        lower = np.min(corners, axis=0) - 3.0
        upper = np.max(corners, axis=0) + 3.0
        shape = tuple(np.ceil((upper - lower) / GRID_M).astype(int) + 1)
        xs = lower[0] + GRID_M * np.arange(shape[0])
        ys = lower[1] + GRID_M * np.arange(shape[1])
        occupied = np.zeros(shape, bool)
        solid = np.zeros(shape, bool)
        yaw = self.base_xy_yaw(robot)[2]
        for (centre, half), grown in zip(boxes, radii):  # cells whose centre lies within radius of the box
            gap = np.hypot(np.maximum(np.abs(xs[:, None] - centre[0]) - half[0], 0),
                           np.maximum(np.abs(ys[None, :] - centre[1]) - half[1], 0))
            occupied |= gap < grown
            # where the chassis, driving out straight, would touch it: never free, not even near the
            # start; unless the chassis stands over it already (a low support put under it): then
            # the contact check judges while it drives off
            if self._footprint_clear(robot, start, yaw, [(centre, half)], 0.0):
                solid |= gap < model.footprint[1] / 2 + CLEARANCE_M
        grown = occupied.copy()
        near_start = np.hypot(xs[:, None] - start[0], ys[None, :] - start[1]) < radius
        occupied &= ~(near_start & ~solid)
        cell = lambda p: tuple(np.round((np.asarray(p) - lower) / GRID_M).astype(int))  # noqa: E731
        if grown[cell(goal)]:  # (a goal in the start's escape zone is no place to stop either)
            free = np.argwhere(~grown)
            nearest = free[np.argmin(np.hypot(*(lower[:, None] + GRID_M * free.T - goal[:, None])))]
            goal = lower + GRID_M * nearest
        cells = motion.grid_path(occupied, cell(start), cell(goal))
        if cells is None:
            raise Blocked(f"no collision-free path for {robot} from ({start[0]:.2f}, {start[1]:.2f}) to "
                               f"({goal[0]:.2f}, {goal[1]:.2f})")
        points = lower + cells * GRID_M
        points[0], points[-1] = start, goal
        # straightened through free cells only (the start's own neighbourhood may be grown-occupied)
        free_at = lambda p: occupied[tuple(np.clip(cell(p), 0, np.array(shape) - 1))]  # noqa: E731
        # (start and goal in one cell: the goal alone, as for a straight way)
        return motion.simplify(points, free_at, GRID_M / 2)[1:] or [goal]

    def driving_posture(self, robot: str) -> np.ndarray:
        """The arm's joints (rad) while the base drives: as they are when it holds something, else
        where :meth:`stow_arm` puts them."""
        r = self.robots[robot]
        return r.q_ref.copy() if r.holding else self._stowed_posture(robot)

    def plan_poses(self, robot: str, goal_xy, goal_yaw: float | None = None, keep_out=(),
                   iterations: int = planning.BASE_ITERATIONS) -> PosePath | None:
        """A path in the plane (OMPL, Reeds-Shepp curves: forward and backward, see
        :mod:`bimrobot.physics.planning`) to ``goal_xy`` heading ``goal_yaw`` (any of eight headings
        when None), checked on the MuJoCo scene with the robot's whole body as it drives (chassis and
        arm in :meth:`driving_posture`) keeping :data:`CLEARANCE_M` from everything; at the goal its
        chassis is clear of ``keep_out`` boxes too (centre xy, half xy: about to appear, not there
        to touch on the way). What it is nearer than that to at its start it may stay as near to,
        never nearer (it has just worked beside it). For where the
        grid planner, which lets the robot turn anywhere, finds no way: a robot holding a beam
        between columns sweeps metres when it turns. None when no path is found within ``iterations``
        of the planner per heading (a count, not a time: the same answer on a busy machine)."""
        x, y, yaw = self.base_xy_yaw(robot)
        start = np.array([x, y, yaw])
        valid = self._pose_check(robot, start)
        keep_out = [(np.asarray(c, float), np.asarray(h, float)) for c, h in keep_out]
        goal_xy = np.asarray(goal_xy, float)
        boxes = self.obstacles(robot) + keep_out
        corners = [start[:2], goal_xy] + [c - h for c, h in boxes] + [c + h for c, h in boxes]
        lower, upper = np.min(corners, axis=0) - 3.0, np.max(corners, axis=0) + 3.0
        # checked where the robot's farthest point (its sweep radius out) has moved 2 cm
        resolution = 0.02 * TURNING_RADIUS_M / (self.sweep_radius(robot) + TURNING_RADIUS_M)
        headings = [goal_yaw] if goal_yaw is not None else \
            sorted(np.linspace(-math.pi, math.pi, 8, endpoint=False), key=lambda h: abs(_wrap(h - yaw)))
        for heading in headings:
            goal = np.array([*goal_xy, heading])
            if not valid(*goal) or not self._footprint_clear(robot, goal[:2], heading, keep_out):
                continue
            poses = planning.base_path(valid, start, goal, lower, upper, TURNING_RADIUS_M, resolution, iterations)
            if poses is not None:
                return PosePath(poses)
        return None

    def _pose_check(self, robot: str, start: np.ndarray):
        """valid(x, y, yaw) for :meth:`plan_poses` (positions only, on a scratch copy of the state)."""
        probe = self._probe_model(robot, CLEARANCE_M)
        scratch = self.scratch_state()
        scratch.qpos[self.idx[robot]["q"]] = self.driving_posture(robot)
        base = self.idx[robot]["base_q"]
        already = self._contacts_within(robot, probe, scratch, base, start)

        def valid(x, y, yaw):
            return self._no_nearer(self._contacts_within(robot, probe, scratch, base, (x, y, yaw)), already)

        return valid

    def _probe_model(self, robot: str, margin: float):
        """A copy of the model for checking the robot's poses quickly: only the robot's geoms collide
        (with what they would touch in the simulation, not other robots; what lies on the ground is
        not checked against the ground on every try), and they touch what comes within ``margin`` (m)."""
        import copy

        probe = copy.copy(self.model)
        mine = self.idx[robot]["geoms"]
        kind, affinity = probe.geom_contype, probe.geom_conaffinity
        solid = mine[(kind[mine] | affinity[mine]) != 0]
        # MuJoCo's rule: two geoms collide when either's type matches the other's affinity
        meets_robot = ((kind & np.bitwise_or.reduce(affinity[solid])) != 0) | \
                      ((affinity & np.bitwise_or.reduce(kind[solid])) != 0)
        meets_robot[mine] = False
        only = 1 << 30  # a bit nothing else uses
        kind[:], affinity[:] = 0, np.where(meets_robot, only, 0)
        kind[solid] = only
        probe.geom_margin[mine] = margin
        return probe

    def _contacts_within(self, robot: str, probe, scratch, addresses, values) -> dict[int, float]:
        """What the robot would touch or come within the probe model's margin of, in ``scratch``
        with its coordinates ``addresses`` (qpos) set to ``values`` (positions only): a body's id (or
        minus one minus a static geom's id; a planner asks thousands of times: no names) -> the
        least distance (m, negative: overlap)."""
        scratch.qpos[addresses] = values
        self.mj.mj_kinematics(probe, scratch)
        self.mj.mj_collision(probe, scratch)
        if not scratch.ncon:
            return {}
        contacts = scratch.contact
        geoms = contacts.geom[: scratch.ncon]
        own = np.isin(probe.geom_bodyid[geoms[:, 0]], self.idx[robot]["geom_bodies"])
        other = np.where(own, geoms[:, 1], geoms[:, 0])
        body = probe.geom_bodyid[other]
        found: dict[int, float] = {}
        for key, distance in zip(np.where(body == 0, -1 - other, body).tolist(), contacts.dist[: scratch.ncon].tolist()):
            found[key] = min(distance, found.get(key, distance))
        return found

    @staticmethod
    def _no_nearer(found: dict[int, float], already: dict[int, float]) -> bool:
        """Whether every contact of ``found`` is one of ``already`` and no nearer (1 mm) than there:
        a robot may move away from, or along, what it stood close to."""
        return all(key in already and distance >= already[key] - 0.001 for key, distance in found.items())

    def _follow(self, robot: str, path: PosePath) -> float:
        """Drive the base along ``path``: its poses timed so that the base moves at the robot's speed
        and turns at TURN_RATE_RAD_S at most, each step's velocity the reference's plus a correction
        of the pose error; then into the last pose (5 mm, 0.002 rad). MotionFailed when it touches
        something new. Returns the distance driven (m)."""
        r = self.robots[robot]
        if not r.holding and r.model.family == "heavy":
            self.stow_arm(robot)
        poses = np.array(path.poses, float)
        poses[:, 2] = np.unwrap(poses[:, 2])
        step = np.diff(poses, axis=0)
        times = np.concatenate([[0.0], np.cumsum(np.maximum(np.linalg.norm(step[:, :2], axis=1) / r.speed_m_s,
                                                              np.abs(step[:, 2]) / TURN_RATE_RAD_S))])
        reference = lambda t: np.array([np.interp(t, times, poses[:, i]) for i in range(3)])  # noqa: E731
        already, before = set(self.robot_contacts(robot)), self.component_poses()
        dt, t, driven, stalled = 0.02, 0.0, 0.0, 0.0
        last = self.base_xy_yaw(robot)[:2]
        while True:
            t = min(t + dt, times[-1])
            x, y, yaw = self.base_xy_yaw(robot)
            goal = reference(t)
            error = np.array([goal[0] - x, goal[1] - y, _wrap(goal[2] - yaw)])
            if t >= times[-1] and np.linalg.norm(error[:2]) < 0.005 and abs(error[2]) < 2e-3:
                break
            if stalled > 5.0:  # 5 s past the end of its path and not in its last pose
                r.base_velocity = np.zeros(3)
                raise MotionFailed(f"the base of {robot} is blocked at ({x:.2f}, {y:.2f}), "
                                   f"{np.linalg.norm(error[:2]) * 1000:.0f} mm from its goal")
            stalled += dt if t >= times[-1] else 0.0
            ahead = (reference(t + dt) - goal) / dt if t < times[-1] else np.zeros(3)
            velocity = ahead + 3.0 * error
            velocity[:2] *= min(1.0, 1.5 * r.speed_m_s / max(float(np.linalg.norm(velocity[:2])), 1e-9))
            velocity[2] = np.clip(velocity[2], -1.5 * TURN_RATE_RAD_S, 1.5 * TURN_RATE_RAD_S)
            r.base_velocity = velocity
            self.step(dt)
            here = self.base_xy_yaw(robot)[:2]
            driven, last = driven + float(np.linalg.norm(here - last)), here
            self._halt_on_contact(robot, already, f"driving at ({x:.2f}, {y:.2f})", before)
        r.base_velocity = np.zeros(3)
        self.step(0.1)
        return driven

    def _halt_on_contact(self, robot: str, already, doing: str, before: dict | None = None) -> None:
        """Stop the base there and fail when the robot touches anything but ``already`` (what it
        touched when the motion began: it may move away from that), or has pushed a component it
        touches from where it was ``before`` (:meth:`component_poses`), while ``doing`` (words)."""
        touching = self.robot_contacts(robot, besides=already)
        pushed = self.shoved(robot, before) if before else []
        if touching or pushed:
            self.robots[robot].base_velocity = np.zeros(3)
            self.step(0.1)
            what = f"hit something while {doing}: {'; '.join(touching)}" if touching else \
                f"pushed {'; '.join(pushed)} while {doing}"
            raise MotionFailed(f"{robot} {what}")

    def drive(self, robot: str, goal_xy, final_yaw: float | None = None, path: list | None = None) -> float:
        """Drive the base along a planned path to ``goal_xy`` (turn, then go straight, per leg); turn
        to ``final_yaw`` at the end. ``path``: the waypoints :meth:`plan_path` gave from where the
        base stands now (planned already to check the way), or a :class:`PosePath`. When the grid
        planner finds no way, a path of :meth:`plan_poses` (the robot's whole body, driving forward
        and backward). Returns the distance driven (m)."""
        if path is None:
            try:
                path = self.plan_path(robot, goal_xy)
            except Blocked:
                path = self.plan_poses(robot, goal_xy, final_yaw)
                if path is None:
                    raise
        if isinstance(path, PosePath):
            driven = self._follow(robot, path)
            if final_yaw is not None:
                self.turn(robot, final_yaw)
            return driven
        waypoints = path
        r = self.robots[robot]
        # empty: drive with the (metres long) arm tucked, tucked before it backs out too (backing
        # out of a column's way, an arm left at its work point on the column dragged along it)
        if not r.holding and r.model.family == "heavy":
            self.stow_arm(robot)
        x, y, yaw = self.base_xy_yaw(robot)
        first = waypoints[0] - np.array([x, y])
        turns = np.linalg.norm(first) > 0.02 and abs(_wrap(math.atan2(first[1], first[0]) - yaw)) > 0.05
        if turns and self._back_out(robot):
            waypoints = self.plan_path(robot, goal_xy)  # from where it may turn
        driven = 0.0
        for point in waypoints:
            here = self.base_xy_yaw(robot)[:2]
            if np.linalg.norm(point - here) > 0.02:
                self.turn(robot, math.atan2(point[1] - here[1], point[0] - here[0]))
                driven += self._straight(robot, point)
        if final_yaw is not None:
            self.turn(robot, final_yaw)
        return driven

    def _back_out(self, robot: str) -> bool:
        """When the robot's base stands too near something taller than its chassis to turn in place
        (it has just worked beside it, or carried a component there), drive it straight, backwards or
        forwards along its heading, to the nearest spot (up to 4 m) where it may turn, its chassis
        clear of everything on the way (a component it holds passes through other components).
        Whether it moved."""
        low, tall = self.obstacles(robot, split=True)
        if self._clear(robot, self.base_xy_yaw(robot)[:2], low, tall):
            return False
        return self._straight_to(robot, lambda spot: self._clear(robot, spot, low, tall))

    def _straight_to(self, robot: str, good, boxes=()) -> bool:
        """Drive straight, backwards or forwards along the heading, to the nearest spot (up to 4 m)
        where ``good(spot)`` holds, the chassis clear of every obstacle (and of ``boxes``) on the way,
        without turning. Whether it found one and moved."""
        x, y, yaw = self.base_xy_yaw(robot)
        here = np.array([x, y])
        heading = np.array([math.cos(yaw), math.sin(yaw)])
        # what the chassis' footprint overlaps already is left to the contact check while it moves
        boxes = [box for box in self.obstacles(robot) + list(boxes) if self._footprint_clear(robot, here, yaw, [box], 0.0)]
        for distance in np.arange(0.1, 4.01, 0.1):
            for sign in (-1.0, 1.0):
                spot = here + sign * distance * heading
                way = [here + sign * t * heading for t in np.arange(0.1, distance + 1e-9, 0.1)]
                # on the way, not touching (it may have worked within the clearance of something)
                if good(spot) and all(self._footprint_clear(robot, p, yaw, boxes, 0.0) for p in way):
                    self._straight_along(robot, distance, sign)
                    return True
        return False

    def _straight_along(self, robot: str, distance: float, sign: float) -> None:
        """Drive ``distance`` m straight along the heading (``sign`` -1: backwards), without turning."""
        r = self.robots[robot]
        x, y, yaw = self.base_xy_yaw(robot)
        start = np.array([x, y])
        heading = np.array([math.cos(yaw), math.sin(yaw)])
        already, before = set(self.robot_contacts(robot)), self.component_poses()
        for _ in range(int(120 / 0.02)):
            left = distance - float((self.base_xy_yaw(robot)[:2] - start) @ heading) * sign
            if left < 0.005:
                break
            speed = sign * min(r.speed_m_s, 1.5 * left)
            r.base_velocity = np.array([speed * heading[0], speed * heading[1], 0.0])
            self.step(0.02)
            self._halt_on_contact(robot, already, "backing out", before)
        r.base_velocity = np.zeros(3)
        self.step(0.1)

    def turn(self, robot: str, yaw: float) -> None:
        """Turn the base in place to ``yaw`` (rad), the short way round, or the long way when the short
        one would sweep the chassis or the arm into something (checked on positions first; Blocked
        when both would: other robots' work may clear the way)."""
        now = self.base_xy_yaw(robot)[2]
        way = self._turning_way(robot, now, yaw)
        if abs(way) < 1e-3:
            return
        # in steps of at most 90 degrees, so that each step's short way is the chosen way
        count = max(1, math.ceil(abs(way) / (math.pi / 2)))
        for k in range(1, count + 1):
            self._turn_to(robot, now + way * k / count)

    def _turning_way(self, robot: str, from_yaw: float, to_yaw: float, xy=None) -> float:
        """The turn (rad, signed) from ``from_yaw`` to ``to_yaw`` that sweeps the robot into nothing
        new, the short way first, standing where it is or at ``xy``; Blocked when both ways would."""
        short = _wrap(to_yaw - from_yaw)
        if abs(short) < 1e-3:
            return short
        already = set(self.robot_contacts(robot))
        touched_short = self._sweep_contacts(robot, from_yaw, short, already, xy)
        if not touched_short:
            return short
        long = short - math.copysign(2 * math.pi, short)
        if not self._sweep_contacts(robot, from_yaw, long, already, xy):
            return long
        x, y = self.base_xy_yaw(robot)[:2] if xy is None else xy
        raise Blocked(f"{robot} cannot turn at ({x:.2f}, {y:.2f}) without touching {'; '.join(touched_short)}")

    def _sweep_contacts(self, robot: str, start_yaw: float, turn: float, already: set, xy=None) -> list[str]:
        """What the robot would newly touch turning in place by ``turn`` rad from ``start_yaw``, where
        it stands or at ``xy`` (samples every 0.05 rad; positions only, on a scratch copy of the
        state)."""
        scratch = self.scratch_state()
        base = self.idx[robot]["base_q"]
        if xy is not None:
            scratch.qpos[base[:2]] = xy
        for t in np.linspace(0.0, 1.0, max(2, math.ceil(abs(turn) / 0.05)) + 1)[1:]:
            touching = self._contacts_at(robot, scratch, base[2], start_yaw + turn * t, already)
            if touching:
                return touching
        return []

    def _turn_to(self, robot: str, yaw: float) -> None:
        r = self.robots[robot]
        already, before = set(self.robot_contacts(robot)), self.component_poses()
        for _ in range(int(30 / 0.02)):
            error = _wrap(yaw - self.base_xy_yaw(robot)[2])
            if abs(error) < 1e-3:
                break
            r.base_velocity = np.array([0.0, 0.0, np.clip(3.0 * error, -TURN_RATE_RAD_S, TURN_RATE_RAD_S)])
            self.step(0.02)
            self._halt_on_contact(robot, already, "turning", before)  # its corners or its arm swept into something
        r.base_velocity = np.zeros(3)
        self.step(0.1)

    def _straight(self, robot: str, point: np.ndarray) -> float:
        r = self.robots[robot]
        start = self.base_xy_yaw(robot)[:2]
        stalled = 0.0
        last = start
        for _ in range(int(600 / 0.02)):
            x, y, yaw = self.base_xy_yaw(robot)
            offset = point - np.array([x, y])
            distance = float(np.linalg.norm(offset))
            if distance < 0.005:
                break
            speed = min(r.speed_m_s, 1.5 * distance)
            heading = math.atan2(offset[1], offset[0]) if distance > 0.05 else yaw
            turn = np.clip(3.0 * _wrap(heading - yaw), -TURN_RATE_RAD_S, TURN_RATE_RAD_S)
            r.base_velocity = np.array([speed * math.cos(yaw), speed * math.sin(yaw), turn])
            self.step(0.02)
            moved = np.linalg.norm(self.base_xy_yaw(robot)[:2] - last)
            last = self.base_xy_yaw(robot)[:2]
            stalled = stalled + 0.02 if moved < 1e-4 else 0.0
            # the robot ran into something the plan did not foresee: stop there
            self._halt_on_contact(robot, (), f"driving at ({x:.2f}, {y:.2f})")
            if stalled > 1.0:
                r.base_velocity = np.zeros(3)
                contacts = "; ".join(self.robot_contacts(robot)) or "it stopped"
                raise MotionFailed(f"the base of {robot} is blocked at ({x:.2f}, {y:.2f}): {contacts}")
        r.base_velocity = np.zeros(3)
        self.step(0.1)
        return float(np.linalg.norm(self.base_xy_yaw(robot)[:2] - start))

    def face(self, robot: str, target_xy) -> None:
        """Turn the base to face ``target_xy``; when turning in place would sweep its corners into an
        obstacle, back away from the target first and come forward again after the turn."""
        model = self.robots[robot].model
        x, y, _ = self.base_xy_yaw(robot)
        here = np.array([x, y])
        offset = np.asarray(target_xy, float) - here
        yaw = math.atan2(offset[1], offset[0])
        low, tall = self.obstacles(robot, split=True)
        if not self._clear(robot, here, low, tall):
            away = here - offset / max(np.linalg.norm(offset), 1e-9) * 0.8 * model.footprint[0]
            self.drive(robot, away)
            self.turn(robot, yaw)
            self._straight(robot, here)  # facing the target now: forward to where it stood
        self.turn(robot, yaw)

    def make_room(self, robot: str, target_xy, half_xy) -> None:
        """Before something is put or reached at ``target_xy`` (a box of ``half_xy``): when the base is
        so close that its footprint could touch the box, drive it to the nearest free stand pose on a
        circle around the target (its corners clear of the box by CLEARANCE_M) that it has a path to,
        then face the target; with a path to none, straight along its heading until its chassis is
        clear of the box. Blocked when it cannot."""
        model = self.robots[robot].model
        target = np.asarray(target_xy, float)
        here = self.base_xy_yaw(robot)[:2]
        corner = math.hypot(*model.footprint) / 2
        radius = corner + float(np.hypot(*half_xy)) + CLEARANCE_M
        if np.linalg.norm(here - target) >= radius - 1e-6:
            return
        boxes = self.obstacles(robot) + [(target, np.asarray(half_xy, float))]
        angles = np.linspace(-math.pi, math.pi, 36, endpoint=False)
        candidates = [target + radius * np.array([math.cos(a), math.sin(a)]) for a in angles]
        candidates.sort(key=lambda c: float(np.linalg.norm(c - here)))
        why = "every pose around it is blocked"
        planned = 0
        for candidate in candidates:
            if self._blocked(candidate, boxes, corner):
                continue
            facing = math.atan2(target[1] - candidate[1], target[0] - candidate[0])
            try:
                path = self.plan_path(robot, candidate)  # the nearest pose may be walled off: the next one
                end = path[-1]  # the planner ends on the nearest free cell when the pose is too near a tall obstacle
            except Blocked as failure:
                why = str(failure)
                if planned == POSE_PLANS_PER_SEARCH:
                    continue
                planned += 1  # its whole body's way in the plane (see approach)
                path = self.plan_poses(robot, candidate, facing, keep_out=[(target, np.asarray(half_xy, float))])
                if path is None:
                    continue
                end = path.end
            if self._blocked(end, boxes, corner):
                why = f"the nearest free spot to a pose, ({end[0]:.2f}, {end[1]:.2f}), is within the box"
                continue
            self.drive(robot, candidate, path=path)
            self.turn(robot, math.atan2(target[1] - end[1], target[0] - end[0]))
            return
        # none it can drive to, turning on the way (a robot inside the frame holding a beam sweeps
        # metres when it turns): straight along its heading, out of the box's way
        box = (target, np.asarray(half_xy, float))
        yaw = self.base_xy_yaw(robot)[2]
        if self._straight_to(robot, lambda spot: self._footprint_clear(robot, spot, yaw, [box]), [box]):
            return
        raise Blocked(f"no free stand pose for {robot} around ({target[0]:.2f}, {target[1]:.2f}): {why}")

    def sweep_radius(self, robot: str) -> float:
        """Radius (m) of the circle around the base's centre that the robot sweeps when it turns in
        place with its arm in its driving posture (:meth:`driving_posture`: the carry posture when it
        holds a component, which depends on how it holds it; stowed when empty): its chassis'
        corners, or its arm's joints (plus the links' thickness) where they reach out further."""
        r = self.robots[robot]
        posture = self.driving_posture(robot)
        key = (robot, tuple(np.round(posture, 2)))
        if key not in self._sweep:
            data = self.mj.MjData(r.ik.model)
            data.qpos[:6] = posture
            self.mj.mj_kinematics(r.ik.model, data)
            mount = r.model.arm_mount
            arm = np.hypot(data.xpos[1:, 0] + mount[0], data.xpos[1:, 1]).max() + 0.06 * r.model.scale
            self._sweep[key] = float(max(math.hypot(*r.model.footprint) / 2, arm))
        return self._sweep[key]

    def working_distance(self, robot: str) -> float:
        """Horizontal distance (m) from the arm's base at which the arm works comfortably: 45 % of
        its upper arm and forearm together."""
        model = self.robots[robot].model
        return 0.45 * (abs(model.dh[1][0]) + abs(model.dh[2][0]))

    def approach(self, robot: str, point_xy, keep_out=(), distance: float | None = None, low_keep_out=(),
                 reach=()) -> None:
        """Stand where the arm's base is ``distance`` (default :meth:`working_distance`) from
        ``point_xy`` and face it: stay when the arm's base is within 0.7-1.15 x that distance already
        and the base is clear of every obstacle and of ``keep_out`` (boxes (centre xy, half xy) about
        to appear, tall; ``low_keep_out``: lying on the ground); else drive to the nearest free stand
        on the circle around the point (its corners clear by CLEARANCE_M, so that it may turn there)
        from which the arm reaches every tool pose of ``reach`` (a function of the stand's xy and
        heading giving tool poses, 4x4 world, or a list; checked before it moves, as are the path and
        the turn). MotionFailed when none can be reached."""
        model = self.robots[robot].model
        point = np.asarray(point_xy, float)
        distance = self.working_distance(robot) if distance is None else distance
        low, tall = self.obstacles(robot, split=True)
        low = low + [(np.asarray(c, float), np.asarray(h, float)) for c, h in low_keep_out]
        tall = tall + [(np.asarray(c, float), np.asarray(h, float)) for c, h in keep_out]
        boxes = low + tall
        x, y, yaw = self.base_xy_yaw(robot)
        arm = np.array([x, y]) + model.arm_mount[0] * np.array([math.cos(yaw), math.sin(yaw)])
        here = np.array([x, y])
        facing = math.atan2(point[1] - y, point[0] - x)
        # (the chassis as it will stand, turned to the point: a circle of its half width let a
        # transport stay with its corner where it then laid a column down, which shoved it away)
        if 0.7 * distance <= np.linalg.norm(arm - point) <= 1.15 * distance and \
                self._footprint_clear(robot, here, facing, boxes, 0.0) and self._reaches(robot, reach, here, facing):
            self.face(robot, point)
            return
        # stands on rings around the point (the ideal distance first), nearest to the base first
        angles = np.linspace(-math.pi, math.pi, 72, endpoint=False)
        candidates = []
        checked = callable(reach) or len(reach) > 0  # (only a stand whose reach is checked may be far)
        for rank, radius in enumerate(self._stand_radii(robot, distance, checked)):
            for a in angles:
                c = point + radius * np.array([math.cos(a), math.sin(a)])
                # the chassis, facing the point, clear of everything (the arm, raised, passes over
                # what it works on)
                if self._footprint_clear(robot, c, math.atan2(point[1] - c[1], point[0] - c[0]), boxes):
                    candidates.append((float(np.linalg.norm(c - here)) + rank * 2.0 * distance, c))
        candidates = [c for _, c in sorted(candidates, key=lambda item: item[0])]
        why = "every stand around it is blocked"
        tried, unreachable, planned = 0, 0, 0
        for candidate in candidates:
            if tried == 8 or unreachable == 12:
                break
            facing = math.atan2(point[1] - candidate[1], point[0] - candidate[0])
            try:  # a stand it can drive to and turn at to face the point, checked before it moves
                path = self.plan_path(robot, candidate)
                turns = self._turns_on(robot, path, facing)
            except Blocked as failure:
                why, path, turns = str(failure), None, "no path"
            if path is not None and np.linalg.norm(path[-1] - candidate) > 0.01:
                # the grid's way ends at the free cell nearest the stand, metres from it where the
                # robot swings a beam (its whole turning circle must be clear on the grid): only its
                # whole body's way (below) gets it there, and its reach counts there only
                path, turns = None, "no path"
            if not self._reaches(robot, reach, candidate, facing):
                unreachable += 1
                why = f"its arm does not reach its work from the stands around it ({unreachable} tried)"
                continue
            if turns and planned < POSE_PLANS_PER_SEARCH:
                # the grid lets the robot turn anywhere on its way; where it cannot (holding a beam it
                # sweeps metres), its whole body's way in the plane, arriving facing the point
                planned += 1
                poses = self.plan_poses(robot, candidate, facing, keep_out=list(keep_out) + list(low_keep_out))
                if poses is not None:
                    path = poses
                elif turns != "at the start":  # (there, drive may back out of the way first)
                    path = None
                    why = f"{why}; nor a way driving forward and backward ({planned} tried)"
            elif turns and turns != "at the start":
                path = None
            if path is None:
                continue
            tried += 1
            try:  # there, and turned to face the point (a turn that would touch something: the next stand)
                self.drive(robot, candidate, path=path)
                self.turn(robot, facing)
            except MotionFailed as failure:
                why = str(failure)
                continue
            return
        raise Blocked(f"no stand for {robot} within reach of ({point[0]:.2f}, {point[1]:.2f}): {why}")

    def _stand_radii(self, robot: str, distance: float, checked: bool) -> list[float]:
        """Distances (m) from the point worked on to the base's centre of the stands :meth:`approach`
        tries, best first: the arm's base 1, 0.85, 1.15 and 0.7 x ``distance`` from it; when the reach
        of each stand is ``checked``, then further out in 0.25 m steps to 90 % of the arm's horizontal
        reach (the middle one of a row of long beams lying 0.5 m apart on the yard is reached
        from beyond a beam's end, not from between two)."""
        model = self.robots[robot].model
        radii = [factor * distance for factor in (1.0, 0.85, 1.15, 0.7)]
        if checked:
            longest = 0.9 * (abs(model.dh[1][0]) + abs(model.dh[2][0]))
            radii += list(np.arange(1.15 * distance + 0.25, longest, 0.25))
        return [r + model.arm_mount[0] for r in radii]

    def _turns_on(self, robot: str, path: list, facing: float) -> str:
        """Where the robot, driving the grid ``path`` (turn, then straight, per leg) from where it
        stands, cannot make its first turn ("at the start") or the turn to ``facing`` at the end ("at
        the end") without sweeping into something; "" when it can make both."""
        x, y, yaw = self.base_xy_yaw(robot)
        here = np.array([x, y])
        try:
            first = path[0] - here
            if np.linalg.norm(first) > 0.02:
                self._turning_way(robot, yaw, math.atan2(first[1], first[0]))
        except Blocked:
            return "at the start"
        before = path[-2] if len(path) > 1 else here
        arrival = math.atan2(*(path[-1] - before)[::-1]) if np.linalg.norm(path[-1] - before) > 0.02 else yaw
        try:
            self._turning_way(robot, arrival, facing, path[-1])
        except Blocked:
            return "at the end"
        return ""

    def _reaches(self, robot: str, reach, xy, yaw: float) -> bool:
        """Whether the arm reaches every tool pose of ``reach(xy, yaw)`` (4x4, world) with the base at
        ``xy`` heading ``yaw``, one after the other as it will move (each solved from the joints of
        the one before: inverse kinematics near the edge of the workspace depends on its seed, and a
        column's install checked from the carrying posture alone failed 148 mm out of reach on the
        way), its arm touching nothing at any of them or on its joint-space way between them (reaching
        from a stand beyond a neighbour on the yard, a transport's upper arm met the neighbour);
        ``reach`` may also be a list of poses, or empty."""
        poses = reach(xy, yaw) if callable(reach) else reach
        if not len(poses):
            return True
        r = self.robots[robot]
        arm_base = self.moved_to(robot, xy, yaw) @ self.arm_base_pose(robot)
        joints = r.q_ref
        scratch = self.scratch_state()
        stand = (np.asarray(xy, float), float(yaw))
        try:  # (q_ref is the seed of solve; nothing steps the simulation meanwhile)
            for pose in poses:
                before = r.q_ref
                r.q_ref = self.solve(robot, pose, avoid_contacts=True, arm_base=arm_base, stand=stand)
                # and on the way there, which the arm goes in joint space (turning towards a beam's
                # place, a 4 m arm's upper arm swept through the column beside its stand)
                for fraction in REACH_PATH_FRACTIONS:
                    if self.arm_contacts_at(robot, before + (r.q_ref - before) * fraction, scratch, stand=stand):
                        return False
        except MotionFailed:
            return False
        finally:
            r.q_ref = joints
        return True

    # --- arm ---------------------------------------------------------------------------------------
    def arm_base_pose(self, robot: str) -> np.ndarray:
        return self.body_pose(f"{robot}/arm_base")

    def solve(self, robot: str, tcp_world: np.ndarray, avoid_contacts: bool = False,
              arm_base: np.ndarray | None = None, stand=None) -> np.ndarray:
        """Joint angles putting the tool centre point at ``tcp_world`` (4x4); MotionFailed when out of
        reach (IK error over tolerance). Of the solutions from several seeds (the current joints, the
        ready posture), the ones whose links stay above the ground (an elbow-down solution of an arm
        on a low base would dig in) and, of those (with ``avoid_contacts``: first those at which the arm
        touches nothing), the nearest to the current joints. ``arm_base``: solve as if the arm's base
        stood there (4x4, world) instead of where it is, its base at ``stand`` ((xy, yaw), for the
        contacts)."""
        r = self.robots[robot]
        arm_base = self.arm_base_pose(robot) if arm_base is None else arm_base
        local = np.linalg.inv(arm_base) @ tcp_world
        full_turn = np.array([True, True, False, True, True, True])
        best, found = None, []
        pan = math.atan2(local[1, 3], local[0, 3])  # elbow-up seeds turned towards the goal
        toward = [np.array([pan, *seed[1:]]) for seed in (READY_SEED, REACH_SEED)]
        # the elbow-up families turned towards the goal come last: mink's differential IK stays in
        # the family of its seed, and a level tool at the shoulder's height is often reached from
        # the first seeds only with the elbow (a metres-long forearm) below the ground
        families = [np.array([pan, lift, elbow, wrist_1, wrist_2, 0.0]) for lift, elbow, wrist_1, wrist_2 in ELBOW_UP_SEEDS]
        for seed in (r.q_ref, self._ready_posture_cached(robot), READY_SEED, *toward, *families):
            q, position_error, angle_error = r.ik.solve(local, seed)
            if best is None or position_error < best[1]:
                best = (q, position_error, angle_error)
            if position_error < motion.IK_POSITION_TOLERANCE_M and angle_error < motion.IK_ANGLE_TOLERANCE_RAD:
                q = motion.wrap_near(q, r.q_ref, full_turn)
                lowest = arm_base[2, 3] + r.ik.lowest_link(q)
                clear = lowest >= self.ground_z + 0.06 * r.model.scale
                change = float(np.abs(q - r.q_ref).max())
                touches = avoid_contacts and clear and bool(self.arm_contacts_at(robot, q, stand=stand))
                found.append((not clear, touches, change, q))
                if clear and not touches and change < 1.5:
                    break
        p = tcp_world[:3, 3]
        if found and not min(found, key=lambda item: item[:3])[0]:
            return min(found, key=lambda item: item[:3])[3]
        if found:
            raise MotionFailed(f"the arm of {robot} reaches ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) only with a link "
                               "in the ground")
        raise MotionFailed(f"({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) is out of reach of the arm of {robot} "
                           f"(inverse kinematics ends {best[1] * 1000:.0f} mm away)")

    def _ready_posture_cached(self, robot: str) -> np.ndarray:
        if not hasattr(self, "_ready"):
            self._ready = {}
        if robot not in self._ready:
            self._ready[robot] = self._ready_posture(self.robots[robot].model)
        return self._ready[robot]

    def move_arm(self, robot: str, q_goal: np.ndarray, check_contacts: bool = True, onto_seat: bool = False) -> float:
        """Move the arm to ``q_goal`` along a smooth joint-space interpolation at the arm's speed;
        MotionFailed on a collision or when the arm cannot follow (torque limits). When the straight
        joint-space path of an empty arm would touch something (checked on positions beforehand), it goes through
        the first via posture of :meth:`_via_postures` from which both halves are clear. ``onto_seat``:
        the move lowers the held component onto what it rests on; stopped short by that contact, the
        move is done (a guarded move: the component sits on its seat). Returns seconds."""
        if check_contacts and not self.robots[robot].holding:  # a held member is moved in short steps instead
            already = set(self.robot_contacts(robot))
            start = self.robots[robot].q_ref.copy()
            if self._path_contacts(robot, start, q_goal, already):
                for via in self._via_postures(robot, start, q_goal):
                    if not self._path_contacts(robot, start, via, already) and \
                            not self._path_contacts(robot, via, q_goal, already):
                        return self._move_arm(robot, via, True) + self._move_arm(robot, q_goal, True, onto_seat)
                path = self.plan_arm(robot, q_goal)
                if path is not None:
                    seconds = sum(self._move_arm(robot, q, True) for q in path[1:-1])
                    return seconds + self._move_arm(robot, q_goal, True, onto_seat)
        return self._move_arm(robot, q_goal, check_contacts, onto_seat)

    def plan_arm(self, robot: str, q_goal: np.ndarray, iterations: int = planning.ARM_ITERATIONS) -> list[np.ndarray] | None:
        """Joint vectors (rad) from the arm's joints to ``q_goal`` along which the arm keeps 2 cm from
        everything, its links above the ground (OMPL's RRT-Connect in joint space, checked on
        positions every 0.01 rad; see :mod:`bimrobot.physics.planning`). What it is nearer than
        that to at its start it may stay as near to, never nearer. None when none is found within
        ``iterations`` of the planner (a count, not a time)."""
        r = self.robots[robot]
        start = r.q_ref.copy()
        scratch = self.scratch_state()
        arm = self.idx[robot]["q"]
        base_z = self.arm_base_pose(robot)[2, 3]
        ground = self.ground_z + 0.06 * r.model.scale
        probe = self._probe_model(robot, 0.02)
        already = self._contacts_within(robot, probe, scratch, arm, start)

        def valid(q):
            if base_z + r.ik.lowest_link(q) < ground:
                return False
            return self._no_nearer(self._contacts_within(robot, probe, scratch, arm, q), already)

        ranges = self.model.jnt_range[[self.model.joint(f"{robot}/{j}").id for j in JOINT_NAMES]]
        limited = ranges[:, 1] > ranges[:, 0]
        lower = np.where(limited, ranges[:, 0], np.minimum(start, q_goal) - 2 * math.pi)
        upper = np.where(limited, ranges[:, 1], np.maximum(start, q_goal) + 2 * math.pi)
        if not valid(np.asarray(q_goal, float)):
            return None
        return planning.joint_path(valid, start, q_goal, lower, upper, resolution_rad=0.01, iterations=iterations)

    def _path_contacts(self, robot: str, q_from: np.ndarray, q_to: np.ndarray, already: set) -> list[str]:
        """What the arm would newly touch on the straight joint-space path (24 samples, positions only)."""
        scratch = self.scratch_state()
        for t in np.linspace(0.0, 1.0, 25)[1:]:
            touching = self.arm_contacts_at(robot, q_from + (q_to - q_from) * t, scratch, already)
            if touching:
                return touching
        return []

    def _via_postures(self, robot: str, q_from: np.ndarray, q_to: np.ndarray) -> list[np.ndarray]:
        """Postures to go through around an obstacle: the ready posture (and, for the heavy variant,
        the tucked one) turned as at the start, as at the goal, and as it is."""
        full_turn = np.array([True, True, False, True, True, True])
        r = self.robots[robot]
        postures = [self._ready_posture_cached(robot)]
        if r.model.family == "heavy":  # only empty arms go round (see move_arm): tucking is allowed
            postures.append(TUCK_POSTURE)
        out = []
        for posture in postures:
            for pan in (q_from[0], q_to[0], posture[0]):
                out.append(motion.wrap_near(np.array([pan, *posture[1:]]), q_from, full_turn))
        return out

    def _move_arm(self, robot: str, q_goal: np.ndarray, check_contacts: bool = True, onto_seat: bool = False) -> float:
        r = self.robots[robot]
        start_q = r.q_ref.copy()
        start_tcp = self.tcp_pose(robot)[:3, 3]
        goal_tcp = self._tcp_of(robot, q_goal)
        # a held component is swung at a third of the speed: its inertia (a 4 m member's is hundreds of
        # kg m2) would otherwise need more than the wrists' torque limits to accelerate it
        joint_speed = JOINT_SPEED_RAD_S / (3.0 if r.holding else 1.0)
        seconds = max(float(np.abs(q_goal - start_q).max()) / joint_speed,
                      float(np.linalg.norm(goal_tcp - start_tcp)) / r.arm_speed_m_s, 0.5)
        dt = 0.01
        # what it touches already it may move away from (an arm left against a column by a failed
        # activity could otherwise never move again)
        already = set(self.robot_contacts(robot)) if check_contacts else set()
        before = self.component_poses() if check_contacts else {}
        for reference in motion.smooth_steps(start_q, q_goal, seconds, dt):
            r.q_ref = reference
            self.step(dt)
            if check_contacts:
                touching = self.robot_contacts(robot, besides=already)
                pushed = self.shoved(robot, before)
                if touching or pushed:
                    r.q_ref = self.arm_q(robot)  # stop there: pressing on would push what it touches
                    what = f"collision while moving the arm of {robot}: {'; '.join(touching)}" if touching else \
                        f"the arm of {robot} pushed {'; '.join(pushed)}"
                    raise MotionFailed(what)
        error = self._settle(robot, goal_tcp)
        if error > TRACKING_TOLERANCE_M and not (onto_seat and self.seated(robot)):
            joints = self.saturated(robot)
            why = f"torque limit of {', '.join(joints)}" if joints else "it could not follow"
            raise MotionFailed(f"the arm of {robot} ended {error * 1000:.0f} mm from its goal ({why})")
        return seconds + 0.5

    def _settle(self, robot: str, goal_tcp: np.ndarray) -> float:
        """Wait until the arm is in position (its tcp within TRACKING_TOLERANCE_M of ``goal_tcp``) or
        at rest, for at least 0.5 s and at most SETTLE_MAX_S; returns the tcp's distance to the goal
        (m). An arm holding a member near its torque limits creeps the last millimetres in."""
        self.step(0.5)
        waited = 0.5
        while True:
            error = float(np.linalg.norm(self.tcp_pose(robot)[:3, 3] - goal_tcp))
            moving = float(np.abs(self.data.qvel[self.idx[robot]["v"]]).max()) > 1e-3
            if error <= TRACKING_TOLERANCE_M or not moving or waited >= SETTLE_MAX_S:
                return error
            self.step(0.25)
            waited += 0.25

    def move_tcp_through(self, robot: str, poses: list[np.ndarray], check_contacts: bool = True,
                         onto_seat: bool = False, avoid_contacts: bool = False) -> None:
        """Move the tool centre point through ``poses`` (4x4, world), each reached by inverse kinematics
        and a joint-space move; holding a component, in steps of at most 0.3 m and 30 degrees (one
        joint-space move between two poses lets the tool, and a long member with it, tilt on the way).
        ``onto_seat``: the last pose sets the held component on its seat (see :meth:`move_arm`);
        ``avoid_contacts``: see :meth:`solve`."""
        for goal in poses:
            steps = self._steps(robot, self.tcp_pose(robot), goal)
            for step in steps:
                last = onto_seat and goal is poses[-1] and step is steps[-1]
                self.move_arm(robot, self.solve(robot, step, avoid_contacts), check_contacts=check_contacts, onto_seat=last)

    def _steps(self, robot: str, here: np.ndarray, goal: np.ndarray) -> list[np.ndarray]:
        """The tool poses of a move from ``here`` to ``goal`` (see :meth:`move_tcp_through`)."""
        if not self.robots[robot].holding:
            return [goal]
        angle = motion.angle_between(here[:3, :3], goal[:3, :3])
        count = max(1, math.ceil(max(np.linalg.norm(goal[:3, 3] - here[:3, 3]) / 0.3, angle / math.radians(30))))
        return [motion.between(here, goal, k / count) for k in range(1, count + 1)]

    def tcp_path(self, robot: str, start: np.ndarray, poses: list[np.ndarray]) -> list[np.ndarray]:
        """Every tool pose :meth:`move_tcp_through` goes by from ``start`` through ``poses``."""
        path, here = [], start
        for goal in poses:
            path += self._steps(robot, here, goal)
            here = goal
        return path

    def moved_to(self, robot: str, xy, yaw: float) -> np.ndarray:
        """The rigid motion (4x4, world) that takes the robot as it stands to ``xy`` heading ``yaw``:
        where its tool would be, carried along, is this @ the tool's pose now."""
        x, y, now = self.base_xy_yaw(robot)
        return motion.planar(xy[0], xy[1], yaw) @ np.linalg.inv(motion.planar(x, y, now))

    def carry_posture(self, robot: str) -> np.ndarray:
        """Arm joints of the carry posture: the tool down over the base's front (the ready posture),
        turned so that a held component's longest side runs across the base (a long member then
        sticks out to the sides, clear of the chassis when set down in front)."""
        r = self.robots[robot]
        ready = self._ready_posture_cached(robot)
        if not r.holding:
            return ready
        s = r.model.scale
        long_axis = r.grip[:3, 0]  # the component's x (its longest side), in the gripper frame
        axis = motion.tool_down(0.0) @ long_axis  # in the arm base frame, with the tool at yaw 0
        turn = math.atan2(axis[1], axis[0])
        best = None
        # seeded from the joints as they are too: seeded only from the ready posture, the solution may
        # be the same tool pose with the wrist flipped, and the move there swings the held member
        # half a turn about the wrists
        for across, seed in itertools.product((math.pi / 2, -math.pi / 2), (r.q_ref, ready)):
            tool = motion.tool_down(across - turn)
            q, position_error, angle_error = r.ik.solve(motion.pose(tool, (0.35 * s, 0.0, 0.45 * s)), seed)
            if position_error < motion.IK_POSITION_TOLERANCE_M and angle_error < motion.IK_ANGLE_TOLERANCE_RAD:
                q = motion.wrap_near(q, r.q_ref, np.array([True, True, False, True, True, True]))
                cost = float(np.abs(q - r.q_ref).max())
                if best is None or cost < best[1]:
                    best = (q, cost)
        return ready if best is None else best[0]

    def _tcp_of(self, robot: str, q: np.ndarray) -> np.ndarray:
        """World position of the tcp for arm joints ``q`` with the base where it is (forward kinematics)."""
        return self._tcp_pose_at(robot, q)[:3, 3]

    def commanded_tcp_pose(self, robot: str) -> np.ndarray:
        """The tool centre point's pose (4x4, world) at the arm's commanded joints, the base where it is:
        where the arm settles. An arm holding a long member lags and sags centimetres behind its
        command for a while; a reach checked from where its tool is at that moment did not hold once
        it had settled (a 3.2 m beam, 30 mm at the edge of a 4 m arm's reach)."""
        return self._tcp_pose_at(robot, self.robots[robot].q_ref)

    def _tcp_pose_at(self, robot: str, q: np.ndarray) -> np.ndarray:
        """The tcp's pose (4x4, world) for arm joints ``q`` with the base where it is (forward kinematics)."""
        ik = self.robots[robot].ik
        data = self.mj.MjData(ik.model)
        data.qpos[:6] = q
        self.mj.mj_kinematics(ik.model, data)
        tcp = data.site("tcp")
        return self.arm_base_pose(robot) @ motion.pose(tcp.xmat.reshape(3, 3).copy(), tcp.xpos.copy())

    # --- gripper -----------------------------------------------------------------------------------
    def grasp_pose(self, component: str, placement: np.ndarray | None = None) -> np.ndarray:
        """Where the tcp grasps a component: on its vertical axis, FINGER_DEPTH_M below its top, tool
        down, jaws across its x axis (4x4 world; ``placement``: the component's pose, default where it is)."""
        pose = self.body_pose(component) if placement is None else placement
        height = self.components[component].size[2]
        yaw = yaw_of(pose)
        point = pose[:3, 3] + pose[:3, 2] * (height - FINGER_DEPTH_M)
        return motion.pose(motion.tool_down(yaw), point)

    def held_in_tcp(self, robot: str) -> np.ndarray:
        """Pose (4x4) of the held component in the tool centre point's frame, as the weld holds it.
        Plans use this, not the poses measured at the moment: the weld gives a little under load (a
        held member yaws a few degrees in the gripper while the base turns) and springs back."""
        r = self.robots[robot]
        tcp_in_gripper = np.eye(4)
        tcp_in_gripper[:3, 3] = self.model.site(f"{robot}/tcp").pos
        return np.linalg.inv(tcp_in_gripper) @ r.grip

    def close_gripper(self, robot: str, component: str) -> None:
        """Close the jaws on the component and switch the weld on; MotionFailed when the tcp is not
        within the grasp tolerance."""
        target = self.grasp_pose(component)
        tcp = self.tcp_pose(robot)
        offset = float(np.linalg.norm(tcp[:3, 3] - target[:3, 3]))
        angle = math.degrees(min(motion.angle_between(tcp[:3, :3], target[:3, :3]),
                                 motion.angle_between(tcp[:3, :3], target[:3, :3] @ np.diag([-1, -1, 1]))))
        if offset > GRASP_POSITION_TOLERANCE_M or angle > GRASP_ANGLE_TOLERANCE_DEG:
            raise MotionFailed(f"the gripper of {robot} is {offset * 1000:.1f} mm and {angle:.1f} degrees from the "
                               f"grasp pose of {component} (tolerance {GRASP_POSITION_TOLERANCE_M * 1000:.0f} mm, "
                               f"{GRASP_ANGLE_TOLERANCE_DEG:.0f} degrees)")
        width = self.components[component].size[1]
        self.data.ctrl[self.idx[robot]["fingers"]] = min(width / 2, self.robots[robot].model.gripper_opening / 2)
        self.step(0.3)
        relative = np.linalg.inv(self.body_pose(f"{robot}/gripper")) @ self.body_pose(component)
        self._weld(robot, component, relative)
        self.robots[robot].holding, self.robots[robot].grip = component, relative
        self._touches_robots(component, False)
        self.robots[robot].held_gains = self._held_gains(robot, component)
        self.step(0.2)

    def _held_gains(self, robot: str, component: str) -> tuple[np.ndarray, np.ndarray]:
        """The arm's PD gains with the damping raised for the held component's inertia as each joint
        feels it (m J_p^T J_p + J_r^T I J_r, diagonal): a 4 m member on a wrist tuned for the wrist's
        own links would ring until the torque limits give way."""
        kp, _ = self.robots[robot].gains
        m, d, idx = self.model, self.data, self.idx[robot]
        body = d.body(component)
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        self.mj.mj_jac(m, d, jacp, jacr, body.xipos, idx["gripper"])
        jp, jr = jacp[:, idx["v"]], jacr[:, idx["v"]]
        rotation = body.ximat.reshape(3, 3)
        inertia = rotation @ np.diag(m.body(component).inertia) @ rotation.T
        full = np.zeros((m.nv, m.nv))
        self.mj.mj_fullM(m, d, full)
        own = np.maximum(np.diag(full)[idx["v"]], 1e-3)
        load = self.components[component].mass * np.sum(jp * jp, axis=0) + np.einsum("ij,ik,kj->j", jr, inertia, jr)
        return kp, 2.0 * np.sqrt(kp * (own + load))

    def _touches_robots(self, component: str, touches: bool) -> None:
        """A held component does not collide with the robots (the one holding it turns it past its
        own arm and chassis), only with the ground and the supports; let go, it does again."""
        affinity = (3 if touches else 1) | PROP_CONTYPE
        self.spec.geom(f"{component}/box").conaffinity = affinity
        self.model.geom(f"{component}/box").conaffinity = affinity

    def _weld(self, robot: str, component: str, relative: np.ndarray) -> None:
        """Switch on the weld holding ``component`` at ``relative`` (4x4, in the gripper's frame)."""
        equality = self.model.equality(f"{robot}/grasp/{component}")
        self.model.eq_data[equality.id, 0:3] = 0.0
        self.model.eq_data[equality.id, 3:6] = relative[:3, 3]
        self.model.eq_data[equality.id, 6:10] = quat_wxyz(relative[:3, :3])
        self.model.eq_data[equality.id, 10] = 1.0
        self.data.eq_active[equality.id] = 1

    def open_gripper(self, robot: str) -> None:
        held = self.robots[robot].holding
        if held:
            self.data.eq_active[self.model.equality(f"{robot}/grasp/{held}").id] = 0
            self._touches_robots(held, True)
        self.robots[robot].holding = None
        self.data.ctrl[self.idx[robot]["fingers"]] = self.robots[robot].model.gripper_opening / 2
        self.step(0.3)


def _robots_meet(spec, names: list[str]) -> None:
    """Give each robot's colliding geoms (contype 2, conaffinity 1: they meet the building, not each
    other, nor the robot's own links) a bit of their own, and every other robot's geoms that bit in
    their conaffinity: robots collide with each other, not with themselves. Robots past
    :data:`ROBOT_BITS` get none and pass through the others (documented)."""
    bits = {name: 1 << (ROBOT_BIT_0 + k) for k, name in enumerate(names[:ROBOT_BITS])}
    everyone = sum(bits.values())
    for geom in spec.geoms:
        owner = geom.name.split("/", 1)[0]
        if owner in bits and geom.contype & 2:
            geom.contype |= bits[owner]
            geom.conaffinity |= everyone & ~bits[owner]


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def _line_blocked(a, b, blocked) -> bool:
    return not motion._line_free(np.asarray(a, float), np.asarray(b, float), blocked, GRID_M / 2)
