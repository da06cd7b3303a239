"""The one time model: how long each construction task takes, in seconds.

Every part that turns work into time uses these functions: the market's bids
(:mod:`bimrobot.coordination.market`), the event simulation and the thesis' step loop
(:mod:`bimrobot.coordination`), and RCAN's ``sim`` backend executing a schedule
(:mod:`bimrobot.rcan.backends.sim`). So a schedule written by ``simulate`` and the same schedule executed
by RCAN take the same time, activity by activity.

========================= ==================================================================================
task                      seconds
========================= ==================================================================================
travel                    horizontal distance (m) / ``speed_m_s``; robots drive straight on the site
transport                 travel to the pick-up + ``load_s`` + travel to the drop-off + ``unload_s``
position                  travel to the component + max(1, connection nodes) x ``per_node_s``
assemble                  travel to the joint or node + assembly points x ``per_point_s``
arm motion                distance (m) / ``arm_speed_m_s``; 0 for a fleet robot (Table 4.1 gives no arm
                          speed: its handling times include the arm's motions)
========================= ==================================================================================

A task whose assembly points are not known (an RCAN experiment, a schedule CSV written by another tool)
counts as one point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class RobotTimes:
    """A robot's speeds and handling times: metres per second and seconds.

    ``arm_speed_m_s`` is ``math.inf`` when the handling times already include the arm's motions (every
    chapter-4 fleet robot). A robot's are :attr:`bimrobot.site.fleet.RobotSpec.times`."""

    speed_m_s: float
    load_s: float = 0.0
    unload_s: float = 0.0
    per_node_s: float = 0.0
    per_point_s: float = 0.0
    arm_speed_m_s: float = math.inf


def travel_s(times: RobotTimes, distance_m: float) -> float:
    """Seconds to drive ``distance_m`` metres (horizontal, straight) at the robot's speed."""
    return float(distance_m) / times.speed_m_s


def arm_s(times: RobotTimes, distance_m: float) -> float:
    """Seconds for the end effector to move ``distance_m`` metres (0 when handling includes it)."""
    return 0.0 if math.isinf(times.arm_speed_m_s) else float(distance_m) / times.arm_speed_m_s


def transport_s(times: RobotTimes, carry_m: float) -> float:
    """Seconds of a transport once the robot is at the pick-up: load, carry ``carry_m`` metres, unload."""
    return times.load_s + travel_s(times, carry_m) + times.unload_s


def position_s(times: RobotTimes, nodes: int) -> float:
    """Seconds to position a component (or one of its nodes) with ``nodes`` connection nodes."""
    return max(1, int(nodes)) * times.per_node_s


def assemble_s(times: RobotTimes, points: int | None) -> float:
    """Seconds to make ``points`` assembly points (bolts, welds); None (not known) counts as one."""
    return (1 if points is None else int(points)) * times.per_point_s
