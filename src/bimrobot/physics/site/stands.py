"""Stands in the MuJoCo site: where a robot's base stands to work on something, chosen before it
moves (a path it can drive, a turn it can make there, and an arm that reaches every tool pose of the
work that follows).

Public: :meth:`~StandSkill.approach`, :meth:`~StandSkill.make_room`, :meth:`~StandSkill.working_distance`.
"""

from __future__ import annotations

import math

import numpy as np

from bimrobot.physics.site.common import (CLEARANCE_M, POSE_PLANS_PER_SEARCH, REACH_PATH_FRACTIONS, Blocked,
                                          MotionFailed)


class StandSkill:
    """Where a base stands to work (see the module docstring)."""

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
                self.footprint_clear(robot, here, facing, boxes, 0.0) and self._reaches(robot, reach, here, facing):
            self.face(robot, point)
            return
        checked = callable(reach) or len(reach) > 0  # (only a stand whose reach is checked may be far)
        candidates = self._stand_candidates(robot, point, distance, boxes, here, checked)
        self._drive_to_a_stand(robot, point, candidates, reach, list(keep_out) + list(low_keep_out))

    def _stand_candidates(self, robot: str, point: np.ndarray, distance: float, boxes, here: np.ndarray,
                          checked: bool) -> list[np.ndarray]:
        """Stands (xy, m) on rings around ``point`` (:meth:`_stand_radii`, the ideal distance first),
        nearest to the base at ``here`` first, whose chassis, facing the point, is clear of ``boxes``
        (the arm, raised, passes over what it works on)."""
        angles = np.linspace(-math.pi, math.pi, 72, endpoint=False)
        candidates = []
        for rank, radius in enumerate(self._stand_radii(robot, distance, checked)):
            for a in angles:
                c = point + radius * np.array([math.cos(a), math.sin(a)])
                if self.footprint_clear(robot, c, math.atan2(point[1] - c[1], point[0] - c[0]), boxes):
                    candidates.append((float(np.linalg.norm(c - here)) + rank * 2.0 * distance, c))
        return [c for _, c in sorted(candidates, key=lambda item: item[0])]

    def _drive_to_a_stand(self, robot: str, point: np.ndarray, candidates: list[np.ndarray], reach,
                          keep_out: list) -> None:
        """Drive to the first of ``candidates`` (stands, xy m) that the robot has a path to, can turn at
        to face ``point``, and from which its arm reaches ``reach`` (see :meth:`approach`; ``keep_out``:
        boxes its chassis keeps clear of at the stand); Blocked when none."""
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
                poses = self.plan_poses(robot, candidate, facing, keep_out=keep_out)
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
            if self.near_box(candidate, boxes, corner):
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
            if self.near_box(end, boxes, corner):
                why = f"the nearest free spot to a pose, ({end[0]:.2f}, {end[1]:.2f}), is within the box"
                continue
            self.drive(robot, candidate, path=path)
            self.turn(robot, math.atan2(target[1] - end[1], target[0] - end[0]))
            return
        # none it can drive to, turning on the way (a robot inside the frame holding a beam sweeps
        # metres when it turns): straight along its heading, out of the box's way
        box = (target, np.asarray(half_xy, float))
        yaw = self.base_xy_yaw(robot)[2]
        if self._straight_to(robot, lambda spot: self.footprint_clear(robot, spot, yaw, [box]), [box]):
            return
        raise Blocked(f"no free stand pose for {robot} around ({target[0]:.2f}, {target[1]:.2f}): {why}")
