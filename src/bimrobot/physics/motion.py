"""Motion helpers: the arm's inverse kinematics (mink), joint-space interpolation, grid paths for the
base (pyastar2d), and poses. Units: metres, radians; rotation matrices 3x3, poses 4x4."""

from __future__ import annotations

import math

import numpy as np

from bimrobot.core.frames import planar_transform as planar  # poses and turns are bimrobot.core.frames', by their old names
from bimrobot.core.frames import tool_down
from bimrobot.core.frames import transform as pose
from bimrobot.physics.robot import RobotModel, arm_only_xml

IK_POSITION_TOLERANCE_M = 1e-3
IK_ANGLE_TOLERANCE_RAD = math.radians(0.5)


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """Rotation angle (rad) from rotation a to rotation b."""
    cosine = (np.trace(a.T @ b) - 1) / 2
    return float(math.acos(max(-1.0, min(1.0, cosine))))


def between(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    """The pose a fraction ``t`` of the way from pose ``a`` to pose ``b`` (4x4): position linear,
    rotation about the axis that turns one into the other."""
    relative = a[:3, :3].T @ b[:3, :3]
    angle = angle_between(a[:3, :3], b[:3, :3])
    rotation = a[:3, :3]
    if angle > 1e-9:
        axis = np.array([relative[2, 1] - relative[1, 2], relative[0, 2] - relative[2, 0], relative[1, 0] - relative[0, 1]])
        if np.linalg.norm(axis) < 1e-9:  # half a turn: the axis from the symmetric part
            axis = np.sqrt(np.maximum((np.diag(relative) + 1) / 2, 0.0))
        axis = axis / np.linalg.norm(axis)
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        theta = angle * t
        rotation = a[:3, :3] @ (np.eye(3) + math.sin(theta) * k + (1 - math.cos(theta)) * k @ k)
    return pose(rotation, a[:3, 3] + (b[:3, 3] - a[:3, 3]) * t)


def wrap_near(target: np.ndarray, current: np.ndarray, full_turn: np.ndarray) -> np.ndarray:
    """``target`` with every joint that may turn fully (``full_turn``) moved by whole turns to the
    equivalent angle nearest ``current``: the arm never turns a joint further than it must."""
    delta = (target - current + math.pi) % (2 * math.pi) - math.pi
    wrapped = current + delta
    # within the joints' range of +-2 pi (a whole turn the other way where it would leave it)
    wrapped = np.where(wrapped > 2 * math.pi, wrapped - 2 * math.pi, np.where(wrapped < -2 * math.pi, wrapped + 2 * math.pi, wrapped))
    return np.where(full_turn, wrapped, target)


def smooth_steps(start: np.ndarray, goal: np.ndarray, seconds: float, dt: float):
    """Joint references from ``start`` to ``goal`` in ``seconds``, one per step ``dt`` (a quintic
    time law: zero speed and acceleration at both ends)."""
    count = max(1, int(round(seconds / dt)))
    for k in range(1, count + 1):
        s = k / count
        blend = 10 * s**3 - 15 * s**4 + 6 * s**5
        yield start + (goal - start) * blend


class ArmIK:
    """Inverse kinematics of one arm of the family, with mink (differential IK on MuJoCo, QP solver
    daqp): a frame task on the tool centre point, a light posture task towards the seed (keeps the
    elbow up and the solution near the current joints), and the joint limits."""

    def __init__(self, robot: RobotModel):
        import mink
        import mujoco

        self.mink = mink
        self.model = mujoco.MjModel.from_xml_string(arm_only_xml(robot))
        self.arm_dofs = 6
        self.task = mink.FrameTask("tcp", "site", position_cost=1.0, orientation_cost=1.0)
        self.posture = mink.PostureTask(self.model, cost=1e-2)
        self.limits = [mink.ConfigurationLimit(self.model)]
        self.configuration = mink.Configuration(self.model)
        self._kinematics = mujoco.MjData(self.model)  # scratch for lowest_link

    def solve(self, target: np.ndarray, seed: np.ndarray, iterations: int = 400) -> tuple[np.ndarray, float, float]:
        """Joint angles (6) putting the tcp at ``target`` (4x4 in the arm base frame) from ``seed``;
        with the remaining position (m) and angle (rad) error."""
        mink = self.mink
        q = np.zeros(self.model.nq)
        q[:6] = seed
        self.configuration.update(q)
        self.posture.set_target(q)
        self.task.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(target[:3, :3]), target[:3, 3]))
        error = np.full(6, np.inf)
        # first with the posture task (a solution near the seed), then the frame task alone: the posture
        # task's pull would otherwise leave a millimetre or two of error
        for tasks in ([self.task, self.posture], [self.task]):
            for _ in range(iterations // 2):
                velocity = mink.solve_ik(self.configuration, tasks, 0.05, "daqp", damping=1e-3, limits=self.limits)
                self.configuration.integrate_inplace(velocity, 0.05)
                error = self.task.compute_error(self.configuration)
                if np.linalg.norm(error[:3]) < IK_POSITION_TOLERANCE_M / 10 and np.linalg.norm(error[3:]) < 1e-4:
                    break
        return self.configuration.q[:6].copy(), float(np.linalg.norm(error[:3])), float(np.linalg.norm(error[3:]))


    def lowest_link(self, q: np.ndarray) -> float:
        """Height (m, arm base frame) of the lowest joint of the arm at joints ``q``."""
        import mujoco

        data = self._kinematics
        data.qpos[:6] = q
        mujoco.mj_kinematics(self.model, data)
        return float(data.xpos[2:, 2].min())  # bodies after the world and the arm's first link


def grid_path(occupied: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> np.ndarray | None:
    """Cells (row, col) of a shortest 8-connected path from ``start`` to ``goal`` avoiding
    ``occupied`` cells (pyastar2d's A*), or None when there is none."""
    import pyastar2d

    weights = np.where(occupied, np.inf, 1.0).astype(np.float32)
    weights[start] = 1.0  # the robot's own cell counts free (it stands there)
    if not np.isfinite(weights[goal]):
        return None
    return pyastar2d.astar_path(weights, start, goal, allow_diagonal=True)


def simplify(points: np.ndarray, occupied_at, step: float) -> list[np.ndarray]:
    """Fewer waypoints: from each kept point, jump to the farthest later point reachable in a straight
    line through free space (checked every ``step`` m with ``occupied_at(xy) -> bool``)."""
    kept = [points[0]]
    i = 0
    while i < len(points) - 1:
        j = len(points) - 1
        while j > i + 1 and not _line_free(points[i], points[j], occupied_at, step):
            j -= 1
        kept.append(points[j])
        i = j
    return kept


def _line_free(a: np.ndarray, b: np.ndarray, occupied_at, step: float) -> bool:
    count = max(2, int(np.linalg.norm(b - a) / step) + 1)
    return not any(occupied_at(a + (b - a) * t) for t in np.linspace(0, 1, count))
