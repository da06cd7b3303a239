"""Paths of a robot's base in the MuJoCo site: on an occupancy grid (A*, then straightened), or in
the plane with its whole body (OMPL, Reeds-Shepp curves) where the grid finds no way.

Both are bounded by counts (the grid's size; the planner's iterations), never by time: the same
scene gives the same path on a busy machine.

Public: :meth:`~PathSkill.plan_path`, :meth:`~PathSkill.plan_poses`.
"""

from __future__ import annotations

import math

import numpy as np

from bimrobot.physics import motion, planning
from bimrobot.physics.site.common import CLEARANCE_M, GRID_M, TURNING_RADIUS_M, Blocked, PosePath, wrap_angle


class PathSkill:
    """Paths for the base (see the module docstring)."""

    def plan_path(self, robot: str, goal_xy) -> list[np.ndarray]:
        """Waypoints (xy, m) from the base to ``goal_xy`` on an occupancy grid of :data:`GRID_M` cells
        whose obstacles are grown by half the base's width plus :data:`CLEARANCE_M` (A* search by
        pyastar2d, then straightened; grown by half the base's diagonal, so that it may turn anywhere
        on the path). The grid covers the start, the goal and every obstacle with
        3 m around them. A base that stands within the grown obstacles (it has just worked beside
        one) may leave them: cells within that distance of it count free, unless the chassis would
        touch an obstacle there (obstacles grown by half the chassis' width and the clearance). A goal within the grown obstacles is replaced by the nearest free
        cell (the goal of *move to component* is a stand-off point, and the next activity finds its
        own stand). MotionFailed when no path exists."""
        model = self.robots[robot].model
        start = self.base_xy_yaw(robot)[:2]
        goal = np.asarray(goal_xy, float)
        low, tall = self.obstacles(robot, split=True)
        boxes = low + tall
        # the robot turns in place at each waypoint: it needs its sweep radius all around (its chassis'
        # half diagonal for what is lower than the chassis)
        radius = self.sweep_radius(robot) + CLEARANCE_M
        radii = [math.hypot(*model.footprint) / 2 + CLEARANCE_M] * len(low) + [radius] * len(tall)
        blocked = lambda p: not self.stand_clear(robot, p, low, tall)  # noqa: E731
        if not boxes or (not blocked(goal) and not _line_blocked(start, goal, blocked)):
            return [goal]
        corners = [start, goal] + [c - h for c, h in boxes] + [c + h for c, h in boxes]
        lower = np.min(corners, axis=0) - 3.0
        upper = np.max(corners, axis=0) + 3.0
        shape = tuple(np.ceil((upper - lower) / GRID_M).astype(int) + 1)
        xs = lower[0] + GRID_M * np.arange(shape[0])
        ys = lower[1] + GRID_M * np.arange(shape[1])
        occupied = np.zeros(shape, bool)
        solid = np.zeros(shape, bool)
        yaw = self.base_xy_yaw(robot)[2]
        for (centre, half), grown in zip(boxes, radii):  # cells whose centre lies within radius of the box
            gap = np.hypot(np.maximum(np.abs(xs[:, None] - centre[0]) - half[0], 0),
                           np.maximum(np.abs(ys[None, :] - centre[1]) - half[1], 0))
            occupied |= gap < grown
            # where the chassis, driving out straight, would touch it: never free, not even near the
            # start; unless the chassis stands over it already (a low support put under it): then
            # the contact check judges while it drives off
            if self.footprint_clear(robot, start, yaw, [(centre, half)], 0.0):
                solid |= gap < model.footprint[1] / 2 + CLEARANCE_M
        grown = occupied.copy()
        near_start = np.hypot(xs[:, None] - start[0], ys[None, :] - start[1]) < radius
        occupied &= ~(near_start & ~solid)
        cell = lambda p: tuple(np.round((np.asarray(p) - lower) / GRID_M).astype(int))  # noqa: E731
        if grown[cell(goal)]:  # (a goal in the start's escape zone is no place to stop either)
            free = np.argwhere(~grown)
            nearest = free[np.argmin(np.hypot(*(lower[:, None] + GRID_M * free.T - goal[:, None])))]
            goal = lower + GRID_M * nearest
        cells = motion.grid_path(occupied, cell(start), cell(goal))
        if cells is None:
            raise Blocked(f"no collision-free path for {robot} from ({start[0]:.2f}, {start[1]:.2f}) to "
                               f"({goal[0]:.2f}, {goal[1]:.2f})")
        points = lower + cells * GRID_M
        points[0], points[-1] = start, goal
        # straightened through free cells only (the start's own neighbourhood may be grown-occupied)
        free_at = lambda p: occupied[tuple(np.clip(cell(p), 0, np.array(shape) - 1))]  # noqa: E731
        # (start and goal in one cell: the goal alone, as for a straight way)
        return motion.simplify(points, free_at, GRID_M / 2)[1:] or [goal]

    def plan_poses(self, robot: str, goal_xy, goal_yaw: float | None = None, keep_out=(),
                   iterations: int = planning.BASE_ITERATIONS) -> PosePath | None:
        """A path in the plane (OMPL, Reeds-Shepp curves: forward and backward, see
        :mod:`bimrobot.physics.planning`) to ``goal_xy`` heading ``goal_yaw`` (any of eight headings
        when None), checked on the MuJoCo scene with the robot's whole body as it drives (chassis and
        arm in :meth:`driving_posture`) keeping :data:`CLEARANCE_M` from everything; at the goal its
        chassis is clear of ``keep_out`` boxes too (centre xy, half xy: about to appear, not there
        to touch on the way). What it is nearer than that to at its start it may stay as near to,
        never nearer (it has just worked beside it). For where the
        grid planner, which lets the robot turn anywhere, finds no way: a robot holding a beam
        between columns sweeps metres when it turns. None when no path is found within ``iterations``
        of the planner per heading (a count, not a time: the same answer on a busy machine)."""
        x, y, yaw = self.base_xy_yaw(robot)
        start = np.array([x, y, yaw])
        valid = self._pose_check(robot, start)
        keep_out = [(np.asarray(c, float), np.asarray(h, float)) for c, h in keep_out]
        goal_xy = np.asarray(goal_xy, float)
        boxes = self.obstacles(robot) + keep_out
        corners = [start[:2], goal_xy] + [c - h for c, h in boxes] + [c + h for c, h in boxes]
        lower, upper = np.min(corners, axis=0) - 3.0, np.max(corners, axis=0) + 3.0
        # checked where the robot's farthest point (its sweep radius out) has moved 2 cm
        resolution = 0.02 * TURNING_RADIUS_M / (self.sweep_radius(robot) + TURNING_RADIUS_M)
        headings = [goal_yaw] if goal_yaw is not None else \
            sorted(np.linspace(-math.pi, math.pi, 8, endpoint=False), key=lambda h: abs(wrap_angle(h - yaw)))
        for heading in headings:
            goal = np.array([*goal_xy, heading])
            if not valid(*goal) or not self.footprint_clear(robot, goal[:2], heading, keep_out):
                continue
            poses = planning.base_path(valid, start, goal, lower, upper, TURNING_RADIUS_M, resolution, iterations)
            if poses is not None:
                return PosePath(poses)
        return None

    def _pose_check(self, robot: str, start: np.ndarray):
        """valid(x, y, yaw) for :meth:`plan_poses` (positions only, on a scratch copy of the state)."""
        probe = self._probe_model(robot, CLEARANCE_M)
        scratch = self.scratch_state()
        scratch.qpos[self.idx[robot]["q"]] = self.driving_posture(robot)
        base = self.idx[robot]["base_q"]
        already = self._contacts_within(robot, probe, scratch, base, start)

        def valid(x, y, yaw):
            return self._no_nearer(self._contacts_within(robot, probe, scratch, base, (x, y, yaw)), already)

        return valid


def _line_blocked(a, b, blocked) -> bool:
    """Whether the straight line from ``a`` to ``b`` (xy, m) passes a point where ``blocked(point)``."""
    return not motion._line_free(np.asarray(a, float), np.asarray(b, float), blocked, GRID_M / 2)
