"""The parts the example buildings are made of: a small author around ``ifcopenshell.api`` (GlobalIds
derived from names, placement, extruded bodies, weights, bolted joints), the steel sections and
densities, the dimensions of the thesis' frames, and the members every example is built from (bolt,
footing, column, beam). Metres, kilograms, z up; IFC4.

:mod:`bimrobot.bim.examples` writes the thesis' buildings with them, :mod:`bimrobot.bim.generated_buildings`
the generated ones.
"""


from __future__ import annotations

import math
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.unit
import ifcopenshell.guid

from bimrobot.core import io

STEEL_DENSITY = 7850.0  # kg/m3
CONCRETE_DENSITY = 2400.0  # kg/m3


@dataclass(frozen=True)
class ISection:
    """A hot-rolled I/H section, metres; ``mass_per_m`` in kg/m (catalogue value)."""

    name: str
    depth: float
    width: float
    web: float
    flange: float
    fillet: float
    mass_per_m: float


# Catalogue dimensions (AISC metric W shapes; Euronorm IPE/HEA).
W250X73 = ISection("W250x73", 0.253, 0.254, 0.0086, 0.0142, 0.013, 72.9)
W310X38_7 = ISection("W310x38.7", 0.310, 0.165, 0.0058, 0.0097, 0.008, 38.7)
HEA100 = ISection("HEA100", 0.096, 0.100, 0.005, 0.008, 0.012, 16.7)
IPE120 = ISection("IPE120", 0.120, 0.064, 0.0044, 0.0063, 0.007, 10.4)

# Steel frame geometry (metres).
FRAME_SPAN_X = 2.846
FRAME_SPAN_Y = 3.500
FOOTING_SIZE = (1.2, 1.2, 0.6)
BASE_PLATE_SIZE = (0.40, 0.40, 0.025)
COLUMN_LENGTH = 4.0
COLUMN_WEIGHT = 289.81  # kg, thesis fig. 4.5
BEAM_WEIGHTS = {FRAME_SPAN_X: 105.49, FRAME_SPAN_Y: 134.39}  # kg by span, thesis fig. 4.5
BEAM_END_GAP = 0.012  # clearance between beam end and column face
CLIP_ANGLE = (0.089, 0.089, 0.0095, 0.20)  # L89x89x9.5, leg, leg, thickness, length
BOLT_DIAMETER = 0.020  # M20

# Greenhouse geometry (metres).
GREENHOUSE_BAY = 3.0
GREENHOUSE_COLUMN_HEIGHT = 2.5
GREENHOUSE_FOUNDATION = (0.6, 0.6, 0.5)

_GUID_NAMESPACE = uuid.UUID("6f1c2a0e-8d4b-4c55-9a57-3b1e0c6d2f10")


