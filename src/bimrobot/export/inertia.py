"""Mass, centre of mass and inertia tensor of a building element, for the SDF ``<inertial>`` block.

Everything is in the element's local frame (the SDF link frame): metres, kg, kg m^2. The tensor is
about the centre of mass with axes parallel to the link frame, as SDF expects when the inertial pose
has no rotation.

Mass comes from the element's weight (``Element.weight_kg``, whatever its source, including the mass
:mod:`bimrobot.bim.unknown_weight` assumed). An element still without a weight (its mesh encloses no
volume, so the unknown-weight rule could not price it) gets the same rule's density times the volume
the integrals are taken over (convex hull or box), and the result says so (``mass_assumed``); the
default is :data:`DEFAULT_DENSITY_KG_M3`, the unknown-weight rule's own. The tensor is the exact one of the solid mesh scaled to that mass (uniform
density); a mesh that is not a closed, consistently wound volume falls back to its convex hull, and a
flat mesh to its bounding box with a minimum thickness of :data:`MIN_THICKNESS_M`.

The integrals depend only on the geometry, so :class:`Body` computes them once per distinct mesh (IFC
files share one geometry between many bolts or cleats) and :func:`mass_properties` scales them.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from bimrobot.bim import unknown_weight
from bimrobot.bim.model import Element

DEFAULT_DENSITY_KG_M3 = unknown_weight.DEFAULT_DENSITY_KG_M3
"""Density used when the BIM gives no weight: the one rule's default (normal-weight concrete)."""

MIN_THICKNESS_M = 0.001
"""Thickness given to flat bodies (zero volume) so that their inertia stays positive definite."""

MERGE_TOLERANCE_M = 1e-8
"""Vertices closer than this (per coordinate) are one vertex."""


@dataclass(frozen=True)
class MassProperties:
    """Mass (kg), centre of mass (local frame, m), inertia about it (3x3, kg m^2), volume (m^3).

    ``inertia_method``: "solid mesh", "convex hull" or "bounding box" (what the tensor was computed
    from). ``mass_assumed``: True when the mass is volume x :data:`DEFAULT_DENSITY_KG_M3`.
    """

    mass: float
    center_of_mass: np.ndarray
    inertia: np.ndarray
    volume: float
    inertia_method: str
    mass_assumed: bool


