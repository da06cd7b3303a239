"""The ``mujoco`` backend's *position for installing* feature: the held component is carried onto its
seat (turned low, raised turned, over and down onto the support that appears under it), or the tool
goes to its work point on a component in place (a further connection)."""

from __future__ import annotations

import math

import numpy as np

from bimrobot.rcan.backends.mujoco.common import LIFT_M, SUPPORT_MIN_Z_M
from bimrobot.rcan.backends import features
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.node import RcanNode


class PositionForInstalling(features.PositionForInstalling):
    """The *position for installing* feature (see the module docstring)."""

    def position_for_installing(self, node: RcanNode, attempt: int = 1, ready_at_s: float = 0.0,
                                feedback=None) -> ActivityResult:
        """*Position for installing* in the one physical world, in its turn: the work of :meth:`_position_for_installing`
        (:meth:`MujocoBackend.act`)."""
        return self.act(node, attempt, ready_at_s, feedback, self._position_for_installing)

    def _position_for_installing(self, node: RcanNode) -> str:
        from bimrobot.physics.site import Blocked, MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if gid in self.shapes:
            return self._position_for_installing_as_given(node)
        if gid not in site.components:
            if node.activity.lifts:
                raise MotionFailed(f"{gid} is not in the scene: it was never picked up")
            self._spawn_in_place(node.activity)  # in place already (a footing): it enters the scene where it is installed
        if site.robots[robot].holding != gid:  # work on a component in place (a further connection)
            # a stand from which the arm reaches its work touching nothing on the way (a stand taken
            # unchecked, beside another robot, had the gripper meet the next member at the joint);
            # when the check finds none, the nearest free stand, unchecked (the check is strict: the
            # work point moves with the stand, and the move may still go another way round)
            def work_from(xy, yaw):
                return self._clear_work_poses(robot, gid, (np.asarray(xy, float), float(yaw)))

            wrist = self._wrist_point(robot, self._work_poses(robot, gid)[-1])
            try:
                site.approach(robot, wrist, reach=work_from)
            except Blocked:
                site.approach(robot, wrist)
            site.move_tcp_through(robot, self._clear_work_poses(robot, gid), avoid_contacts=True)
            return f"{node.kind.label} {gid}: gripper at its work point"
        box = self._installed_box(node.activity)
        self._check_support_place(gid, box, robot)
        if np.abs(site.arm_q(robot) - site.carry_posture(robot)).max() > 0.05:
            self._to_carry(robot)  # it may drive and turn to its stand now
        # stand where the arm's wrist (behind the tool centre point, along the tool) works comfortably
        # its installed turn about its axis is chosen once, here: the stands are sought around the
        # wrist point it gives, and checked with it (chosen again at the stand, it differed, and
        # columns failed 125-148 mm out of reach on the way)
        target, goal = self._install_pose(robot, gid, box)
        def path_from(xy, yaw):  # every tool pose of the move onto the seat, the robot at that stand
            tcp = site.moved_to(robot, xy, yaw) @ site.commanded_tcp_pose(robot)
            return site.tcp_path(robot, tcp, self._carry_waypoints(robot, gid, goal, tcp))

        site.approach(robot, self._wrist_point(robot, goal), keep_out=[(box.centre[:2], box.half_xy)], reach=path_from)
        goal = self._tcp_goal(robot, target)  # as it is held now
        # (from where the arm settles, as the stand's reach was checked)
        waypoints = self._carry_waypoints(robot, gid, goal, site.commanded_tcp_pose(robot))
        # (to the arm solutions touching nothing, as the stand's reach was checked)
        site.move_tcp_through(robot, waypoints[:-1], avoid_contacts=True)
        # its seat appears once it is held above it: carried low at the robot's front, a beam is
        # where its prop stands, and the prop appeared around the arm holding it
        self._support_for(gid, box, robot)
        site.move_tcp_through(robot, waypoints[-1:], onto_seat=True, avoid_contacts=True)
        self.targets[gid], self.installed[gid] = target, box
        again = self._seat_at_place(robot, gid)
        if node.activity.releases_robot:  # PositionFixed: let go, the assembly robots fix it
            self._release(robot)
        return f"{node.kind.label} {gid}: at its target ({box.kind}){self._set_down_again(again)}"

    def _position_for_installing_as_given(self, node: RcanNode) -> str:
        """The thesis' experiments: the component's shape is given and it stands upright on its target."""
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if gid not in site.components:
            raise MotionFailed(f"{gid} is not in the scene: it was never picked up")
        shape = site.components[gid].size
        target = self._placement(node, shape)
        site.make_room(robot, target[:2, 3], self._support_half(shape))
        if abs(target[2, 3] - site.ground_z) > SUPPORT_MIN_Z_M and not self._support_at(target):
            if target[2, 3] < site.ground_z:
                site.add_pit(target[:2, 3], self._support_half(shape))
            self._add_support(gid, target, "support")
        site.face(robot, target[:2, 3])
        holding = site.robots[robot].holding == gid
        if holding:  # the tcp goes where the component's origin lands on the target, as gripped
            grip = site.held_in_tcp(robot)
            goal = target @ np.linalg.inv(grip)
            goal[2, 3] += 0.001  # released 1 mm above its seat
        else:  # work on a component in place (a further connection): reach its grasp pose
            goal = site.grasp_pose(gid)
        site.move_tcp_through(robot, [self._above(goal), goal])
        self.targets[gid] = target
        if holding and node.activity.releases_robot:
            self._release(robot)
        return f"{node.kind.label} {gid}: at its target"

    def _install_pose(self, robot: str, gid: str, box) -> tuple[np.ndarray, np.ndarray]:
        """(component pose, tcp goal) on ``box``: of the rotations that fit the box, the one whose tool
        points down, else away from the robot (its side towards the robot is where it is held)."""
        from bimrobot.physics.placement import body_pose, body_rotations

        site = self.site
        grip = site.held_in_tcp(robot)
        arm = site.arm_base_pose(robot)[:2, 3]
        toward = box.centre[:2] - arm
        toward /= max(float(np.linalg.norm(toward)), 1e-9)
        size = self._size_of(gid)
        best = None
        for rotation in body_rotations(size, box):
            target = body_pose(size, box, rotation)
            goal = target @ np.linalg.inv(grip)
            tool = goal[:3, 2]
            score = 2.0 * -tool[2] + float(tool[:2] @ toward)
            if best is None or score > best[0]:
                best = (score, target, goal)
        return best[1], self._tcp_goal(robot, best[1])

    def _tcp_goal(self, robot: str, target: np.ndarray) -> np.ndarray:
        """The tool pose (4x4, world) that puts the held component at ``target``, as it is held now,
        1 mm above its seat (where it is released)."""
        goal = target @ np.linalg.inv(self.site.held_in_tcp(robot))
        goal[2, 3] += 0.001
        return goal

    def _wrist_point(self, robot: str, goal: np.ndarray) -> np.ndarray:
        """Where the arm's wrist is (xy, m) when its tool centre point is at ``goal``."""
        from bimrobot.physics.robot import GRIPPER_LENGTH_M

        model = self.families[robot]
        return (goal[:3, 3] - goal[:3, 2] * (model.dh[5][1] + GRIPPER_LENGTH_M * model.scale))[:2]

    def _carry_waypoints(self, robot: str, gid: str, goal: np.ndarray, tcp: np.ndarray | None = None) -> list[np.ndarray]:
        """Tool poses from where the held component is (the tool at ``tcp``, default where it is) to
        ``goal``: up to a height where it can turn
        to its installed orientation clear of the ground, turn, up to the goal's height (and
        :data:`LIFT_M`), over the goal, down onto it. It turns low and rises turned: a beam held from
        above rolls onto its side, and the tool, then level, keeps the wrist at the tool's height (held
        tool-down at a beam's height, the wrist would be a metre above the tool, beyond the arm)."""
        site = self.site
        tcp = site.tcp_pose(robot) if tcp is None else tcp
        grip = site.held_in_tcp(robot)
        corners = _corners(site.components[gid].size)

        def lowest_below_tcp(pose: np.ndarray) -> float:
            return float(((pose @ grip) @ corners.T)[2].min() - pose[2, 3])

        clear = site.ground_z + 0.2
        low = max(tcp[2, 3], clear - lowest_below_tcp(goal), clear - lowest_below_tcp(tcp))
        safe = max(low, goal[2, 3] + LIFT_M)
        up = tcp.copy()
        up[2, 3] = low
        turned = goal.copy()
        turned[:3, 3] = up[:3, 3]
        raised = turned.copy()
        raised[2, 3] = safe
        over = goal.copy()
        over[2, 3] = safe
        above = self._above(goal)
        waypoints = []
        for pose in (up, turned, raised, over, above, goal):
            last = waypoints[-1] if waypoints else tcp
            if np.linalg.norm(pose[:3, 3] - last[:3, 3]) > 1e-3 or np.abs(pose[:3, :3] - last[:3, :3]).max() > 1e-3:
                waypoints.append(pose)
        return waypoints

    def _clear_work_poses(self, robot: str, gid: str, stand=None) -> list[np.ndarray]:
        """The work poses (:meth:`_work_poses`) turned about the tool's axis by the first multiple of
        45 degrees at which the arm reaches both without touching anything (a 4 m arm's wrist is
        half a metre wide: turned one way it lies against the column standing on the footing it
        works on); the unturned ones when no turn is clear (the move then fails saying what it hit).
        ``stand``: (xy, yaw) of the base to find them for (m, rad), instead of where it stands."""
        from bimrobot.physics import motion
        from bimrobot.physics.site import MotionFailed

        site = self.site
        arm_base = None if stand is None else site.moved_to(robot, *stand) @ site.arm_base_pose(robot)
        poses = self._work_poses(robot, gid, arm_base)
        for k in (0, 1, -1, 2, -2, 3, -3, 4):
            turned = [pose @ motion.planar(0.0, 0.0, k * math.pi / 4) for pose in poses]  # about the tool's z
            try:
                if not any(site.arm_contacts_at(robot, site.solve(robot, pose, True, arm_base, stand), stand=stand)
                           for pose in turned):
                    return turned
            except MotionFailed:
                if stand is not None:  # out of reach there: a turn about the tool's axis will not reach
                    return poses  # either (a stand is checked for many stands: each try costs ~20 IK solves)
                continue
        return poses

    def _work_poses(self, robot: str, gid: str, arm_base: np.ndarray | None = None) -> list[np.ndarray]:
        """Where the tool works on a component in place (its connection nodes are not in the plan): at
        the point of its surface nearest the arm's shoulder, 5 cm off it, the tool pointing at it (down
        onto a top face, level onto a side of a tall one), and 0.10 m back from there first.
        ``arm_base``: the arm's base (4x4, world) to find them for, instead of where it is."""
        from bimrobot.physics import motion

        site = self.site
        arm_base = site.arm_base_pose(robot) if arm_base is None else arm_base
        pose = site.body_pose(gid)
        world = (pose @ _corners(site.components[gid].size).T)[:3].T
        low, high = world.min(axis=0), world.max(axis=0)
        model = self.families[robot]
        shoulder = arm_base[:3, 3] + np.array([0.0, 0.0, model.dh[0][1]])
        point = np.clip(shoulder, low + 0.05, np.maximum(high - 0.05, low + 0.05))
        if shoulder[2] >= high[2]:  # onto its top face
            yaw = math.atan2(point[1] - shoulder[1], point[0] - shoulder[0])
            goal = motion.pose(motion.tool_down(yaw), (point[0], point[1], high[2] + 0.05))
        else:  # level onto the side facing the arm
            side = np.clip(shoulder[:2], low[:2], high[:2])
            toward = side - shoulder[:2]
            toward = toward / max(float(np.linalg.norm(toward)), 1e-9)
            z_axis = np.array([toward[0], toward[1], 0.0])
            x_axis = np.array([0.0, 0.0, -1.0])
            goal = motion.pose(np.column_stack([x_axis, np.cross(z_axis, x_axis), z_axis]),
                               (side[0] - 0.05 * toward[0], side[1] - 0.05 * toward[1], point[2]))
        back = goal.copy()
        back[:3, 3] -= goal[:3, 2] * LIFT_M
        return [back, goal]


def _corners(size) -> np.ndarray:
    """The 8 corners of a component's box (x, y, z sizes in m) in its own frame, homogeneous (8 x 4): centred
    in x and y, from its base (z = 0) to its top, as the site places components."""
    sx, sy, sz = size
    return np.array([[x, y, z, 1.0] for x in (-sx / 2, sx / 2) for y in (-sy / 2, sy / 2) for z in (0.0, sz)])