class _Author:
    """Small helper around ifcopenshell.api for one model: ids, placement, representation, weight."""

    def __init__(self, project_name: str, site_name: str):
        self.file = ifcopenshell.api.project.create_file(version="IFC4")
        self._names: set[str] = set()
        self._stable_ids: set[str] = set()
        self._key = project_name
        self.project = self.entity("IfcProject", project_name)
        units = [
            ifcopenshell.api.unit.add_si_unit(self.file, unit_type="LENGTHUNIT"),
            ifcopenshell.api.unit.add_si_unit(self.file, unit_type="AREAUNIT"),
            ifcopenshell.api.unit.add_si_unit(self.file, unit_type="VOLUMEUNIT"),
            ifcopenshell.api.unit.add_si_unit(self.file, unit_type="MASSUNIT", prefix="KILO"),
            ifcopenshell.api.unit.add_si_unit(self.file, unit_type="PLANEANGLEUNIT"),
        ]
        ifcopenshell.api.unit.assign_unit(self.file, units=units)
        model = ifcopenshell.api.context.add_context(self.file, context_type="Model")
        self.body = ifcopenshell.api.context.add_context(
            self.file, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model
        )
        self.site = self.entity("IfcSite", site_name)
        self.building = self.entity("IfcBuilding", f"{project_name} building")
        ifcopenshell.api.aggregate.assign_object(self.file, products=[self.site], relating_object=self.project)
        ifcopenshell.api.aggregate.assign_object(self.file, products=[self.building], relating_object=self.site)
        for spatial in (self.site, self.building):
            ifcopenshell.api.geometry.edit_object_placement(self.file, product=spatial, matrix=np.eye(4))
        self.steel = ifcopenshell.api.material.add_material(self.file, name="Steel S355", category="steel")
        self.concrete = ifcopenshell.api.material.add_material(self.file, name="Concrete C30/37", category="concrete")

    def entity(self, ifc_class: str, name: str, predefined_type: str | None = None, global_id: str | None = None):
        """Create a rooted entity whose GlobalId is ``global_id`` or else derived from its (unique) name."""
        if name in self._names:
            raise ValueError(f"duplicate example element name {name!r}")
        self._names.add(name)
        product = ifcopenshell.api.root.create_entity(
            self.file, ifc_class=ifc_class, name=name, predefined_type=predefined_type
        )
        if global_id is None:
            product.GlobalId = self.stable_id(name)
        else:
            product.GlobalId = global_id
            self._stable_ids.add(global_id)
        return product

    def stable_id(self, name: str) -> str:
        """The GlobalId of the entity called ``name`` in this file: the same on every run (a UUID 5 of the
        name), so two runs write the same file."""
        global_id = ifcopenshell.guid.compress(uuid.uuid5(_GUID_NAMESPACE, name).hex)
        self._stable_ids.add(global_id)
        return global_id

    def _settle_global_ids(self) -> None:
        """Make the file the same on every run: every rooted entity that ifcopenshell.api keyed at random
        (relations, property and quantity sets) gets a GlobalId derived from the project, its class and its
        rank among that class's such entities in creation order, and relations list their members by step id."""
        ranks: dict[str, int] = {}
        for entity in sorted(self.file.by_type("IfcRoot"), key=lambda e: e.id()):
            if entity.GlobalId in self._stable_ids:
                continue
            rank = ranks.get(entity.is_a(), 0)
            ranks[entity.is_a()] = rank + 1
            key = f"{self._key}/{entity.is_a()}/{rank}"
            entity.GlobalId = ifcopenshell.guid.compress(uuid.uuid5(_GUID_NAMESPACE, key).hex)
        # ifcopenshell.api fills a relation's members from a Python set, whose order changes between runs;
        # these are unordered SETs in IFC (IfcRelNests' list is ordered and left alone)
        for relation in self.file.by_type("IfcRelationship"):
            if relation.is_a("IfcRelNests"):
                continue
            for attribute in ("RelatedObjects", "RelatedElements"):
                members = getattr(relation, attribute, None)
                if members and len(members) > 1:
                    setattr(relation, attribute, sorted(members, key=lambda member: member.id()))
        for assignment in self.file.by_type("IfcUnitAssignment"):
            assignment.Units = sorted(assignment.Units, key=lambda unit: unit.id())

    def storey(self, name: str, elevation: float):
        """An IfcBuildingStorey at ``elevation`` metres."""
        storey = self.entity("IfcBuildingStorey", name)
        storey.Elevation = elevation
        ifcopenshell.api.aggregate.assign_object(self.file, products=[storey], relating_object=self.building)
        placement = np.eye(4)
        placement[2, 3] = elevation
        ifcopenshell.api.geometry.edit_object_placement(self.file, product=storey, matrix=placement)
        return storey

    def place(self, product, storey, matrix: np.ndarray, material) -> None:
        """Contain ``product`` in ``storey`` at the world ``matrix`` (4x4, metres) and give it a material."""
        ifcopenshell.api.spatial.assign_container(self.file, products=[product], relating_structure=storey)
        ifcopenshell.api.geometry.edit_object_placement(self.file, product=product, matrix=matrix)
        ifcopenshell.api.material.assign_material(self.file, products=[product], type="IfcMaterial", material=material)

    def extrusion(self, product, profile, depth: float, along_x: bool = False) -> None:
        """Body: ``profile`` extruded ``depth`` metres along local z (or local x for beams)."""
        axes = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)) if along_x else (None, None)
        representation = ifcopenshell.api.geometry.add_profile_representation(
            self.file, context=self.body, profile=profile, depth=depth, placement_zx_axes=axes
        )
        ifcopenshell.api.geometry.assign_representation(self.file, product=product, representation=representation)

    def i_profile(self, section: ISection):
        profile = self.file.create_entity(
            "IfcIShapeProfileDef",
            ProfileType="AREA",
            ProfileName=section.name,
            OverallWidth=section.width,
            OverallDepth=section.depth,
            WebThickness=section.web,
            FlangeThickness=section.flange,
            FilletRadius=section.fillet,
        )
        return profile

    def rectangle(self, x: float, y: float):
        return self.file.create_entity("IfcRectangleProfileDef", ProfileType="AREA", XDim=x, YDim=y)

    def circle(self, radius: float):
        return self.file.create_entity("IfcCircleProfileDef", ProfileType="AREA", Radius=radius)

    def angle(self, leg_y: float, leg_x: float, thickness: float):
        return self.file.create_entity(
            "IfcLShapeProfileDef", ProfileType="AREA", ProfileName=f"L{leg_y*1000:.0f}x{leg_x*1000:.0f}x{thickness*1000:.1f}",
            Depth=leg_y, Width=leg_x, Thickness=thickness,
        )

    def weight(self, product, qto_name: str, kg: float, **extra: float) -> None:
        """Attach ``NetWeight`` (an IfcQuantityWeight, kg) and any other quantities to ``product``."""
        qto = ifcopenshell.api.pset.add_qto(self.file, product=product, name=qto_name)
        ifcopenshell.api.pset.edit_qto(self.file, qto=qto, properties={"NetWeight": round(kg, 3), **extra})

    def common(self, product, pset_name: str, **properties) -> None:
        pset = ifcopenshell.api.pset.add_pset(self.file, product=product, name=pset_name)
        ifcopenshell.api.pset.edit_pset(self.file, pset=pset, properties=properties)

    def connect(self, name: str, relating, related, realizing: list, connection_type: str = "BOLTED"):
        """An IfcRelConnectsWithRealizingElements: ``relating`` supports ``related`` through ``realizing``."""
        relation = self.file.create_entity(
            "IfcRelConnectsWithRealizingElements",
            GlobalId=self.stable_id(f"rel:{name}"),
            Name=name,
            RelatingElement=relating,
            RelatedElement=related,
            RealizingElements=realizing,
            ConnectionType=connection_type,
        )
        return relation

    def write(self, path: str | Path, what: str) -> Path:
        """Write the file atomically through bimrobot's output policy (a file bimrobot wrote is replaced,
        any other existing file is refused). The header's originating system carries the signature that
        lets a later run recognise the file as bimrobot's."""
        self._settle_global_ids()
        header = self.file.header.file_name
        header.name = Path(path).name
        header.originating_system = io.signature(f"example {what}")
        header.preprocessor_version = f"IfcOpenShell {ifcopenshell.version}"
        header.author = ("bimrobot",)
        header.organization = ("",)
        header.authorization = ""
        with io.atomic_output_file(path) as tmp:
            self.file.write(str(tmp))
        return Path(path)


