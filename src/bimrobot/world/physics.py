"""Mass, centre of mass and inertia tensor of a building element, for the SDF ``<inertial>`` block.

Everything is in the element's local frame (the SDF link frame): metres, kg, kg m^2. The tensor is
about the centre of mass with axes parallel to the link frame, as SDF expects when the inertial pose
has no rotation.

Mass comes from the BIM weight (``Element.weight_kg``, whatever its source). When the BIM has no
weight, the mass is the body volume times :data:`DEFAULT_DENSITY_KG_M3` and the result says so
(``mass_assumed``). The tensor is the exact one of the solid mesh scaled to that mass (uniform
density); a mesh that is not a closed volume falls back to its convex hull, and a flat mesh to its
bounding box with a minimum thickness of :data:`MIN_THICKNESS_M`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from bimrobot.bim.model import Element

DEFAULT_DENSITY_KG_M3 = 2400.0
"""Density used when the BIM gives no weight: normal-weight concrete, the bulk of most buildings."""

MIN_THICKNESS_M = 0.001
"""Thickness given to flat bodies (zero volume) so that their inertia stays positive definite."""


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


def solid_mesh(vertices: np.ndarray, faces: np.ndarray) -> trimesh.Trimesh:
    """A merged (shared-vertex) trimesh of an element body, with outward normals where it is closed."""
    mesh = trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces, np.int64), process=True)
    if mesh.is_watertight and mesh.volume < 0:
        mesh.invert()
    return mesh


def mass_properties(
    element: Element, mesh: trimesh.Trimesh | None = None, default_density: float = DEFAULT_DENSITY_KG_M3
) -> MassProperties:
    """The element's mass properties (see the module docstring for the fallbacks)."""
    mesh = mesh if mesh is not None else solid_mesh(element.vertices, element.faces)
    body, method = _volume_body(mesh)
    volume = float(body.volume)
    if element.weight_kg is not None and element.weight_kg > 0:
        mass, assumed = float(element.weight_kg), False
    else:
        mass, assumed = volume * default_density, True
    body.density = mass / volume
    inertia = _symmetric_positive(np.asarray(body.moment_inertia, float))
    return MassProperties(
        mass=mass,
        center_of_mass=np.asarray(body.center_mass, float),
        inertia=inertia,
        volume=volume,
        inertia_method=method,
        mass_assumed=assumed,
    )


def _volume_body(mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, str]:
    """The closed body the integrals are taken over, and how it was obtained."""
    if mesh.is_watertight and mesh.volume > 1e-12:
        return mesh, "solid mesh"
    try:
        hull = mesh.convex_hull
        if hull.volume > 1e-12:
            return hull, "convex hull"
    except Exception:  # qhull raises on flat or degenerate input
        pass
    lower, upper = mesh.bounds if len(mesh.vertices) else (np.zeros(3), np.zeros(3))
    extents = np.maximum(upper - lower, MIN_THICKNESS_M)
    box = trimesh.creation.box(extents=extents)
    box.apply_translation((lower + upper) / 2)
    return box, "bounding box"


def _symmetric_positive(tensor: np.ndarray) -> np.ndarray:
    """Symmetrise and lift vanishing principal moments (numerical noise on slender bodies)."""
    tensor = (tensor + tensor.T) / 2
    eigenvalues, eigenvectors = np.linalg.eigh(tensor)
    floor = max(eigenvalues.max(), 1e-12) * 1e-9
    if eigenvalues.min() < floor:
        eigenvalues = np.maximum(eigenvalues, floor)
        tensor = eigenvectors @ np.diag(eigenvalues) @ eigenvectors.T
    return tensor


def principal_moments(inertia: np.ndarray) -> np.ndarray:
    """Principal moments of inertia (ascending, kg m^2)."""
    return np.linalg.eigvalsh((inertia + inertia.T) / 2)
