"""The gripper of a robot in the MuJoCo site: a grasp is a weld between the gripper and the component,
switched on only when the tool centre point is within :data:`GRASP_POSITION_TOLERANCE_M` and
:data:`GRASP_ANGLE_TOLERANCE_DEG` of the grasp pose; the arm's damping is raised for what it holds.

Public: :meth:`~GraspSkill.grasp_pose`, :meth:`~GraspSkill.held_in_tcp`, :meth:`~GraspSkill.close_gripper`,
:meth:`~GraspSkill.open_gripper`.
"""

from __future__ import annotations

import math

import numpy as np

from bimrobot.core.frames import quat_wxyz, yaw_of
from bimrobot.physics import motion
from bimrobot.physics.site.common import (FINGER_DEPTH_M, GRASP_ANGLE_TOLERANCE_DEG, GRASP_POSITION_TOLERANCE_M,
                                          PROP_CONTYPE, MotionFailed)


class GraspSkill:
    """Grasping and letting go (see the module docstring)."""

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