def merge_vertices(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shared-vertex form of a triangle soup: duplicate vertices merged, degenerate faces dropped."""
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    if len(vertices) == 0 or len(faces) == 0:
        return vertices.reshape(-1, 3), faces.reshape(-1, 3)
    keys = np.round(vertices / MERGE_TOLERANCE_M).astype(np.int64)
    first, inverse = trimesh.grouping.unique_rows(keys)
    merged_faces = np.asarray(inverse).reshape(-1)[faces]
    keep = (
        (merged_faces[:, 0] != merged_faces[:, 1])
        & (merged_faces[:, 1] != merged_faces[:, 2])
        & (merged_faces[:, 0] != merged_faces[:, 2])
    )
    return vertices[first], merged_faces[keep]


def closed_and_consistent(faces: np.ndarray) -> bool:
    """True when every edge is shared by exactly two faces that traverse it in opposite directions
    (a watertight, consistently wound surface: its volume integral is exact)."""
    if len(faces) < 4:
        return False
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    stride = int(faces.max()) + 1
    if len(np.unique(directed[:, 0] * stride + directed[:, 1])) != len(directed):
        return False
    lower, upper = directed.min(axis=1), directed.max(axis=1)
    _, counts = np.unique(lower * stride + upper, return_counts=True)
    return bool(np.all(counts == 2))


def convex_hull(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(vertices, outward-wound faces) of the convex hull, or None for flat/degenerate point sets."""
    if len(vertices) < 4:
        return None
    try:
        hull = ConvexHull(vertices)
    except (QhullError, ValueError):
        return None
    simplices = hull.simplices.copy()
    corners = vertices[simplices]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    inward = np.einsum("ij,ij->i", normals, hull.equations[:, :3]) < 0
    simplices[inward] = simplices[inward][:, ::-1]
    used, remapped = np.unique(simplices, return_inverse=True)
    hull_vertices, hull_faces = vertices[used], remapped.reshape(-1, 3)
    if hull.volume <= 1e-12:
        return None
    return hull_vertices, hull_faces


class Body:
    """One distinct element geometry (local frame, metres) and its volume integrals."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        self.vertices, self.faces = merge_vertices(vertices, faces)

    @cached_property
    def hull(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Convex hull (vertices, faces), None when the body is flat."""
        return convex_hull(self.vertices)

    @cached_property
    def _integrals(self) -> tuple[float, np.ndarray, np.ndarray, str]:
        """(volume m^3, centre of mass, inertia at unit density, method)."""
        if closed_and_consistent(self.faces):
            props = trimesh.triangles.mass_properties(self.vertices[self.faces])
            if props.volume < 0:  # wound inwards throughout
                props = trimesh.triangles.mass_properties(self.vertices[self.faces[:, ::-1]])
            if props.volume > 1e-12:
                return float(props.volume), props.center_mass, props.inertia, "solid mesh"
        if self.hull is not None:
            vertices, faces = self.hull
            props = trimesh.triangles.mass_properties(vertices[faces])
            return float(props.volume), props.center_mass, props.inertia, "convex hull"
        lower, upper = (self.vertices.min(axis=0), self.vertices.max(axis=0)) if len(self.vertices) else (np.zeros(3),) * 2
        extents = np.maximum(upper - lower, MIN_THICKNESS_M)
        volume = float(np.prod(extents))
        a, b, c = extents**2
        inertia = volume / 12 * np.diag([b + c, a + c, a + b])
        return volume, (lower + upper) / 2, inertia, "bounding box"

    @property
    def volume(self) -> float:
        """Volume of the body the integrals are taken over (m^3)."""
        return self._integrals[0]

    def mass_properties(self, weight_kg: float | None, default_density: float | None = DEFAULT_DENSITY_KG_M3) -> MassProperties:
        """Mass properties for a given BIM weight (None or <= 0: volume x ``default_density``; a
        ``default_density`` of None, the refuse rule, then raises ValueError: callers refuse first)."""
        volume, center, unit_inertia, method = self._integrals
        if weight_kg is not None and weight_kg > 0:
            mass, assumed = float(weight_kg), False
        elif default_density is None:
            raise ValueError("no weight and no density to assume one (--unknown-weight refuse)")
        else:
            mass, assumed = volume * default_density, True
        inertia = _symmetric_positive(np.asarray(unit_inertia, float) * (mass / volume))
        return MassProperties(mass, np.asarray(center, float), inertia, volume, method, assumed)


def mass_properties(element: Element, body: Body | None = None, default_density: float = DEFAULT_DENSITY_KG_M3) -> MassProperties:
    """The element's mass properties (see the module docstring for the fallbacks)."""
    body = body if body is not None else Body(element.vertices, element.faces)
    return body.mass_properties(element.weight_kg, default_density)


def _symmetric_positive(tensor: np.ndarray) -> np.ndarray:
    """Symmetrise and lift vanishing principal moments (numerical noise on slender bodies)."""
    tensor = (tensor + tensor.T) / 2
    eigenvalues, eigenvectors = np.linalg.eigh(tensor)
    floor = max(eigenvalues.max(), 1e-12) * 1e-9
    if eigenvalues.min() < floor:
        eigenvalues = np.maximum(eigenvalues, floor)
        tensor = eigenvectors @ np.diag(eigenvalues) @ eigenvectors.T
    return tensor


symmetric_positive = _symmetric_positive


def principal_moments(inertia: np.ndarray) -> np.ndarray:
    """Principal moments of inertia (ascending, kg m^2)."""
    return np.linalg.eigvalsh((inertia + inertia.T) / 2)
