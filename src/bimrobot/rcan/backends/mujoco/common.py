"""What the ``mujoco`` backend's features share: their tolerances and distances, and the arm's moves
away from a work point (:class:`ArmWork`).

Every feature mixin here works on the backend's state: ``site`` (the
:class:`~bimrobot.physics.site.MujocoSite`), ``shapes``, ``families`` (robot -> RobotModel),
``capabilities``, ``targets``, ``installed``, ``placements``, ``at_work``; it uses the site's public
methods only. Metres, kg, seconds, degrees where named so; poses 4x4 (world, z up).
"""

from __future__ import annotations

import numpy as np

POSITION_TOLERANCE_M = 0.010
ANGLE_TOLERANCE_DEG = 1.0
SETTLE_S = 2.0
LIFT_M = 0.10
RESEAT_TRIES = 2  # a held component seated off its place is lifted and set down again at most this often
RESEAT_LIFT_M = 0.02
SUPPORT_MIN_Z_M = 0.01
MAKE_WAY_M = 8.0  # idle robots this near a blocked robot or its target drive back to their start


class ArmWork:
    """Moves of the arm every feature uses (see the module docstring)."""

    @staticmethod
    def _above(pose: np.ndarray) -> np.ndarray:
        """``pose`` (4x4, world) raised by LIFT_M: where the tool comes down from onto a grasp."""
        above = pose.copy()
        above[2, 3] += LIFT_M
        return above

    def _release(self, robot: str) -> None:
        """Let go of the held component and take the arm back from it (:meth:`_retreat`)."""
        self.site.open_gripper(robot)
        self._retreat(robot)

    def _retreat(self, robot: str) -> None:
        """Take an empty arm back from where its tool works: along the tool's axis (the way it came
        in), for the heavy variant straight back over the base, then to the ready posture."""
        from bimrobot.physics.site import MotionFailed

        site = self.site
        away = site.tcp_pose(robot)  # back out along the tool's axis (up, for a tool pointing down)
        away[:3, 3] -= away[:3, 2] * LIFT_M * max(1.0, self.families[robot].scale / 2)
        try:
            site.move_arm(robot, site.solve(robot, away), check_contacts=False)
        except MotionFailed:  # the component is down already: the arm goes to its ready posture below
            pass
        if self.families[robot].family == "heavy":  # then straight back over the base, as it is turned:
            back = away.copy()  # a joint-space swing of a metres-long arm would sweep through what it placed
            back[:3, 3] = site.tcp_position_at(robot, site.ready_posture(robot))
            try:
                site.move_arm(robot, site.solve(robot, back))
            except MotionFailed:  # not reachable turned so: to the ready posture directly
                pass
        site.move_arm(robot, site.ready_posture(robot))
