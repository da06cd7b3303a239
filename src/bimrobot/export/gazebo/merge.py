"""Merged models for large buildings (``convert --merge-static``): one static model per storey and IFC class.

A building of thousands of elements becomes thousands of models, which a simulator loads, draws and
checks one by one. What robots do not handle only needs to be seen and collided with, so
``--merge-static`` gathers the static elements of each storey and IFC class into one model
(``merged_<storey>_<class>``) with one link: the visual is every element's body, the collision every
element's collision mesh (convex hull or decimated body, as for a single element; Gazebo treats the
mesh of a static model as a triangle mesh, so the pieces need not form one convex body), and the
inertial the exact sum of the elements' (mass, centre of mass and tensor moved to the common centre
of mass by the parallel-axis theorem). The model's frame is the world frame moved to the lower
corner of the group's bounding box, so mesh coordinates stay small (single-precision meshes lose
millimetres far from their origin). report.json names the model that holds each element.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from bimrobot.core.io import printable
from bimrobot.export.gazebo import meshes
from bimrobot.export.gazebo import sdf

if TYPE_CHECKING:
    from bimrobot.export import inertia as physics


@dataclass
class MergedModel:
    """One merged model: its name, storey (GlobalId and name), IFC class, the indices of its elements
    (into the conversion's element list) and its pose (4x4, a pure translation, m)."""

    name: str
    storey_id: str | None
    storey_name: str
    ifc_class: str
    members: list[int]
    pose: np.ndarray
    figures: dict = field(default_factory=dict)  # what write_merged_model measured (mass, triangles)

    def as_report(self) -> dict:
        return {
            "model": self.name,
            "storey_id": self.storey_id,
            "storey_name": self.storey_name,
            "ifc_class": self.ifc_class,
            "elements": len(self.members),
            **{key: value for key, value in self.figures.items() if key != "name"},
        }


def combined_mass(parts: list[tuple[physics.MassProperties, np.ndarray]]) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass kg, centre of mass, inertia 3x3 about it) of rigidly joined bodies, each given as (its
    mass properties in its own frame, its 4x4 pose in the common frame)."""
    masses = np.array([m.mass for m, _ in parts])
    centres = np.array([pose[:3, :3] @ m.center_of_mass + pose[:3, 3] for m, pose in parts])
    total = float(masses.sum())
    centre = (masses[:, None] * centres).sum(axis=0) / total
    inertia = np.zeros((3, 3))
    for (props, pose), mass, point in zip(parts, masses, centres):
        rotation = pose[:3, :3]
        offset = point - centre
        inertia += rotation @ props.inertia @ rotation.T + mass * (offset @ offset * np.eye(3) - np.outer(offset, offset))
    return total, centre, (inertia + inertia.T) / 2


def _concatenate(pieces: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """One (vertices, faces) mesh from several, face indices shifted."""
    offsets = np.cumsum([0] + [len(v) for v, _ in pieces[:-1]])
    vertices = np.concatenate([v for v, _ in pieces])
    faces = np.concatenate([f + offset for (_, f), offset in zip(pieces, offsets)])
    return vertices, faces


def write_merged_model(models_dir: Path, merged: MergedModel, items: list, versions: dict[str, str], source: str) -> dict:
    """Write models/<name>/ for a merged model; ``items`` are the conversion's elements (with body,
    collision mesh, mass properties and pose, see bimrobot.export.gazebo.package). Returns its figures."""
    to_model = np.linalg.inv(merged.pose)
    frames = [to_model @ item.pose for item in items]

    def moved(vertices: np.ndarray, frame: np.ndarray) -> np.ndarray:
        return vertices @ frame[:3, :3].T + frame[:3, 3]

    visual = _concatenate([(moved(item.body.vertices, f), item.body.faces) for item, f in zip(items, frames)])
    collision = _concatenate([(moved(item.geometry.collision[0], f), item.geometry.collision[1]) for item, f in zip(items, frames)])
    mass, centre, inertia = combined_mass([(item.mass, f) for item, f in zip(items, frames)])

    from bimrobot.export.inertia import symmetric_positive  # with trimesh and SciPy: imported by the work

    folder = models_dir / merged.name
    folder.mkdir()
    (folder / "meshes").mkdir()
    visual_file, collision_file = f"{merged.name}.dae", f"{merged.name}_collision.stl"
    dae = meshes.dae_text(*visual, merged.name, meshes.colour_of(merged.ifc_class))
    (folder / "meshes" / visual_file).write_text(dae, encoding="utf-8")
    (folder / "meshes" / collision_file).write_bytes(meshes.stl_bytes(*collision))
    spec = sdf.ModelSpec(
        name=merged.name,
        pose=merged.pose,
        static=True,
        mass=mass,
        center_of_mass=centre,
        inertia=symmetric_positive(inertia),
        visual_uri=f"model://{merged.name}/meshes/{visual_file}",
        collision_uri=f"model://{merged.name}/meshes/{collision_file}",
    )
    for version, file_name in versions.items():
        (folder / file_name).write_text(sdf.model_sdf(spec, version), encoding="utf-8")
    description = (f'{len(items)} static {merged.ifc_class} elements of storey "{printable(merged.storey_name)}" '
                   f"merged into one model (their GlobalIds are in report.json) from {source}")
    (folder / "model.config").write_text(sdf.model_config(merged.name, versions, description), encoding="utf-8")
    return {
        "name": merged.name,
        "mass_kg": round(mass, 6),
        "visual_triangles": int(len(visual[1])),
        "collision_triangles": int(len(collision[1])),
    }
