"""Where each model stands in the world: installed (its IFC placement) or on a yard (pick-up pose).

Poses are 4x4 matrices from the element's local frame (the SDF link frame) to the world frame,
metres, z up. The yard is where the site file (:mod:`bimrobot.site.site`, default the thesis' fig. 4.11) puts
its pick-up positions, taken into the model frame: components lie there in rows starting at the yard's
first corner, each turned by right angles so that its longest side runs along x and its thinnest side
is vertical (a column lies down, a wall panel lies flat), with their lowest point on the ground. This
is the thesis' "yard area to place unconstructed components" (fig. 3.10), where transport robots pick
them up; `simulate` and `rcan` use the same site.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from bimrobot.bim.model import Element
from bimrobot.core.frames import rpy_of  # SDF's roll, pitch, yaw, said in bimrobot.core.frames
from bimrobot.site.site import Site, default_site


@dataclass(frozen=True)
class Yard:
    """The yard rectangle on the ground: ``[[xmin, ymin], [xmax, ymax]]`` (m) at height ``ground_z``."""

    bounds: np.ndarray
    ground_z: float


def rigid(matrix: np.ndarray) -> np.ndarray:
    """The nearest proper rigid transform to a placement (removes round-off and scale from IFC)."""
    matrix = np.asarray(matrix, float)
    u, _, vt = np.linalg.svd(matrix[:3, :3])
    rotation = u @ vt
    if np.linalg.det(rotation) < 0:  # a mirrored placement cannot be a pose; keep the proper part
        u[:, -1] *= -1
        rotation = u @ vt
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = matrix[:3, 3]
    return out


def pose_xyz_rpy(matrix: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """(x, y, z, roll, pitch, yaw) of a rigid transform: metres and radians, SDF's fixed-axis
    convention (rotation = Rz(yaw) Ry(pitch) Rx(roll))."""
    matrix = np.asarray(matrix, float)
    return _pose_of(matrix.shape, matrix.tobytes())


@functools.lru_cache(maxsize=1 << 14)
def _pose_of(shape: tuple[int, ...], data: bytes) -> tuple[float, float, float, float, float, float]:
    """:func:`pose_xyz_rpy` of the matrix of ``shape`` whose float64 numbers are ``data``, computed once
    per matrix: `convert` asks for each model's pose four times (its SDF, the world's include, the
    report and the picture)."""
    matrix = np.frombuffer(data).reshape(shape)
    if np.abs(matrix[:3, :3] @ matrix[:3, :3].T - np.eye(3)).max() > 1e-9:
        matrix = rigid(matrix)
    roll, pitch, yaw = rpy_of(matrix[:3, :3])
    x, y, z = matrix[:3, 3]
    return float(x), float(y), float(z), float(roll), float(pitch), float(yaw)


def format_pose(matrix: np.ndarray) -> str:
    """The SDF ``<pose>`` text of a transform: ``"x y z roll pitch yaw"`` (m, rad)."""
    x, y, z, roll, pitch, yaw = pose_xyz_rpy(matrix)
    return f"{_num(x, 6)} {_num(y, 6)} {_num(z, 6)} {_num(roll, 9)} {_num(pitch, 9)} {_num(yaw, 9)}"


def _num(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def installed_poses(elements: list[Element]) -> dict[str, np.ndarray]:
    """Each element's installed pose: its IFC placement."""
    return {element.global_id: rigid(element.placement) for element in elements}


def site_offset(elements: list[Element], site: Site) -> np.ndarray:
    """Model frame -> site frame translation (x, y) in metres: the site's placement of the building
    (:meth:`bimrobot.site.site.Site.placed`: its ``model_offset``, or the one that centres the elements'
    footprint in the construction area, as `simulate` and `rcan` place it)."""
    return np.array(site.placed(elements).model_offset, dtype=float)


