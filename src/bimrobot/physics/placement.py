"""Where a component's box goes when the RCAN plan says only where its origin is.

An RCAN node gives a component's weight, its three extents (smallest first: ``a <= b <= L``) and a
target position; it gives no orientation (the schedule's targets have no rotation). The scene needs
boxes, so the backend places them by the conventions the rest of bimrobot follows:

- **On the yard** (``convert --layout yard``, :mod:`bimrobot.export.gazebo.layout`) a component lies with its
  longest side along x and its thinnest side vertical, and its pick-up position is its centre of
  mass: the box ``(L, b, a)`` centred on the target.
- **Installed**, the target is the IFC placement origin. A member (``L >= 2.5 b``) is *horizontal* (a
  beam) when both its origin and its far end, ``L`` away along one of the four horizontal axes, lie
  inside components installed before it (the members it spans between): its origin is the centre of
  its end section, its deeper section side ``b`` is vertical. Any other member is *upright* (a
  column): the origin is the centre of its foot, and its section may turn about its axis (the plan
  does not say how; the robot installs it as it holds it, to a multiple of 90 degrees). A component
  that is no member (a footing, a slab, a panel) lies flat, thinnest side vertical, origin at the centre
  of its underside.

The body frame of a component box is the one of :class:`bimrobot.physics.site.Component`: size
``(L, b, a)`` along its x, y, z, origin at the centre of its z-bottom face. Units: metres, radians.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from bimrobot.core.frames import yaw_matrix as yaw_frame  # Rz(yaw), said in bimrobot.core.frames

MEMBER_RATIO = 2.5  # L >= 2.5 b: a linear member (column, beam)
# how far outside another component's box (horizontally, vertically) a member's end may lie and still
# be "in" it: a beam's end section stops a joint gap short of its column's face
INSIDE_TOLERANCE_M = (0.05, 0.01)
SIZE_TOLERANCE_M = 0.002


@dataclass(frozen=True)
class InstalledBox:
    """Where a component's box is once installed: ``centre`` (world, m), ``extents`` along the axes of
    ``frame`` (3x3: the target's yaw), ``kind`` (``upright``, ``horizontal`` or ``flat``)."""

    centre: np.ndarray
    extents: np.ndarray
    frame: np.ndarray
    kind: str

    @property
    def half_xy(self) -> np.ndarray:
        """Half size of the box's footprint along world x, y (its axis-aligned bounds, m)."""
        return (np.abs(self.frame) @ self.extents / 2)[:2]

    @property
    def bottom_z(self) -> float:
        return float(self.centre[2] - self.extents[2] / 2)

    @property
    def top_z(self) -> float:
        return float(self.centre[2] + self.extents[2] / 2)

    def contains(self, point, tolerance: tuple[float, float] = INSIDE_TOLERANCE_M) -> bool:
        local = self.frame.T @ (np.asarray(point, float) - self.centre)
        margin = np.array([tolerance[0], tolerance[0], tolerance[1]])
        return bool(np.all(np.abs(local) <= self.extents / 2 + margin))


def body_size(size_sorted) -> tuple[float, float, float]:
    """The component box's body size (x, y, z) = (L, b, a) from its extents, smallest first."""
    a, b, length = (float(v) for v in size_sorted)
    return (length, b, a)


def lying_pose(size_sorted, centre, yaw: float = 0.0) -> np.ndarray:
    """Body pose (4x4) of a component lying as on the yard, its centre at ``centre``."""
    length, b, a = body_size(size_sorted)
    pose = np.eye(4)
    pose[:3, :3] = yaw_frame(yaw)
    pose[:3, 3] = np.asarray(centre, float) - np.array([0.0, 0.0, a / 2])
    return pose


def installed_box(size_sorted, origin, yaw: float, installed: list[InstalledBox]) -> InstalledBox:
    """The installed box of a component whose IFC origin is at ``origin`` (see the module docstring);
    ``installed``: the boxes of the components installed before it."""
    a, b, length = (float(v) for v in size_sorted)
    origin = np.asarray(origin, float)
    frame = yaw_frame(yaw)
    if length >= MEMBER_RATIO * b:
        if any(box.contains(origin) for box in installed):
            for k in range(4):
                direction = frame @ np.array([math.cos(k * math.pi / 2), math.sin(k * math.pi / 2), 0.0])
                if any(box.contains(origin + length * direction) for box in installed):
                    along = yaw_frame(yaw + k * math.pi / 2)
                    return InstalledBox(origin + direction * length / 2, np.array([length, a, b]), along, "horizontal")
        return InstalledBox(origin + np.array([0.0, 0.0, length / 2]), np.array([b, a, length]), frame, "upright")
    return InstalledBox(origin + np.array([0.0, 0.0, a / 2]), np.array([length, b, a]), frame, "flat")


def _proper_permutations() -> list[np.ndarray]:
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            matrix = np.zeros((3, 3))
            for row, (col, sign) in enumerate(zip(perm, signs)):
                matrix[row, col] = sign
            if np.linalg.det(matrix) > 0:
                out.append(matrix)
    return out


PERMUTATIONS = _proper_permutations()


def body_rotations(size_sorted, box: InstalledBox) -> list[np.ndarray]:
    """Body rotations (3x3, world) that put the body box ``(L, b, a)`` onto ``box``: its sides along
    the box's extents (an upright member's section in either of its two ways)."""
    body = np.array(body_size(size_sorted))
    wanted = [box.extents]
    if box.kind == "upright":
        wanted.append(box.extents[[1, 0, 2]])
    out = []
    for matrix in PERMUTATIONS:
        along = np.abs(matrix) @ body
        if any(np.all(np.abs(along - w) <= SIZE_TOLERANCE_M) for w in wanted):
            out.append(box.frame @ matrix)
    return out


def body_pose(size_sorted, box: InstalledBox, rotation: np.ndarray) -> np.ndarray:
    """Body pose (4x4) with rotation ``rotation`` and the box's centre at ``box.centre``."""
    a = body_size(size_sorted)[2]
    pose = np.eye(4)
    pose[:3, :3] = rotation
    pose[:3, 3] = box.centre - rotation @ np.array([0.0, 0.0, a / 2])
    return pose


#: a box looks the same turned half a turn about any of its axes
BOX_SYMMETRIES = [np.diag(v) for v in ((1.0, 1.0, 1.0), (1.0, -1.0, -1.0), (-1.0, 1.0, -1.0), (-1.0, -1.0, 1.0))]


def box_angle(actual: np.ndarray, target: np.ndarray) -> float:
    """Angle (rad) between two box orientations, up to the box's symmetries."""
    best = math.pi
    for symmetry in BOX_SYMMETRIES:
        cosine = (np.trace(actual.T @ target @ symmetry) - 1) / 2
        best = min(best, math.acos(max(-1.0, min(1.0, cosine))))
    return best
