"""The BuildingModel: what an IFC file holds, read once and handed on to every other part.

Frames and units: every length is in metres, z up; placements are 4x4 homogeneous matrices from the
element's local frame to the project's world frame; meshes are in the element's local frame, so
``world_vertex = placement @ [local_vertex, 1]``. Masses are in kg. Elements are identified by their
IFC GlobalId everywhere.

This module holds plain data only; reading IFC lives in :mod:`bimrobot.bim.reader`.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np


class WeightSource(str, enum.Enum):
    """Where an element's weight came from, best first."""

    QUANTITY = "IfcQuantityWeight"
    PROPERTY = "weight property"  # e.g. Revit's Structural/Exact Weight
    DENSITY = "volume x material density"
    ASSUMED = "assumed density (--unknown-weight)"  # set by bimrobot.bim.unknown_weight, never by the reader
    UNKNOWN = "unknown"


@dataclass(frozen=True)
class Storey:
    """An IfcBuildingStorey: ``elevation`` in metres above the project origin (world z)."""

    global_id: str
    name: str
    elevation: float


@dataclass(frozen=True)
class Connection:
    """A joint between two elements.

    From ``IfcRelConnectsWithRealizingElements`` (``inferred=False``): ``relating_id`` and
    ``related_id`` are the connected elements, ``realizing_ids`` the bolts, welds, plates or cleats that
    realise the joint, ``connection_type`` the relation's ConnectionType (may be empty).
    Inferred from touching geometry (``inferred=True``): ``global_id`` is None and ``realizing_ids`` empty.
    """

    relating_id: str
    related_id: str
    realizing_ids: tuple[str, ...] = ()
    connection_type: str = ""
    global_id: str | None = None
    inferred: bool = False


