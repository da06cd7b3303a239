"""The world of the MuJoCo site: the model, and where everything is in it.

:class:`WorldSkill` builds one MuJoCo model: a ground slab (with pits cut for what is installed below
the ground), the robots at their homes, and the components and supports added as they become known
(``MjSpec.recompile`` keeps the state). It reads poses: bodies, the tool centre point, the base.

Public: :meth:`~WorldSkill.add_component`, :meth:`~WorldSkill.add_support`, :meth:`~WorldSkill.add_pit`,
:meth:`~WorldSkill.body_pose`, :meth:`~WorldSkill.tcp_pose`, :meth:`~WorldSkill.base_xy_yaw`,
:meth:`~WorldSkill.arm_q`, :meth:`~WorldSkill.arm_base_pose`, :meth:`~WorldSkill.body_names`,
:meth:`~WorldSkill.scratch_state`; the state ``model``, ``data``, ``robots``, ``components``,
``supports``, ``props``, ``pits``, ``ground_z``, ``time_s``, ``frames``, ``idx`` (MuJoCo addresses per
robot). Poses are 4x4 (world, metres).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from bimrobot.core.frames import quat_wxyz
from bimrobot.physics import motion
from bimrobot.physics.robot import JOINT_NAMES, RobotModel, add_robot
from bimrobot.export.mujoco.scene import scene_root
from bimrobot.physics.site.common import (GRASP_TIME_CONSTANT_S, PIT_DEPTH_M, PROP_CONTYPE, READY_SEED, ROBOT_BIT_0,
                                          ROBOT_BITS, SITE_HALF_M, Component, Robot)


def ready_joints(model: RobotModel) -> np.ndarray:
    """Joint angles (rad) with the tool down above the base's front (the arm's rest and carry pose)."""
    ik = motion.ArmIK(model)
    s = model.scale
    q, _, _ = ik.solve(motion.pose(motion.tool_down(0.0), (0.35 * s, 0.0, 0.45 * s)),
                       READY_SEED)
    return q


class WorldSkill:
    """The model and where everything is in it (see the module docstring)."""

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
            ready = ready_joints(model)
            self.data.joint(f"{name}/x").qpos[0], self.data.joint(f"{name}/y").qpos[0] = home
            self.robots[name] = Robot(model, speed, arm_speed, motion.ArmIK(model), ready)
            for joint, angle in zip(JOINT_NAMES, ready):
                self.data.joint(f"{name}/{joint}").qpos[0] = angle
        self.pits: list[tuple[np.ndarray, np.ndarray]] = []  # (lower xy, upper xy)
        self._slabs: list = []
        self._cut_slabs()
        self._sweep: dict[tuple[str, tuple], float] = {}  # (robot, driving posture) -> m
        self._ready: dict[str, np.ndarray] = {}  # robot -> its ready posture (rad), once solved
        self.components: dict[str, Component] = {}
        self.supports: list[tuple[np.ndarray, np.ndarray]] = []  # static boxes (centre, half size)
        self.props: list[tuple[np.ndarray, np.ndarray]] = []  # the same, that only components meet
        self.time_s = 0.0
        self.frames: list[tuple[float, np.ndarray]] = []
        self._next_frame = 0.0
        self._reindex()
        mujoco.mj_forward(self.model, self.data)

    def _reindex(self) -> None:
        """MuJoCo's addresses of each robot's joints, actuators and bodies (``idx``), and its arm's PD
        gains the first time (from its joints' inertia), after every (re)compile."""
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
        """Compile the model again after a change of the spec, keeping the state and the grasps."""
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

    def arm_base_pose(self, robot: str) -> np.ndarray:
        return self.body_pose(f"{robot}/arm_base")

    def body_names(self) -> list[str]:
        return [self.model.body(b).name for b in range(1, self.model.nbody)]

    def scratch_state(self):
        """A copy of the positions of everything, to try poses on without touching the simulation."""
        scratch = self.mj.MjData(self.model)
        scratch.qpos[:] = self.data.qpos
        return scratch


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