def yard_poses(
    elements: list[Element],
    ground_z: float,
    spacing: float = 0.5,
    centers_of_mass: dict[str, np.ndarray] | None = None,
    site: Site | None = None,
) -> tuple[dict[str, np.ndarray], Yard]:
    """Pick-up poses on the site's yard (see the module docstring) and the yard itself (model frame).

    ``spacing``: clear distance (m) between neighbouring components. Rows run along y from the yard's
    corner nearest the site origin (lowest x, then y, of the site's yard positions) and away from the
    building along x; a row is as deep as the yard positions span in y (at least 10 m). Components are
    sorted longest first, so similar parts (all columns, all beams) lie together. ``centers_of_mass``
    (local frame, m; default: the mean vertex) decide which face a part rests on: of the flat
    orientations, the one with the lowest centre of mass, so an angle lies on a leg rather than
    balancing on its edges. ``site``: default the thesis' fig. 4.11.
    """
    if not elements:
        return {}, Yard(np.zeros((2, 2)), ground_z)
    site = site or default_site()
    yard_points = site.to_model(np.array(site.yard, dtype=float), site_offset(elements, site))
    yard_min, yard_max = yard_points.min(axis=0), yard_points.max(axis=0)
    row_depth = max(yard_max[1] - yard_min[1], 10.0)
    centers = centers_of_mass or {}
    laid = {e.global_id: _lay_flat(e, centers.get(e.global_id)) for e in elements}
    order = sorted(elements, key=lambda e: (-_extents(laid[e.global_id], e)[0], e.ifc_class, e.global_id))
    poses: dict[str, np.ndarray] = {}
    row_x, cursor_y, row_length = yard_min[0], yard_min[1], 0.0
    far_corner = np.array([row_x, cursor_y])
    for element in order:
        rotation = laid[element.global_id]
        rotated = element.vertices @ rotation.T
        lower, upper = rotated.min(axis=0), rotated.max(axis=0)
        size = upper - lower
        if cursor_y > yard_min[1] and cursor_y + size[1] > yard_min[1] + row_depth:
            row_x, cursor_y, row_length = row_x + row_length + spacing, yard_min[1], 0.0
        pose = np.eye(4)
        pose[:3, :3] = rotation
        pose[:3, 3] = np.array([row_x, cursor_y, ground_z]) - lower
        poses[element.global_id] = pose
        cursor_y += size[1] + spacing
        row_length = max(row_length, size[0])
        far_corner = np.maximum(far_corner, [row_x + size[0], cursor_y - spacing])
    return poses, Yard(np.array([yard_min, far_corner]), ground_z)


def _lay_flat(element: Element, center_of_mass: np.ndarray | None = None) -> np.ndarray:
    """World rotation of the element on the yard: its installed rotation followed by the right-angle
    turn that puts its longest world extent along x and its shortest along z; among the turns about x
    that keep the thinnest side vertical, the one with the lowest centre of mass (a stable rest)."""
    installed = rigid(element.placement)[:3, :3]
    extents = np.ptp(element.vertices @ installed.T, axis=0)
    order = np.argsort(-extents, kind="stable")
    turn = np.zeros((3, 3))
    turn[np.arange(3), order] = 1.0
    if np.linalg.det(turn) < 0:
        turn[1] *= -1
    base = turn @ installed
    center = element.vertices.mean(axis=0) if center_of_mass is None else np.asarray(center_of_mass, float)
    candidates = []
    for quarter_turns in range(4):
        angle = quarter_turns * np.pi / 2
        about_x = np.array([[1, 0, 0], [0, np.cos(angle), -np.sin(angle)], [0, np.sin(angle), np.cos(angle)]])
        rotation = np.round(about_x) @ base
        rotated = element.vertices @ rotation.T
        height = np.ptp(rotated[:, 2])
        center_height = (rotation @ center)[2] - rotated[:, 2].min()
        candidates.append((round(height, 4), round(center_height, 6), quarter_turns, rotation))
    return min(candidates, key=lambda c: c[:3])[3]


def _extents(rotation: np.ndarray, element: Element) -> np.ndarray:
    return np.ptp(element.vertices @ rotation.T, axis=0)
