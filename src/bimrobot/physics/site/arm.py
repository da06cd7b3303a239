"""The arm of a robot in the MuJoCo site: inverse kinematics with seeds of several families, joint-space
moves (through a clear via posture, or along an OMPL path, around what the straight way would touch),
Cartesian steps for a held member, and the postures it rests, drives and carries in.

Public: :meth:`~ArmSkill.solve`, :meth:`~ArmSkill.move_arm`, :meth:`~ArmSkill.move_tcp_through`,
:meth:`~ArmSkill.plan_arm`, :meth:`~ArmSkill.path_contacts`, :meth:`~ArmSkill.stow_arm`,
:meth:`~ArmSkill.ready_posture`, :meth:`~ArmSkill.stowed_posture`, :meth:`~ArmSkill.carry_posture`,
:meth:`~ArmSkill.tcp_path`, :meth:`~ArmSkill.moved_to`, :meth:`~ArmSkill.tcp_position_at`,
:meth:`~ArmSkill.tcp_pose_at`, :meth:`~ArmSkill.commanded_tcp_pose`. Joints in rad, poses 4x4 (world, m).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from bimrobot.physics import motion, planning
from bimrobot.physics.robot import JOINT_NAMES
from bimrobot.physics.site.common import (ELBOW_UP_SEEDS, JOINT_SPEED_RAD_S, REACH_SEED, READY_SEED, SETTLE_MAX_S,
                                          TRACKING_TOLERANCE_M, TUCK_POSTURE, MotionFailed)
from bimrobot.physics.site.world import ready_joints


class ArmSkill:
    """Moving the arm (see the module docstring)."""

    def ready_posture(self, robot: str) -> np.ndarray:
        """The robot's ready posture (rad): the tool down above the base's front (the arm's rest and
        carry pose, :func:`~bimrobot.physics.site.world.ready_joints`), solved once per robot."""
        if robot not in self._ready:
            self._ready[robot] = ready_joints(self.robots[robot].model)
        return self._ready[robot]

    def stowed_posture(self, robot: str) -> np.ndarray:
        """The joints (rad) :meth:`stow_arm` moves an empty arm to, its base joint turned the short way."""
        r = self.robots[robot]
        posture = TUCK_POSTURE if r.model.family == "heavy" else self.ready_posture(robot)
        return motion.wrap_near(posture, r.q_ref, np.array([True, True, False, True, True, True]))

    def stow_arm(self, robot: str) -> None:
        """An empty arm to the posture it drives in: tucked (the heavy variant's metres long arm), or
        the ready posture (the UR5); its base joint turned the short way (checked for contacts)."""
        goal = self.stowed_posture(robot)
        if np.abs(goal - self.robots[robot].q_ref).max() > 0.05:
            self.move_arm(robot, goal)

    def solve(self, robot: str, tcp_world: np.ndarray, avoid_contacts: bool = False,
              arm_base: np.ndarray | None = None, stand=None) -> np.ndarray:
        """Joint angles putting the tool centre point at ``tcp_world`` (4x4); MotionFailed when out of
        reach (IK error over tolerance). Of the solutions from several seeds (the current joints, the
        ready posture), the ones whose links stay above the ground (an elbow-down solution of an arm
        on a low base would dig in) and, of those (with ``avoid_contacts``: first those at which the arm
        touches nothing), the nearest to the current joints. ``arm_base``: solve as if the arm's base
        stood there (4x4, world) instead of where it is, its base at ``stand`` ((xy, yaw), for the
        contacts)."""
        r = self.robots[robot]
        arm_base = self.arm_base_pose(robot) if arm_base is None else arm_base
        local = np.linalg.inv(arm_base) @ tcp_world
        full_turn = np.array([True, True, False, True, True, True])
        best, found = None, []
        pan = math.atan2(local[1, 3], local[0, 3])  # elbow-up seeds turned towards the goal
        toward = [np.array([pan, *seed[1:]]) for seed in (READY_SEED, REACH_SEED)]
        # the elbow-up families turned towards the goal come last: mink's differential IK stays in
        # the family of its seed, and a level tool at the shoulder's height is often reached from
        # the first seeds only with the elbow (a metres-long forearm) below the ground
        families = [np.array([pan, lift, elbow, wrist_1, wrist_2, 0.0]) for lift, elbow, wrist_1, wrist_2 in ELBOW_UP_SEEDS]
        for seed in (r.q_ref, self.ready_posture(robot), READY_SEED, *toward, *families):
            q, position_error, angle_error = r.ik.solve(local, seed)
            if best is None or position_error < best[1]:
                best = (q, position_error, angle_error)
            if position_error < motion.IK_POSITION_TOLERANCE_M and angle_error < motion.IK_ANGLE_TOLERANCE_RAD:
                q = motion.wrap_near(q, r.q_ref, full_turn)
                lowest = arm_base[2, 3] + r.ik.lowest_link(q)
                clear = lowest >= self.ground_z + 0.06 * r.model.scale
                change = float(np.abs(q - r.q_ref).max())
                touches = avoid_contacts and clear and bool(self.arm_contacts_at(robot, q, stand=stand))
                found.append((not clear, touches, change, q))
                if clear and not touches and change < 1.5:
                    break
        p = tcp_world[:3, 3]
        if found and not min(found, key=lambda item: item[:3])[0]:
            return min(found, key=lambda item: item[:3])[3]
        if found:
            raise MotionFailed(f"the arm of {robot} reaches ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) only with a link "
                               "in the ground")
        raise MotionFailed(f"({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) is out of reach of the arm of {robot} "
                           f"(inverse kinematics ends {best[1] * 1000:.0f} mm away)")

    def move_arm(self, robot: str, q_goal: np.ndarray, check_contacts: bool = True, onto_seat: bool = False) -> float:
        """Move the arm to ``q_goal`` along a smooth joint-space interpolation at the arm's speed;
        MotionFailed on a collision or when the arm cannot follow (torque limits). When the straight
        joint-space path of an empty arm would touch something (checked on positions beforehand), it goes through
        the first via posture of :meth:`_via_postures` from which both halves are clear. ``onto_seat``:
        the move lowers the held component onto what it rests on; stopped short by that contact, the
        move is done (a guarded move: the component sits on its seat). Returns seconds."""
        if check_contacts and not self.robots[robot].holding:  # a held member is moved in short steps instead
            already = set(self.robot_contacts(robot))
            start = self.robots[robot].q_ref.copy()
            if self.path_contacts(robot, start, q_goal, already):
                for via in self._via_postures(robot, start, q_goal):
                    if not self.path_contacts(robot, start, via, already) and \
                            not self.path_contacts(robot, via, q_goal, already):
                        return self._move_arm(robot, via, True) + self._move_arm(robot, q_goal, True, onto_seat)
                path = self.plan_arm(robot, q_goal)
                if path is not None:
                    seconds = sum(self._move_arm(robot, q, True) for q in path[1:-1])
                    return seconds + self._move_arm(robot, q_goal, True, onto_seat)
        return self._move_arm(robot, q_goal, check_contacts, onto_seat)

    def plan_arm(self, robot: str, q_goal: np.ndarray, iterations: int = planning.ARM_ITERATIONS) -> list[np.ndarray] | None:
        """Joint vectors (rad) from the arm's joints to ``q_goal`` along which the arm keeps 2 cm from
        everything, its links above the ground (OMPL's RRT-Connect in joint space, checked on
        positions every 0.01 rad; see :mod:`bimrobot.physics.planning`). What it is nearer than
        that to at its start it may stay as near to, never nearer. None when none is found within
        ``iterations`` of the planner (a count, not a time)."""
        r = self.robots[robot]
        start = r.q_ref.copy()
        scratch = self.scratch_state()
        arm = self.idx[robot]["q"]
        base_z = self.arm_base_pose(robot)[2, 3]
        ground = self.ground_z + 0.06 * r.model.scale
        probe = self._probe_model(robot, 0.02)
        already = self._contacts_within(robot, probe, scratch, arm, start)

        def valid(q):
            if base_z + r.ik.lowest_link(q) < ground:
                return False
            return self._no_nearer(self._contacts_within(robot, probe, scratch, arm, q), already)

        ranges = self.model.jnt_range[[self.model.joint(f"{robot}/{j}").id for j in JOINT_NAMES]]
        limited = ranges[:, 1] > ranges[:, 0]
        lower = np.where(limited, ranges[:, 0], np.minimum(start, q_goal) - 2 * math.pi)
        upper = np.where(limited, ranges[:, 1], np.maximum(start, q_goal) + 2 * math.pi)
        if not valid(np.asarray(q_goal, float)):
            return None
        return planning.joint_path(valid, start, q_goal, lower, upper, resolution_rad=0.01, iterations=iterations)

    def path_contacts(self, robot: str, q_from: np.ndarray, q_to: np.ndarray, already: set) -> list[str]:
        """What the arm would newly touch on the straight joint-space path (24 samples, positions only)."""
        scratch = self.scratch_state()
        for t in np.linspace(0.0, 1.0, 25)[1:]:
            touching = self.arm_contacts_at(robot, q_from + (q_to - q_from) * t, scratch, already)
            if touching:
                return touching
        return []

    def _via_postures(self, robot: str, q_from: np.ndarray, q_to: np.ndarray) -> list[np.ndarray]:
        """Postures to go through around an obstacle: the ready posture (and, for the heavy variant,
        the tucked one) turned as at the start, as at the goal, and as it is."""
        full_turn = np.array([True, True, False, True, True, True])
        r = self.robots[robot]
        postures = [self.ready_posture(robot)]
        if r.model.family == "heavy":  # only empty arms go round (see move_arm): tucking is allowed
            postures.append(TUCK_POSTURE)
        out = []
        for posture in postures:
            for pan in (q_from[0], q_to[0], posture[0]):
                out.append(motion.wrap_near(np.array([pan, *posture[1:]]), q_from, full_turn))
        return out

    def _move_arm(self, robot: str, q_goal: np.ndarray, check_contacts: bool = True, onto_seat: bool = False) -> float:
        r = self.robots[robot]
        start_q = r.q_ref.copy()
        start_tcp = self.tcp_pose(robot)[:3, 3]
        goal_tcp = self.tcp_position_at(robot, q_goal)
        # a held component is swung at a third of the speed: its inertia (a 4 m member's is hundreds of
        # kg m2) would otherwise need more than the wrists' torque limits to accelerate it
        joint_speed = JOINT_SPEED_RAD_S / (3.0 if r.holding else 1.0)
        seconds = max(float(np.abs(q_goal - start_q).max()) / joint_speed,
                      float(np.linalg.norm(goal_tcp - start_tcp)) / r.arm_speed_m_s, 0.5)
        dt = 0.01
        # what it touches already it may move away from (an arm left against a column by a failed
        # activity could otherwise never move again)
        already = set(self.robot_contacts(robot)) if check_contacts else set()
        before = self.component_poses() if check_contacts else {}
        for reference in motion.smooth_steps(start_q, q_goal, seconds, dt):
            r.q_ref = reference
            self.step(dt)
            if check_contacts:
                touching = self.robot_contacts(robot, besides=already)
                pushed = self.shoved(robot, before)
                if touching or pushed:
                    r.q_ref = self.arm_q(robot)  # stop there: pressing on would push what it touches
                    what = f"collision while moving the arm of {robot}: {'; '.join(touching)}" if touching else \
                        f"the arm of {robot} pushed {'; '.join(pushed)}"
                    raise MotionFailed(what)
        error = self._settle(robot, goal_tcp)
        if error > TRACKING_TOLERANCE_M and not (onto_seat and self.seated(robot)):
            joints = self.saturated(robot)
            why = f"torque limit of {', '.join(joints)}" if joints else "it could not follow"
            raise MotionFailed(f"the arm of {robot} ended {error * 1000:.0f} mm from its goal ({why})")
        return seconds + 0.5

    def _settle(self, robot: str, goal_tcp: np.ndarray) -> float:
        """Wait until the arm is in position (its tcp within TRACKING_TOLERANCE_M of ``goal_tcp``) or
        at rest, for at least 0.5 s and at most SETTLE_MAX_S; returns the tcp's distance to the goal
        (m). An arm holding a member near its torque limits creeps the last millimetres in."""
        self.step(0.5)
        waited = 0.5
        while True:
            error = float(np.linalg.norm(self.tcp_pose(robot)[:3, 3] - goal_tcp))
            moving = float(np.abs(self.data.qvel[self.idx[robot]["v"]]).max()) > 1e-3
            if error <= TRACKING_TOLERANCE_M or not moving or waited >= SETTLE_MAX_S:
                return error
            self.step(0.25)
            waited += 0.25

    def move_tcp_through(self, robot: str, poses: list[np.ndarray], check_contacts: bool = True,
                         onto_seat: bool = False, avoid_contacts: bool = False) -> None:
        """Move the tool centre point through ``poses`` (4x4, world), each reached by inverse kinematics
        and a joint-space move; holding a component, in steps of at most 0.3 m and 30 degrees (one
        joint-space move between two poses lets the tool, and a long member with it, tilt on the way).
        ``onto_seat``: the last pose sets the held component on its seat (see :meth:`move_arm`);
        ``avoid_contacts``: see :meth:`solve`."""
        for goal in poses:
            steps = self._steps(robot, self.tcp_pose(robot), goal)
            for step in steps:
                last = onto_seat and goal is poses[-1] and step is steps[-1]
                self.move_arm(robot, self.solve(robot, step, avoid_contacts), check_contacts=check_contacts, onto_seat=last)

    def _steps(self, robot: str, here: np.ndarray, goal: np.ndarray) -> list[np.ndarray]:
        """The tool poses of a move from ``here`` to ``goal`` (see :meth:`move_tcp_through`)."""
        if not self.robots[robot].holding:
            return [goal]
        angle = motion.angle_between(here[:3, :3], goal[:3, :3])
        count = max(1, math.ceil(max(np.linalg.norm(goal[:3, 3] - here[:3, 3]) / 0.3, angle / math.radians(30))))
        return [motion.between(here, goal, k / count) for k in range(1, count + 1)]

    def tcp_path(self, robot: str, start: np.ndarray, poses: list[np.ndarray]) -> list[np.ndarray]:
        """Every tool pose :meth:`move_tcp_through` goes by from ``start`` through ``poses``."""
        path, here = [], start
        for goal in poses:
            path += self._steps(robot, here, goal)
            here = goal
        return path

    def moved_to(self, robot: str, xy, yaw: float) -> np.ndarray:
        """The rigid motion (4x4, world) that takes the robot as it stands to ``xy`` heading ``yaw``:
        where its tool would be, carried along, is this @ the tool's pose now."""
        x, y, now = self.base_xy_yaw(robot)
        return motion.planar(xy[0], xy[1], yaw) @ np.linalg.inv(motion.planar(x, y, now))

    def carry_posture(self, robot: str) -> np.ndarray:
        """Arm joints of the carry posture: the tool down over the base's front (the ready posture),
        turned so that a held component's longest side runs across the base (a long member then
        sticks out to the sides, clear of the chassis when set down in front)."""
        r = self.robots[robot]
        ready = self.ready_posture(robot)
        if not r.holding:
            return ready
        s = r.model.scale
        long_axis = r.grip[:3, 0]  # the component's x (its longest side), in the gripper frame
        axis = motion.tool_down(0.0) @ long_axis  # in the arm base frame, with the tool at yaw 0
        turn = math.atan2(axis[1], axis[0])
        best = None
        # seeded from the joints as they are too: seeded only from the ready posture, the solution may
        # be the same tool pose with the wrist flipped, and the move there swings the held member
        # half a turn about the wrists
        for across, seed in itertools.product((math.pi / 2, -math.pi / 2), (r.q_ref, ready)):
            tool = motion.tool_down(across - turn)
            q, position_error, angle_error = r.ik.solve(motion.pose(tool, (0.35 * s, 0.0, 0.45 * s)), seed)
            if position_error < motion.IK_POSITION_TOLERANCE_M and angle_error < motion.IK_ANGLE_TOLERANCE_RAD:
                q = motion.wrap_near(q, r.q_ref, np.array([True, True, False, True, True, True]))
                cost = float(np.abs(q - r.q_ref).max())
                if best is None or cost < best[1]:
                    best = (q, cost)
        return ready if best is None else best[0]

    def tcp_position_at(self, robot: str, q: np.ndarray) -> np.ndarray:
        """World position of the tcp for arm joints ``q`` with the base where it is (forward kinematics)."""
        return self.tcp_pose_at(robot, q)[:3, 3]

    def commanded_tcp_pose(self, robot: str) -> np.ndarray:
        """The tool centre point's pose (4x4, world) at the arm's commanded joints, the base where it is:
        where the arm settles. An arm holding a long member lags and sags centimetres behind its
        command for a while; a reach checked from where its tool is at that moment did not hold once
        it had settled (a 3.2 m beam, 30 mm at the edge of a 4 m arm's reach)."""
        return self.tcp_pose_at(robot, self.robots[robot].q_ref)

    def tcp_pose_at(self, robot: str, q: np.ndarray) -> np.ndarray:
        """The tcp's pose (4x4, world) for arm joints ``q`` with the base where it is (forward kinematics)."""
        ik = self.robots[robot].ik
        data = self.mj.MjData(ik.model)
        data.qpos[:6] = q
        self.mj.mj_kinematics(ik.model, data)
        tcp = data.site("tcp")
        return self.arm_base_pose(robot) @ motion.pose(tcp.xmat.reshape(3, 3).copy(), tcp.xpos.copy())
