"""The ``mujoco`` backend's *position for picking up* and *pick up* features: the component appears
(on the yard, or at its target for the thesis' experiments), the base stands within reach, the tool
comes down through a pre-grasp pose, the gripper closes and the arm lifts :data:`LIFT_M`."""

from __future__ import annotations

import numpy as np

from bimrobot.rcan.backends.mujoco.common import LIFT_M
from bimrobot.rcan.backends import features
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.node import RcanNode


class PositionForPickingUp(features.PositionForPickingUp):
    """The *position for picking up* feature (see the module docstring)."""

    def position_for_picking_up(self, node: RcanNode, attempt: int = 1, ready_at_s: float = 0.0,
                                feedback=None) -> ActivityResult:
        """*Position for picking up* in the one physical world, in its turn: the work of :meth:`_position_for_picking_up`
        (:meth:`MujocoBackend.act`)."""
        return self.act(node, attempt, ready_at_s, feedback, self._position_for_picking_up)

    def _position_for_picking_up(self, node: RcanNode) -> str:
        from bimrobot.physics.placement import lying_pose

        site, robot, gid = self.site, node.robot, node.component_id
        legacy = gid in self.shapes
        if gid not in site.components:
            if legacy:
                shape = self._shape(node)
                site.make_room(robot, (node.target.x, node.target.y), self._support_half(shape))
                self._spawn(node, self._placement(node, shape), "stand")
            else:  # it lies as on the yard, centred on the target (see bimrobot.physics.placement)
                target = node.target
                self._spawn_box(node.activity, lying_pose(self._size(node.activity), (target.x, target.y, target.z), target.yaw), "stand")
        grasp = site.grasp_pose(gid)
        if not legacy:  # (the stand's reach is checked: boxed in on the yard, it may stand further out)
            site.approach(robot, grasp[:2, 3], reach=[self._above(grasp), grasp])
        site.face(robot, site.body_pose(gid)[:2, 3] if legacy else grasp[:2, 3])
        grasp = site.grasp_pose(gid)  # where it is now: driving up to it may have nudged it
        # (of the arm's solutions, one touching nothing: reaching over a neighbour on the yard, the
        # nearest one had a transport's upper arm on it)
        site.move_tcp_through(robot, [self._above(grasp), grasp], avoid_contacts=True)
        grasp = site.grasp_pose(gid)
        if np.linalg.norm(site.tcp_pose(robot)[:3, 3] - grasp[:3, 3]) > 0.002:  # it moved as the arm came: once more
            site.move_tcp_through(robot, [grasp])
        return f"{node.kind.label} {gid}: gripper at the grasp pose"


class PickUp(features.PickUp):
    """The *pick up* feature (see the module docstring)."""

    def pick_up(self, node: RcanNode, attempt: int = 1, ready_at_s: float = 0.0,
                feedback=None) -> ActivityResult:
        """*Pick up* in the one physical world, in its turn: the work of :meth:`_pick_up`
        (:meth:`MujocoBackend.act`)."""
        return self.act(node, attempt, ready_at_s, feedback, self._pick_up)

    def _pick_up(self, node: RcanNode) -> str:
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if gid not in site.components:
            raise MotionFailed(f"{gid} is not in the scene: position for picking up comes first")
        site.close_gripper(robot, gid)
        try:
            site.move_arm(robot, site.solve(robot, self._above(site.tcp_pose(robot))))
        except MotionFailed as failure:
            site.open_gripper(robot)
            site.step(1.0)
            mass = site.components[gid].mass
            payload = self.capabilities.by_name[robot].payload_kg
            raise MotionFailed(f"{gid} weighs {mass:.1f} kg: the arm of {robot} (rated payload {payload:.1f} kg, "
                               f"{self.families[robot].family} model) cannot lift it: {failure}") from None
        return f"{node.kind.label} {gid}: held and lifted {LIFT_M:.2f} m"
