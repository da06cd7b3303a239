"""Clearance of a robot's base in the MuJoCo site: what it must keep away from, as boxes in plan view.

Obstacles are axis-aligned boxes (centre xy, half size xy; m, world): supports, components on the
ground or held by another robot, and the other robots (chassis low, arm tall). A robot may stand
(and turn in place) where its sweep radius keeps :data:`CLEARANCE_M` from the tall ones and its
chassis' half diagonal from the low ones.

Public: :meth:`~ClearanceSkill.obstacles`, :meth:`~ClearanceSkill.robot_boxes`,
:meth:`~ClearanceSkill.component_box`, :meth:`~ClearanceSkill.stand_clear`,
:meth:`~ClearanceSkill.footprint_clear`, :meth:`~ClearanceSkill.near_box`,
:meth:`~ClearanceSkill.sweep_radius`, :meth:`~ClearanceSkill.driving_posture`.
"""

from __future__ import annotations

import math

import numpy as np

from bimrobot.physics.site.common import CLEARANCE_M


class ClearanceSkill:
    """What a base keeps away from (see the module docstring)."""

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

    def stand_clear(self, robot: str, xy, low, tall) -> bool:
        """Whether the robot may stand (and turn) at ``xy`` with these obstacles (see obstacles())."""
        base = math.hypot(*self.robots[robot].model.footprint) / 2 + CLEARANCE_M
        return not self.near_box(xy, low, base) and not self.near_box(xy, tall, self.sweep_radius(robot) + CLEARANCE_M)

    def footprint_clear(self, robot: str, xy, yaw: float, boxes, clearance: float = CLEARANCE_M) -> bool:
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

    def near_box(self, xy: np.ndarray, boxes, radius: float) -> bool:
        for centre, half in boxes:
            gap = np.maximum(np.abs(xy - centre) - half, 0.0)
            if np.linalg.norm(gap) < radius:
                return True
        return False

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

    def driving_posture(self, robot: str) -> np.ndarray:
        """The arm's joints (rad) while the base drives: as they are when it holds something, else
        where :meth:`stow_arm` puts them."""
        r = self.robots[robot]
        return r.q_ref.copy() if r.holding else self.stowed_posture(robot)
