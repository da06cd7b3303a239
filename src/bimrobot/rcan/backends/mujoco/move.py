"""The ``mujoco`` backend's *move to component* feature: the base drives to the stand-off point on a
planned path (:meth:`~bimrobot.physics.site.MujocoSite.drive`)."""

from __future__ import annotations

import numpy as np

from bimrobot.rcan.backends import features
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.node import RcanNode


class MoveToComponent(features.MoveToComponent):
    """The *move to component* feature (see the module docstring)."""

    def move_to_component(self, node: RcanNode, attempt: int = 1, ready_at_s: float = 0.0,
                          feedback=None) -> ActivityResult:
        """*Move to component* in the one physical world, in its turn: the work of :meth:`_move_to_component`
        (:meth:`MujocoBackend.act`)."""
        return self.act(node, attempt, ready_at_s, feedback, self._move_to_component)

    def _move_to_component(self, node: RcanNode) -> str:
        goal = np.array([node.target.x, node.target.y])
        distance = self.site.drive(node.robot, goal)
        short = float(np.linalg.norm(self.site.base_xy_yaw(node.robot)[:2] - goal))
        note = f" (stopped {short:.2f} m short: the base does not fit at the stand-off point)" if short > 0.05 else ""
        return f"{node.kind.label} {node.component_id}: drove {distance:.2f} m{note}"
