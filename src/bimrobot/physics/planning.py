"""Sampling-based motion planning with OMPL (the Open Motion Planning Library, ``ompl`` on PyPI).

Two searches, both RRT-Connect followed by OMPL's path simplifier (run to its end, not for a time), around whatever the caller's
``valid`` function says the robot would touch (the site checks a pose against the MuJoCo scene):

- :func:`joint_path`: an arm's path in joint space (rad), from its joints to a goal posture.
- :func:`base_path`: a wheeled base's path in the plane, poses (x, y, yaw; m, m, rad; world frame,
  z up), as Reeds-Shepp curves of a small turning radius: forward and backward arcs and straights,
  which a skid-steer or differential-drive base can follow; the robot's whole body (chassis, arm
  as it is held while driving) counts, not a circle around it, so a robot holding a long member can
  get out of a tight spot by driving along its heading.

Each returns ``None`` when it finds no path within its budget of planner iterations (a count, never
seconds: :data:`BASE_ITERATIONS`, :data:`ARM_ITERATIONS`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

SEED = 20261124

#: Iterations of RRT-Connect's loop a base path may take. One iteration extends both trees as far as
#: they go, checking the whole robot every 2 cm of the way: 20 to 100 ms on the test machine, so 50 is
#: about the 1 s wall-clock budget this replaced; the paths the tests find take 1 to 8.
BASE_ITERATIONS = 50
#: Iterations an arm's joint-space path may take (the replaced budget was 2 s).
ARM_ITERATIONS = 100


def _ompl():
    """OMPL's modules, quiet."""
    import ompl.base as ob
    import ompl.geometric as og
    import ompl.util as ou

    ou.setLogLevel(ou.LogLevel.LOG_ERROR)
    return ob, og


def _seed() -> None:
    """Seed OMPL's generator of seeds again, so that the random generators of the planner about to be
    made (and its samplers) draw the same numbers whatever was planned before in the process: a plan
    depends on its inputs only, not on the order of plans (OMPL logs an error that seeds were drawn
    already, which is the point here: silenced)."""
    import ompl.util as ou

    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    ou.RNG.setSeed(SEED)
    ou.setLogLevel(ou.LogLevel.LOG_ERROR)


def _solve(setup, og, iterations: int) -> bool:
    """RRT-Connect, stopped at its first exact solution or after ``iterations`` turns of its loop (then
    False), whose path is then simplified as far as OMPL's simplifier goes. Both are bounded by counts,
    not by time, and the generators are seeded (:func:`_seed`): a plan depends on its inputs only, not
    on how busy the machine is (a planner with a wall-clock budget found a corridor's way out when run
    alone and not under load), and a replay reaches the same state."""
    import ompl.base as ob

    _seed()
    setup.setPlanner(og.RRTConnect(setup.getSpaceInformation()))
    turns = 0

    def spent() -> bool:
        nonlocal turns
        turns += 1
        return turns > iterations

    solved = setup.solve(ob.PlannerTerminationCondition(spent))
    if not solved or not setup.haveExactSolutionPath():
        return False
    setup.getPathSimplifier().simplifyMax(setup.getSolutionPath())
    return True


def joint_path(valid: Callable[[np.ndarray], bool], start: Sequence[float], goal: Sequence[float],
               lower: Sequence[float], upper: Sequence[float], resolution_rad: float = 0.01,
               iterations: int = ARM_ITERATIONS) -> list[np.ndarray] | None:
    """Joint vectors (rad) from ``start`` to ``goal`` (both included), every straight joint-space
    segment between them valid when checked every ``resolution_rad`` (the largest joint step
    between checks); ``lower``/``upper``: joint limits (rad)."""
    ob, og = _ompl()
    n = len(start)
    space = ob.RealVectorStateSpace(n)
    bounds = ob.RealVectorBounds(n)
    for i in range(n):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)
    setup.setStateValidityChecker(lambda state: bool(valid(np.array([state[i] for i in range(n)]))))
    setup.getSpaceInformation().setStateValidityCheckingResolution(resolution_rad / space.getMaximumExtent())
    a, b = space.allocState(), space.allocState()
    for i in range(n):
        a[i], b[i] = float(start[i]), float(goal[i])
    setup.setStartAndGoalStates(a, b)
    if not _solve(setup, og, iterations):
        return None
    path = setup.getSolutionPath()
    return [np.array([path.getState(k)[i] for i in range(n)]) for k in range(path.getStateCount())]


def base_path(valid: Callable[[float, float, float], bool], start: Sequence[float], goal: Sequence[float],
              lower_xy: Sequence[float], upper_xy: Sequence[float], turning_radius_m: float = 0.1,
              resolution_m: float = 0.02, iterations: int = BASE_ITERATIONS) -> list[np.ndarray] | None:
    """Poses (x, y, yaw; m, rad) from ``start`` to ``goal``, both (x, y, yaw), every ``resolution_m``
    of the way valid, on Reeds-Shepp curves of ``turning_radius_m`` within the box ``lower_xy`` -
    ``upper_xy``; densely sampled (about every 2 cm of travel) so that a controller can track it."""
    ob, og = _ompl()
    space = ob.ReedsSheppStateSpace(turning_radius_m)
    bounds = ob.RealVectorBounds(2)
    for i in range(2):
        bounds.setLow(i, float(lower_xy[i]))
        bounds.setHigh(i, float(upper_xy[i]))
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)
    setup.setStateValidityChecker(lambda state: bool(valid(state.getX(), state.getY(), state.getYaw())))
    setup.getSpaceInformation().setStateValidityCheckingResolution(resolution_m / space.getMaximumExtent())
    ends = []
    for x, y, yaw in (start, goal):
        state = space.allocState()
        state.setX(float(x))
        state.setY(float(y))
        state.setYaw(math.remainder(float(yaw), 2 * math.pi))
        space.enforceBounds(state)
        ends.append(state)
    setup.setStartAndGoalStates(ends[0], ends[1])
    if not _solve(setup, og, iterations):
        return None
    path = setup.getSolutionPath()
    path.interpolate(max(2, int(math.ceil(path.length() / 0.02)) + 1))
    poses = [np.array([s.getX(), s.getY(), s.getYaw()]) for s in (path.getState(k) for k in range(path.getStateCount()))]
    poses[-1] = np.array([goal[0], goal[1], math.remainder(float(goal[2]), 2 * math.pi)])
    return poses
