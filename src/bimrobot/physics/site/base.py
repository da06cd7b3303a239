"""The base of a robot in the MuJoCo site: it drives along planned paths, turns in place, backs out
of tight spots and faces its work, stopping and failing when it touches something new.

Public: :meth:`~BaseSkill.drive`, :meth:`~BaseSkill.turn`, :meth:`~BaseSkill.face`.
"""

from __future__ import annotations

import math

import numpy as np

from bimrobot.physics.site.common import TURN_RATE_RAD_S, Blocked, MotionFailed, PosePath, wrap_angle


class BaseSkill:
    """Driving and turning the base (see the module docstring)."""

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
        turns = np.linalg.norm(first) > 0.02 and abs(wrap_angle(math.atan2(first[1], first[0]) - yaw)) > 0.05
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
            error = np.array([goal[0] - x, goal[1] - y, wrap_angle(goal[2] - yaw)])
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

    def _back_out(self, robot: str) -> bool:
        """When the robot's base stands too near something taller than its chassis to turn in place
        (it has just worked beside it, or carried a component there), drive it straight, backwards or
        forwards along its heading, to the nearest spot (up to 4 m) where it may turn, its chassis
        clear of everything on the way (a component it holds passes through other components).
        Whether it moved."""
        low, tall = self.obstacles(robot, split=True)
        if self.stand_clear(robot, self.base_xy_yaw(robot)[:2], low, tall):
            return False
        return self._straight_to(robot, lambda spot: self.stand_clear(robot, spot, low, tall))

    def _straight_to(self, robot: str, good, boxes=()) -> bool:
        """Drive straight, backwards or forwards along the heading, to the nearest spot (up to 4 m)
        where ``good(spot)`` holds, the chassis clear of every obstacle (and of ``boxes``) on the way,
        without turning. Whether it found one and moved."""
        x, y, yaw = self.base_xy_yaw(robot)
        here = np.array([x, y])
        heading = np.array([math.cos(yaw), math.sin(yaw)])
        # what the chassis' footprint overlaps already is left to the contact check while it moves
        boxes = [box for box in self.obstacles(robot) + list(boxes) if self.footprint_clear(robot, here, yaw, [box], 0.0)]
        for distance in np.arange(0.1, 4.01, 0.1):
            for sign in (-1.0, 1.0):
                spot = here + sign * distance * heading
                way = [here + sign * t * heading for t in np.arange(0.1, distance + 1e-9, 0.1)]
                # on the way, not touching (it may have worked within the clearance of something)
                if good(spot) and all(self.footprint_clear(robot, p, yaw, boxes, 0.0) for p in way):
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
        short = wrap_angle(to_yaw - from_yaw)
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
            error = wrap_angle(yaw - self.base_xy_yaw(robot)[2])
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
            turn = np.clip(3.0 * wrap_angle(heading - yaw), -TURN_RATE_RAD_S, TURN_RATE_RAD_S)
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
        if not self.stand_clear(robot, here, low, tall):
            away = here - offset / max(np.linalg.norm(offset), 1e-9) * 0.8 * model.footprint[0]
            self.drive(robot, away)
            self.turn(robot, yaw)
            self._straight(robot, here)  # facing the target now: forward to where it stood
        self.turn(robot, yaw)
