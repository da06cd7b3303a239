"""Components and supports of the ``mujoco`` backend's scene: each component a box of its plan's size
(or a known shape), on the yard or in place, with a support under it (a pedestal; a prop under a
beam's middle third; a pit below the ground), robots making way before a support appears.
"""

from __future__ import annotations

import numpy as np

from bimrobot.rcan.activities import ActivityKind
from bimrobot.rcan.backends.mujoco.common import SUPPORT_MIN_Z_M
from bimrobot.rcan.backends.mujoco.layout import starting_activities
from bimrobot.rcan.node import RcanNode


class SceneParts:
    """Components and their supports in the scene (see the module docstring)."""

    def _size(self, activity) -> tuple[float, float, float]:
        from bimrobot.physics.site import MotionFailed

        if activity.size_m is None:
            raise MotionFailed(f"the shape of {activity.component_id} is unknown to the mujoco backend (the plan gives "
                               f"no size; it knows {', '.join(self.shapes)}): give it with shapes={{GlobalId: (w, d, h)}}")
        return tuple(float(v) for v in activity.size_m)

    def _size_of(self, gid: str) -> tuple[float, float, float]:
        length, b, a = self.site.components[gid].size
        return (a, b, length)

    def _shape(self, node: RcanNode) -> tuple[float, float, float]:
        from bimrobot.physics.site import MotionFailed

        shape = self.shapes.get(node.component_id) or node.activity.size_m  # (w, d, length), as planned
        if shape is None:
            raise MotionFailed(f"the shape of {node.component_id} is unknown to the mujoco backend (it knows "
                               f"{', '.join(self.shapes)}): give it with shapes={{GlobalId: (w, d, h)}}")
        return shape

    def _installed_box(self, activity):
        from bimrobot.physics.placement import installed_box

        others = [box for gid, box in self.installed.items() if gid != activity.component_id]
        target = activity.target
        return installed_box(self._size(activity), (target.x, target.y, target.z), target.yaw, others)

    def _spawn_plan(self, plan) -> None:
        """Put every component of ``plan`` (RCAN activities) where it starts: on the yard (lying, at the
        target of its first *position for picking up*) or, when no activity lifts it, in place (a
        footing). Components without a size or a weight stay out (their activities fail saying so)."""
        from bimrobot.physics.placement import lying_pose

        for activity in starting_activities(plan, self.shapes).values():
            if activity is None:
                continue
            if activity.kind is ActivityKind.POSITION_FOR_PICKING_UP:
                t = activity.target
                self._spawn_box(activity, lying_pose(self._size(activity), (t.x, t.y, t.z), t.yaw), "stand")
            else:
                self._spawn_in_place(activity)

    def _spawn_in_place(self, activity) -> None:
        from bimrobot.physics.placement import body_pose, body_rotations

        box = self._installed_box(activity)
        placement = body_pose(self._size(activity), box, body_rotations(self._size(activity), box)[0])
        self._spawn_box(activity, placement, "support")
        self.targets[activity.component_id], self.installed[activity.component_id] = placement, box

    def _spawn_box(self, activity, placement: np.ndarray, support: str):
        """Put the component's box (body size (L, b, a)) at ``placement``, on a support when it is
        above the ground and in a pit when below."""
        from bimrobot.physics.placement import body_size
        from bimrobot.physics.site import Component, MotionFailed

        if activity.weight_kg is None:
            raise MotionFailed(f"the weight of {activity.component_id} is unknown: the scene cannot simulate it")
        size = body_size(self._size(activity))
        half = (np.abs(placement[:3, :3]) @ np.array(size) / 2)[:2] + 0.01
        centre = (placement @ np.array([0.0, 0.0, size[2] / 2, 1.0]))[:3]
        # its lowest point, whichever way it is turned (an upright member's body z is horizontal)
        bottom = float(centre[2] - (np.abs(placement[:3, :3]) @ np.array(size) / 2)[2])
        self._support_under(activity.component_id, centre[:2], bottom, half, support)
        self.site.add_component(Component(activity.component_id, size, float(activity.weight_kg)), placement)

    def _spawn(self, node: RcanNode, placement: np.ndarray, support: str) -> None:
        from bimrobot.physics.site import Component, MotionFailed

        if node.activity.weight_kg is None:
            raise MotionFailed(f"the weight of {node.component_id} is unknown: the scene cannot simulate it")
        shape = self._shape(node)
        if abs(placement[2, 3] - self.site.ground_z) > SUPPORT_MIN_Z_M:
            if placement[2, 3] < self.site.ground_z:
                self.site.add_pit(placement[:2, 3], self._support_half(shape))
            self._add_support(node.component_id, placement, support, shape)
        self.site.add_component(Component(node.component_id, shape, float(node.activity.weight_kg)), placement)

    def _placement(self, node: RcanNode, shape) -> np.ndarray:
        """The component's origin (bottom face centre) when its centre is at the node's target (4x4)."""
        from bimrobot.physics.motion import planar

        return planar(node.target.x, node.target.y, node.target.yaw, node.target.z - shape[2] / 2)

    @staticmethod
    def _support_half(shape) -> tuple[float, float]:
        return (max(shape[0], shape[1]) / 2 + 0.01,) * 2

    def _add_support(self, gid: str, placement: np.ndarray, kind: str, shape=None) -> None:
        half = self._support_half(shape or self.site.components[gid].size)
        self.site.add_support(f"{kind}/{gid}/{len(self.site.supports)}", placement[:2, 3], placement[2, 3], half)

    def _support_at(self, placement: np.ndarray) -> bool:
        return any(np.all(np.abs(placement[:2, 3] - c[:2]) <= h[:2]) and abs(c[2] + h[2] - placement[2, 3]) < 1e-3
                   for c, h in self.site.supports)

    def _support_under(self, gid: str, centre_xy, bottom_z: float, half_xy, kind: str, robot: str | None = None,
                       prop: bool = False) -> None:
        """A support under ``gid`` from the ground (or a pit's floor) up to ``bottom_z`` (m); robots
        make way for it first, unless it is a ``prop`` (see MujocoSite.add_support: they pass through)."""
        site = self.site
        if abs(bottom_z - site.ground_z) <= SUPPORT_MIN_Z_M:
            return
        if not prop:
            self._make_way(gid, centre_xy, half_xy, bottom_z, robot)
        if bottom_z < site.ground_z:
            site.add_pit(centre_xy, half_xy)
        site.add_support(f"{kind}/{gid}/{len(site.supports) + len(site.props)}", centre_xy, bottom_z, half_xy, prop)

    def _make_way(self, gid: str, centre_xy, half_xy, top_z: float, robot: str | None) -> None:
        """Before a support appears at ``centre_xy`` (a box of ``half_xy``, m, up to ``top_z``), every
        robot whose chassis stands on it or within the clearance drives aside, and every empty arm
        that reaches into it is stowed: ``robot`` (the one at work, in its carry posture) and any
        other waiting between activities (an arm is left where its last activity ended). Blocked
        when another one holds a component or has its gripper at one: its own work comes first."""
        from bimrobot.physics.site import Blocked, MotionFailed

        site = self.site
        box = (np.asarray(centre_xy, float)[:2], np.asarray(half_xy, float))
        for name, arm_in in self._in_the_way(box, top_z):
            self._raise_if_busy(name, gid, robot)
            try:
                if arm_in:
                    site.stow_arm(name)
                site.make_room(name, box[0], box[1])
            except MotionFailed as failure:
                raise Blocked(f"{name} stands where the support of {gid} goes and cannot move aside: {failure}") from None

    def _in_the_way(self, box, top_z: float) -> list[tuple[str, bool]]:
        """(robot, whether it is by its empty arm) for each robot whose chassis stands on ``box``
        (centre xy, half size xy; m) or within the clearance, or whose empty arm reaches into it
        below ``top_z``."""
        site, out = self.site, []
        for name in site.robots:
            x, y, yaw = site.base_xy_yaw(name)
            arm_in = not site.robots[name].holding and site.arm_within(name, box[0], box[1], top_z)
            if arm_in or not site.footprint_clear(name, (x, y), yaw, [box]):
                out.append((name, arm_in))
        return out

    def _raise_if_busy(self, name: str, gid: str, robot: str | None) -> None:
        """Blocked when robot ``name``, in the way of the support of ``gid``, is not ``robot`` and
        holds a component or has its gripper at one."""
        from bimrobot.physics.site import Blocked

        busy = name != robot and (self.site.robots[name].holding or self.at_work.get(name))
        if busy:
            raise Blocked(f"{name} stands where the support of {gid} goes, at work on {busy}")

    def _support_geometry(self, box) -> tuple[np.ndarray, np.ndarray, bool]:
        """(centre xy, half size xy, whether a prop) of the support an installed box rests on: a
        pedestal under an upright or flat one, a prop under the middle third (at most 1 m) of a
        horizontal member (the connections it hangs from in the building are not modelled)."""
        if box.kind == "horizontal":
            local = np.array([min(box.extents[0] / 6, 0.5), box.extents[1] / 2 + 0.01, 0.0])
            return box.centre[:2], (np.abs(box.frame) @ local)[:2], True
        return box.centre[:2], box.half_xy + 0.01, False

    def _support_for(self, gid: str, box, robot: str) -> None:
        """The support an installed box rests on (:meth:`_support_geometry`), robots making way."""
        centre, half, prop = self._support_geometry(box)
        self._support_under(gid, centre, box.bottom_z, half, "support", robot, prop=prop)

    def _check_support_place(self, gid: str, box, robot: str) -> None:
        """Blocked, before the robot lifts ``gid`` towards its seat, when another robot at work stands
        where its support will appear (found only once the component was held high, the robot was
        left holding a 4 m column up there, and every try after failed from that posture)."""
        centre, half, prop = self._support_geometry(box)
        if prop or abs(box.bottom_z - self.site.ground_z) <= SUPPORT_MIN_Z_M:
            return
        for name, _ in self._in_the_way((centre, half), box.bottom_z):
            self._raise_if_busy(name, gid, robot)
