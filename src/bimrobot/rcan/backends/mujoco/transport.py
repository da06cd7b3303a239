"""The ``mujoco`` backend's *transport* feature: the held component to the carry posture, the base
drives, and (when the transport frees the robot) the component is laid down at a free spot beside
which the fleet's largest robot can stand."""

from __future__ import annotations

import math

import numpy as np

from bimrobot.rcan.backends import features
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.node import RcanNode


class Transport(features.Transport):
    """The *transport* feature (see the module docstring)."""

    def transport(self, node: RcanNode, attempt: int = 1, ready_at_s: float = 0.0,
                  feedback=None) -> ActivityResult:
        """*Transport* in the one physical world, in its turn: the work of :meth:`_transport`
        (:meth:`MujocoBackend.act`)."""
        return self.act(node, attempt, ready_at_s, feedback, self._transport)

    def _transport(self, node: RcanNode) -> str:
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if site.robots[robot].holding != gid:
            down = self._set_down_near(gid, (node.target.x, node.target.y)) if node.activity.releases_robot else None
            if down is None:
                raise MotionFailed(f"robot {robot} does not hold {gid} to transport it")
            site.move_arm(robot, site.ready_posture(robot))  # what the attempt before did not finish
            return f"{node.kind.label} {gid}: set down at ({down[0]:.2f}, {down[1]:.2f}) by the attempt before"
        legacy = gid in self.shapes
        if legacy:
            site.move_arm(robot, site.ready_posture(robot))
        else:
            self._to_carry(robot)
        distance = site.drive(robot, (node.target.x, node.target.y))
        if not node.activity.releases_robot:
            return f"{node.kind.label} {gid}: carried {distance:.2f} m"
        if legacy:  # set it down in front of the base and let go
            self._set_down(robot, gid)
            return f"{node.kind.label} {gid}: carried {distance:.2f} m"
        spot = self._lay_down(robot, gid, (node.target.x, node.target.y))
        return f"{node.kind.label} {gid}: carried {distance:.2f} m, set down at ({spot[0]:.2f}, {spot[1]:.2f})"

    def _set_down_near(self, gid: str, near, within_m: float = 4.0):
        """Where (xy) ``gid`` lies on the ground within ``within_m`` of ``near``, held by no robot (an
        attempt of a transport set it down and then failed, e.g. its arm's retreat), or None."""
        site = self.site
        if gid not in site.components or any(r.holding == gid for r in site.robots.values()):
            return None
        centre, half = site.component_box(gid)
        on_ground = centre[2] - half[2] < site.ground_z + 0.02
        return centre[:2] if on_ground and np.linalg.norm(centre[:2] - np.asarray(near, float)) <= within_m else None

    def _to_carry(self, robot: str) -> None:
        """The held component to the carry posture over the base: pulled in level to the arm's
        working distance when it was picked up further out (below the carry height), then straight up, the tool down (a long
        member would otherwise dip its ends into the ground), then across the base."""
        from bimrobot.physics import motion

        site = self.site
        carry = site.carry_posture(robot)
        goal = site.tcp_position_at(robot, carry)
        here = site.tcp_pose(robot)
        arm = site.arm_base_pose(robot)[:2, 3]
        out = here[:2, 3] - arm
        if np.linalg.norm(out) > site.working_distance(robot) and here[2, 3] < goal[2]:
            # (picked from a stand beyond the working distance, a 290 kg column could not be lifted
            # straight up there: the arm's branch ended at the edge of its workspace; one held high
            # already, by an install that stopped, is not pulled in up there, out of reach)
            here[:2, 3] = arm + out * site.working_distance(robot) / np.linalg.norm(out)
            site.move_tcp_through(robot, [here])
        up = site.tcp_pose(robot)
        up[2, 3] = max(up[2, 3], goal[2])
        site.move_tcp_through(robot, [up])
        # then over and turned in steps (30 degrees, 0.3 m at most), the tool kept pointing down: one
        # joint-space move would tilt the member on its way
        start_yaw = math.atan2(up[1, 0], up[0, 0])
        end = site.tcp_pose_at(robot, carry)[:3, :3]
        turn = math.remainder(math.atan2(end[1, 0], end[0, 0]) - start_yaw, 2 * math.pi)
        count = max(1, math.ceil(max(abs(turn) / math.radians(30), np.linalg.norm(goal - up[:3, 3]) / 0.3)))
        poses = [motion.pose(motion.tool_down(start_yaw + turn * k / count), up[:3, 3] + (goal - up[:3, 3]) * k / count)
                 for k in range(1, count + 1)]
        site.move_tcp_through(robot, poses)
        site.move_arm(robot, carry)

    def _lay_down(self, robot: str, gid: str, near) -> np.ndarray:
        """Set the held component down lying on the ground at the free spot nearest ``near`` where
        the largest robot of the fleet can stand beside it to pick it up again, and let go."""
        from bimrobot.physics.placement import lying_pose

        site = self.site
        spot, yaw = self._free_spot(robot, gid, np.asarray(near, float))
        size = self._size_of(gid)
        half = (np.abs(lying_pose(size, (0, 0, 0), yaw)[:3, :3]) @ np.array(site.components[gid].size) / 2)[:2]
        site.approach(robot, spot, low_keep_out=[(spot, half)])
        tcp = site.tcp_pose(robot)
        grip = site.held_in_tcp(robot)
        best = None
        for turn in (0.0, math.pi):  # the box is the same turned half a turn: the smaller wrist turn
            body = lying_pose(size, (spot[0], spot[1], site.ground_z + size[0] / 2 + 0.002), yaw + turn)
            goal = body @ np.linalg.inv(grip)
            change = abs(math.remainder(math.atan2(goal[1, 0], goal[0, 0]) - math.atan2(tcp[1, 0], tcp[0, 0]), 2 * math.pi))
            if best is None or change < best[0]:
                best = (change, goal)
        site.move_tcp_through(robot, self._carry_waypoints(robot, gid, best[1]))
        self._release(robot)
        return spot

    def _free_spot(self, robot: str, gid: str, near: np.ndarray) -> tuple[np.ndarray, float]:
        """(centre xy, yaw) of a spot on the ground for the component lying (0.3 m clear of every
        obstacle and of every other robot as it stands: a component let go on an arm at work would
        push it away) beside which the largest robot of the fleet finds a free stand within reach;
        the nearest to ``near`` of rings 1 m apart."""
        from bimrobot.physics.site import Blocked

        site = self.site
        length, width, _ = site.components[gid].size
        big = max(site.robots, key=lambda name: math.hypot(*site.robots[name].model.footprint))
        model = site.robots[big].model
        reach = site.working_distance(big) + model.arm_mount[0]
        low, tall = site.obstacles(big, split=True)
        tall = tall + [(b.centre[:2], b.half_xy) for b in self.installed.values()]
        others = [site.robot_extent(name) for name in site.robots if name != robot]
        boxes = low + tall + others
        for ring in range(8):
            count = 1 if ring == 0 else 8 * ring
            for k in range(count):
                angle = 2 * math.pi * k / count
                centre = near + ring * np.array([math.cos(angle), math.sin(angle)])
                for yaw in (0.0, math.pi / 2):
                    along = np.array([math.cos(yaw), math.sin(yaw)])
                    half = np.abs(np.array([[along[0], -along[1]], [along[1], along[0]]])) @ np.array([length, width]) / 2
                    if site.near_box(centre, boxes, 0.0) or any(
                            np.all(np.abs(centre - c) < h + half + 0.3) for c, h in boxes):
                        continue
                    across = np.array([-along[1], along[0]])
                    mine = low + [(centre, half)]
                    if any(site.stand_clear(big, centre + side * reach * across, mine, tall) for side in (1, -1)):
                        return centre, yaw
        raise Blocked(f"no free spot near ({near[0]:.2f}, {near[1]:.2f}) to set {gid} down where a robot can reach it")

    def _set_down(self, robot: str, gid: str) -> None:
        site = self.site
        tcp = site.tcp_pose(robot)
        below = tcp.copy()
        grip = site.held_in_tcp(robot)
        below[2, 3] += site.ground_z + 0.002 - (tcp @ grip)[2, 3]
        site.move_arm(robot, site.solve(robot, below), check_contacts=False)
        site.open_gripper(robot)
        site.move_arm(robot, site.ready_posture(robot))