def _frame(origin, x_axis, z_axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    """4x4 matrix with the given origin, x axis and z axis (y = z cross x)."""
    x = np.asarray(x_axis, dtype=float)
    z = np.asarray(z_axis, dtype=float)
    x /= np.linalg.norm(x)
    z /= np.linalg.norm(z)
    matrix = np.eye(4)
    matrix[:3, 0] = x
    matrix[:3, 1] = np.cross(z, x)
    matrix[:3, 2] = z
    matrix[:3, 3] = origin
    return matrix


def _translation(x: float, y: float, z: float) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, 3] = (x, y, z)
    return matrix


def _bolt(author: _Author, name: str, storey, matrix: np.ndarray, length: float):
    """An M20 bolt along the local z of ``matrix`` (starting at its origin), with its steel weight."""
    bolt = author.entity("IfcMechanicalFastener", name, predefined_type="BOLT")
    bolt.NominalDiameter = BOLT_DIAMETER
    bolt.NominalLength = length
    author.place(bolt, storey, matrix, author.steel)
    author.extrusion(bolt, author.circle(BOLT_DIAMETER / 2), length)
    kg = math.pi * (BOLT_DIAMETER / 2) ** 2 * length * STEEL_DENSITY
    author.weight(bolt, "Qto_MechanicalFastenerBaseQuantities", kg)
    return bolt


def _footing(author: _Author, name: str, storey, x: float, y: float, size: tuple[float, float, float]):
    """A concrete pad footing whose top face is at z = 0, centred on (x, y)."""
    footing = author.entity("IfcFooting", name, predefined_type="PAD_FOOTING")
    author.place(footing, storey, _translation(x, y, -size[2]), author.concrete)
    author.extrusion(footing, author.rectangle(size[0], size[1]), size[2])
    volume = size[0] * size[1] * size[2]
    author.weight(footing, "Qto_FootingBaseQuantities", volume * CONCRETE_DENSITY, NetVolume=volume)
    author.common(footing, "Pset_FootingCommon", LoadBearing=True)
    return footing


def _column(author: _Author, name: str, storey, x: float, y: float, z: float, section: ISection, length: float, kg: float):
    column = author.entity("IfcColumn", name, predefined_type="COLUMN")
    author.place(column, storey, _translation(x, y, z), author.steel)
    author.extrusion(column, author.i_profile(section), length)
    author.weight(column, "Qto_ColumnBaseQuantities", kg, Length=length)
    author.common(column, "Pset_ColumnCommon", Reference=section.name, LoadBearing=True, IsExternal=True)
    return column


def _beam(author: _Author, name: str, storey, start, direction, section: ISection, length: float, kg: float):
    """A beam whose local x runs along ``direction`` from ``start`` (the centre of its end section)."""
    beam = author.entity("IfcBeam", name, predefined_type="BEAM")
    author.place(beam, storey, _frame(start, direction), author.steel)
    author.extrusion(beam, author.i_profile(section), length, along_x=True)
    author.weight(beam, "Qto_BeamBaseQuantities", kg, Length=length)
    author.common(beam, "Pset_BeamCommon", Reference=section.name, LoadBearing=True, Span=length)
    return beam


#: Most bolts per connection node ``steel_frame(bolts_per_node=...)`` accepts (they must fit a clip angle).