def mesh_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Enclosed volume (m3) of a closed triangle mesh (``vertices`` (N, 3) in metres, ``faces`` (M, 3)
    vertex indices) by the divergence theorem (absolute value)."""
    if len(faces) == 0:
        return 0.0
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    return float(abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0)


@dataclass
class Element:
    """One building element with solid geometry.

    ``placement``: 4x4 local-to-world matrix (metres). ``vertices`` (n, 3) float64 and ``faces`` (m, 3)
    int64: the triangulated body in the local frame (metres). ``weight_kg`` is None when unknown.
    ``properties``: property-set values as ``{"Pset/Name": value}`` (units as in the file).
    ``density_kg_m3``: the density of the element's material structure (kg/m3; None when unknown),
    used for the weight when ``weight_source`` is DENSITY and to check a weight the model gives.
    ``weight_basis``: how the weight was found, or why it is unknown, in words.
    ``weight_assumed_as``: the material the unknown-weight rule assumed (e.g. "steel 7850 kg/m3"), or None.
    """

    global_id: str
    ifc_class: str
    name: str
    storey_id: str | None
    placement: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray
    material: str | None = None
    weight_kg: float | None = None
    weight_source: WeightSource = WeightSource.UNKNOWN
    properties: dict = field(default_factory=dict)
    density_kg_m3: float | None = None
    weight_basis: str = ""
    weight_assumed_as: str | None = None  # e.g. "steel 7850 kg/m3" when the unknown-weight rule gave the weight

    @cached_property
    def volume_m3(self) -> float:
        """Enclosed volume of the body (m3), from its mesh."""
        return mesh_volume(self.vertices, self.faces)

    @cached_property
    def mesh(self):
        """The body as a ``trimesh.Trimesh`` in the local frame (metres)."""
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, process=False)

    @cached_property
    def world_vertices(self) -> np.ndarray:
        """Vertices in the world frame (metres), shape (n, 3)."""
        homogeneous = np.c_[self.vertices, np.ones(len(self.vertices))]
        return (homogeneous @ self.placement.T)[:, :3]

    @property
    def local_bounds(self) -> np.ndarray:
        """Axis-aligned bounds in the local frame: [[xmin, ymin, zmin], [xmax, ymax, zmax]] (metres)."""
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    @property
    def world_bounds(self) -> np.ndarray:
        """Axis-aligned bounds in the world frame: [[xmin, ymin, zmin], [xmax, ymax, zmax]] (metres)."""
        world = self.world_vertices
        return np.array([world.min(axis=0), world.max(axis=0)])

    @property
    def position(self) -> np.ndarray:
        """Origin of the local frame in world coordinates (metres)."""
        return self.placement[:3, 3].copy()

    @property
    def centroid(self) -> np.ndarray:
        """Centre of the world bounding box (metres)."""
        return self.world_bounds.mean(axis=0)


@dataclass(frozen=True)
class Assembly:
    """An aggregate lifted and placed as one unit: an ``IfcElementAssembly`` (a precast cast unit, a steel
    sub-frame) or another element made of parts (``IfcRelAggregates``), such as Tekla's wide-slab floor
    plate (an ``IfcSlab`` of ``IfcBuildingElementProxy`` parts) or a window of frame members.

    Only outermost aggregates are kept: a Tekla precast balcony that holds embedded steel assemblies is
    one unit. ``part_ids``: GlobalIds of the loaded elements anywhere below it (and the whole itself when
    it has a body of its own), in file order. ``ifc_class``: the class of the whole.
    """

    global_id: str
    name: str
    storey_id: str | None
    part_ids: tuple[str, ...]
    ifc_class: str = "IfcElementAssembly"


@dataclass(frozen=True)
class Relocation:
    """An element whose local placement lies away from its body: its origin was moved onto the body.

    ``distance_m``: how far the file's origin lay outside the body's local bounding box (metres);
    ``file_origin`` / ``origin``: the origin in world coordinates before and after (metres). The body
    is unchanged in the world; only the frame's origin moved (see :func:`bimrobot.bim.reader.anchor_to_bodies`).
    """

    global_id: str
    ifc_class: str
    name: str
    distance_m: float
    file_origin: tuple[float, float, float]
    origin: tuple[float, float, float]


@dataclass(frozen=True)
class SkippedProduct:
    """A product that did not become an Element, and why (e.g. a curve-only weld)."""

    global_id: str
    ifc_class: str
    name: str
    reason: str


@dataclass
class BuildingModel:
    """Everything the platform needs from one IFC file.

    ``elements`` keeps file order and maps GlobalId -> Element. ``units`` records the file's units as
    read (e.g. ``{"length": "MILLIMETRE", "length_scale_to_m": 0.001, "mass": "KILOGRAM"}``).
    """

    source: Path | None
    schema: str
    project_name: str
    site_name: str
    units: dict
    storeys: list[Storey]
    elements: dict[str, Element]
    connections: list[Connection]
    skipped: list[SkippedProduct] = field(default_factory=list)
    assemblies: dict[str, Assembly] = field(default_factory=dict)
    #: elements whose origin was moved from a placement away from the body onto it (see Relocation)
    relocated: list[Relocation] = field(default_factory=list)
    #: what the unknown-weight rule did when the model was loaded (an UnknownWeights), None if not applied
    unknown_weights: object | None = None
    #: the ``--prebuilt`` selector evaluated when the model was loaded, and the keys it picked
    prebuilt_selector: str | None = None
    prebuilt_ids: frozenset[str] = frozenset()

    def assembly_of(self, global_id: str) -> Assembly | None:
        """The outermost assembly that holds the element, or None."""
        return self._assembly_by_part.get(global_id)

    @cached_property
    def _assembly_by_part(self) -> dict[str, Assembly]:
        return {part: assembly for assembly in self.assemblies.values() for part in assembly.part_ids}

    def element(self, global_id: str) -> Element:
        """The element with this GlobalId (KeyError naming it when absent)."""
        try:
            return self.elements[global_id]
        except KeyError:
            raise KeyError(f"no element with GlobalId {global_id!r} in {self.source or 'the model'}") from None

    def by_class(self, *ifc_classes: str) -> list[Element]:
        """Elements whose IFC class is one of ``ifc_classes`` (exact names, e.g. "IfcBeam")."""
        wanted = set(ifc_classes)
        return [e for e in self.elements.values() if e.ifc_class in wanted]

    def connections_of(self, global_id: str) -> list[Connection]:
        """Connections in which the element is relating, related or realizing."""
        return [
            c
            for c in self.connections
            if global_id in (c.relating_id, c.related_id) or global_id in c.realizing_ids
        ]

    def storey(self, global_id: str) -> Storey:
        """The storey with this GlobalId."""
        for storey in self.storeys:
            if storey.global_id == global_id:
                return storey
        raise KeyError(f"no storey with GlobalId {global_id!r}")

    def class_counts(self) -> dict[str, int]:
        """Number of elements per IFC class, sorted by class name."""
        counts: dict[str, int] = {}
        for element in self.elements.values():
            counts[element.ifc_class] = counts.get(element.ifc_class, 0) + 1
        return dict(sorted(counts.items()))
