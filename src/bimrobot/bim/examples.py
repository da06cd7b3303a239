"""Built-in example buildings, authored with ``ifcopenshell.api`` so that demos and tests need no file.

Both are IFC4 files in metres and kilograms, z up, with real steel sections (``IfcIShapeProfileDef``)
and deterministic GlobalIds (the same file content on every run).

``steel_frame(path)``: the thesis' chapter-4 frame (section 4.3). Four concrete pad footings, four
W250x73 columns (4000 mm, 289.81 kg) standing on base plates, four W310x38.7 beams spanning 2846 mm
(105.49 kg) and 3500 mm (134.39 kg) between column centres at the top of the columns, one clip angle at
each beam end. Every joint is an ``IfcRelConnectsWithRealizingElements`` with ConnectionType "BOLTED"
whose realizing elements are its bolts (``IfcMechanicalFastener``): footing -> base plate (4 anchor
bolts), base plate -> column (4 bolts), column -> clip angle (2 bolts), clip angle -> beam (2 bolts).
The relating element always supports the related one, so the relations read as an assembly order.
Weights are ``IfcQuantityWeight`` (``Qto_*BaseQuantities.NetWeight``): the thesis' Revit values for
columns and beams, volume x density (steel 7850, concrete 2400 kg/m3) for the rest. Storey "Level 1"
(elevation 0.0 m, the column bases) holds footings, plates, columns and their bolts; "Level 2"
(4.025 m, the column tops) holds beams, clip angles and their bolts.

``greenhouse(path)``: chapter 3's light steel frame (section 3.4.1): 9 pad foundations on a 3 x 3 grid
(3 m bays), 9 HEA100 columns 2.5 m high, 10 IPE120 beams: 6 eaves beams along x on the column tops and
4 beams along y on top of them at the two gable ends. It has weights but no realizing-element
connections (the thesis' Revit model had none); use
:func:`bimrobot.bim.connections.infer_connections` to find its joints from touching geometry.
"""

from __future__ import annotations

import functools
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
import ifcopenshell.api.type
import ifcopenshell.api.unit
import ifcopenshell.guid
import ifcopenshell.util.placement

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

    def entity(self, ifc_class: str, name: str, predefined_type: str | None = None):
        """Create a rooted entity whose GlobalId is derived from its (unique) name."""
        if name in self._names:
            raise ValueError(f"duplicate example element name {name!r}")
        self._names.add(name)
        product = ifcopenshell.api.root.create_entity(
            self.file, ifc_class=ifc_class, name=name, predefined_type=predefined_type
        )
        product.GlobalId = ifcopenshell.guid.compress(uuid.uuid5(_GUID_NAMESPACE, name).hex)
        return product

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
            GlobalId=ifcopenshell.guid.compress(uuid.uuid5(_GUID_NAMESPACE, f"rel:{name}").hex),
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
MAX_BOLTS_PER_NODE = 12


def steel_frame(path: str | Path, bolts_per_node: int | None = None) -> Path:
    """Write the thesis' chapter-4 steel frame to ``path`` (IFC4, metres) and return the path.

    ``bolts_per_node``: None (default) gives the frame as detailed above (4 anchor bolts per footing, 4
    per column foot, 2 per clip angle side). A number N (1 to 12) gives the thesis' Table 4.2 variant
    (l.3870-3876: six bolts at every node of a column or beam): N bolts at each column foot (base plate
    -> column), N at each column top (column -> clip angle) and N at each beam end (clip angle -> beam),
    none at the footings: the base plates stand on anchors cast into the footings, work of others, so
    no relation joins a footing (footings carry no robot work, thesis l.4709). With N = 6 the frame has
    the 20 nodes and 120 assembly points of Table 4.2.
    """
    from bimrobot.core.errors import InputError

    if bolts_per_node is not None and (
        isinstance(bolts_per_node, bool) or not isinstance(bolts_per_node, int)
        or not 1 <= bolts_per_node <= MAX_BOLTS_PER_NODE
    ):
        raise InputError(f"bolts per node must be a whole number from 1 to {MAX_BOLTS_PER_NODE}, got {bolts_per_node!r}")
    author = _Author("Chapter 4 steel frame", "Construction site")
    level_1 = author.storey("Level 1", 0.0)
    plate_thickness = BASE_PLATE_SIZE[2]
    column_base = plate_thickness
    column_top = column_base + COLUMN_LENGTH
    level_2 = author.storey("Level 2", column_top)
    beam_axis_z = column_top - W310X38_7.depth / 2

    corners = [(0.0, 0.0), (FRAME_SPAN_X, 0.0), (FRAME_SPAN_X, FRAME_SPAN_Y), (0.0, FRAME_SPAN_Y)]
    columns = []
    for index, (x, y) in enumerate(corners, start=1):
        footing = _footing(author, f"Footing F{index}", level_1, x, y, FOOTING_SIZE)
        plate = author.entity("IfcPlate", f"Base plate P{index}", predefined_type="BASE_PLATE")
        author.place(plate, level_1, _translation(x, y, 0.0), author.steel)
        author.extrusion(plate, author.rectangle(BASE_PLATE_SIZE[0], BASE_PLATE_SIZE[1]), plate_thickness)
        plate_volume = BASE_PLATE_SIZE[0] * BASE_PLATE_SIZE[1] * plate_thickness
        author.weight(plate, "Qto_PlateBaseQuantities", plate_volume * STEEL_DENSITY)
        column = _column(author, f"Column C{index}", level_1, x, y, column_base, W250X73, COLUMN_LENGTH, COLUMN_WEIGHT)
        columns.append(column)

        inner = W250X73.depth / 2 - W250X73.flange - BOLT_DIAMETER / 2 - 0.0003
        if bolts_per_node is None:
            # Anchor bolts through the plate corners into the footing.
            anchors = [
                _bolt(author, f"Anchor bolt P{index}-{k}", level_1, _translation(x + dx, y + dy, -0.32), 0.40)
                for k, (dx, dy) in enumerate([(-0.15, -0.15), (0.15, -0.15), (0.15, 0.15), (-0.15, 0.15)], start=1)
            ]
            author.connect(f"F{index}-P{index}", footing, plate, anchors)
            # Column bolts through the plate, just inside the column flanges.
            offsets = [(-0.06, -inner), (0.06, -inner), (0.06, inner), (-0.06, inner)]
        else:
            offsets = [(dx, dy) for dx, dy in _two_rows(bolts_per_node, -0.09, 0.09, -inner, inner)]
        column_bolts = [
            _bolt(author, f"Column bolt C{index}-{k}", level_1, _translation(x + dx, y + dy, -0.005), 0.10)
            for k, (dx, dy) in enumerate(offsets, start=1)
        ]
        author.connect(f"P{index}-C{index}", plate, column, column_bolts)

    # Beams between neighbouring columns: (start corner, end corner).
    for start_index, end_index in [(0, 1), (1, 2), (3, 2), (0, 3)]:
        start_xy = np.array(corners[start_index])
        end_xy = np.array(corners[end_index])
        span = float(np.linalg.norm(end_xy - start_xy))
        direction = np.r_[(end_xy - start_xy) / span, 0.0]
        along_x = abs(direction[0]) > 0.5
        # Beams along x frame into the column web, beams along y into the flange face.
        face = W250X73.web / 2 if along_x else W250X73.depth / 2
        length = span - 2 * (face + BEAM_END_GAP)
        start = np.r_[start_xy, beam_axis_z] + direction * (face + BEAM_END_GAP)
        kg = BEAM_WEIGHTS[round(span, 3)]
        label = f"B{start_index + 1}{end_index + 1}"
        beam = _beam(author, f"Beam {label}", level_2, start, direction, W310X38_7, length, kg)
        for end, column_index, into_beam in [("a", start_index, direction), ("b", end_index, -direction)]:
            joint_origin = np.r_[corners[column_index], 0.0] + into_beam * face
            _clip_angle_joint(author, f"{label}{end}", level_2, columns[column_index], beam,
                              _frame(joint_origin, into_beam), beam_axis_z, bolts_per_node)
    return author.write(path, "steel-frame" if bolts_per_node is None else f"steel-frame, {bolts_per_node} bolts per node")


#: The thesis' RCAN experiments (section 5.3.3): the component's GlobalId (the column's is the one the
#: thesis prints), IFC class, section (m), length (m), mass (kg), where it waits on the yard and where it
#: is installed (the gripper's goal at its centre; m, world frame). The column is a light-weight scale
#: member (aluminium, 2700 kg/m3: 40 x 40 mm x 0.46 m = 2.0 kg, within the UR5's 5 kg payload); the
#: footing a small concrete pad (100 x 100 x 150 mm x 2400 kg/m3 = 3.6 kg).
RCAN_EXPERIMENTS = {
    1: ("column within the manipulator's reach", "267VPu8ab9991QBA3MI3UN", "IfcColumn", (0.04, 0.04), 0.46, 2.0,
        (0.0, -0.75, 0.45), (0.55, -0.35, 0.30)),
    2: ("column that needs transport", "267VPu8ab9991QBA3MI3UN", "IfcColumn", (0.04, 0.04), 0.46, 2.0,
        (0.0, -0.75, 0.45), (4.0, 2.0, 0.30)),
    3: ("footing that needs transport", "1kTvXnbbzCWw8lcMd1dR4o", "IfcFooting", (0.10, 0.10), 0.15, 3.6,
        (0.0, -0.75, 0.10), (4.0, -2.0, 0.0)),
}


def rcan_experiment(number: int, path: str | Path) -> Path:
    """Write the model of the thesis' RCAN experiment ``number`` (1, 2 or 3; :data:`RCAN_EXPERIMENTS`) to
    ``path``: one storey with the experiment's component installed, its centre at the gripper's goal
    (the placement origin is the centre of its bottom face), with its weight as an IfcQuantityWeight."""
    _, global_id, ifc_class, section, length, kg, _, installed = RCAN_EXPERIMENTS[number]
    author = _Author(f"RCAN experiment {number}", "Test site")
    storey = author.storey("Ground floor", 0.0)
    name = "Scale column" if ifc_class == "IfcColumn" else "Scale footing"
    product = author.entity(ifc_class, name, predefined_type="COLUMN" if ifc_class == "IfcColumn" else "PAD_FOOTING")
    product.GlobalId = global_id
    material = author.steel if ifc_class == "IfcColumn" else author.concrete
    if ifc_class == "IfcColumn":
        material = ifcopenshell.api.material.add_material(author.file, name="Aluminium 6061", category="aluminium")
    author.place(product, storey, _translation(installed[0], installed[1], installed[2] - length / 2), material)
    author.extrusion(product, author.rectangle(*section), length)
    qto = "Qto_ColumnBaseQuantities" if ifc_class == "IfcColumn" else "Qto_FootingBaseQuantities"
    author.weight(product, qto, kg, NetVolume=section[0] * section[1] * length)
    return author.write(path, f"rcan-experiment-{number}")


def _two_rows(count: int, low: float, high: float, row_a: float, row_b: float) -> list[tuple[float, float]]:
    """``count`` bolt positions (metres) in two rows (``row_a``, ``row_b``), spread from ``low`` to ``high``."""
    per_row = (count + 1) // 2
    along = np.linspace(low, high, per_row) if per_row > 1 else np.array([(low + high) / 2])
    positions = [(float(a), row_a) for a in along] + [(float(a), row_b) for a in along]
    return positions[:count]


def _clip_angle_joint(author: _Author, label: str, storey, column, beam, joint: np.ndarray, beam_axis_z: float,
                      bolts_per_node: int | None = None) -> None:
    """One clip angle bolting a beam end to a column face.

    ``joint``: frame on the column face at z = 0, x pointing into the beam, y horizontal, z up. The angle's
    heel sits on the face beside the beam web; one leg lies on the column face, the other on the web.
    ``bolts_per_node``: bolts through each leg (default 2, in one row).
    """
    leg_y, leg_x, thickness, length = CLIP_ANGLE
    half_web = W310X38_7.web / 2
    angle = author.entity("IfcMember", f"Clip angle {label}", predefined_type="USERDEFINED")
    angle.ObjectType = "CLIP_ANGLE"
    # IfcLShapeProfileDef is centred on its bounding box; its heel is at (-Width/2, -Depth/2).
    local = _translation(leg_x / 2, half_web + leg_y / 2, beam_axis_z - length / 2)
    author.place(angle, storey, joint @ local, author.steel)
    author.extrusion(angle, author.angle(leg_y, leg_x, thickness), length)
    area = (leg_x + leg_y - thickness) * thickness
    author.weight(angle, "Qto_MemberBaseQuantities", area * length * STEEL_DENSITY, Length=length)

    column_bolts = []
    beam_bolts = []
    if bolts_per_node is None:
        layout = [(dz, 0.055, 0.06) for dz in (-0.05, 0.05)]  # (height, offset on the column leg, on the web leg)
    else:
        layout = [(dz, 0.035 if row < 0 else 0.070, 0.040 if row < 0 else 0.070)
                  for dz, row in _two_rows(bolts_per_node, -0.08, 0.08, -1.0, 1.0)]
    for k, (dz, on_column_leg, on_web_leg) in enumerate(layout, start=1):
        # Through the angle leg and the column web/flange, along joint x.
        to_column = _frame((-0.02, half_web + on_column_leg, beam_axis_z + dz), (0, 1, 0), (1, 0, 0))
        column_bolts.append(_bolt(author, f"Clip bolt {label}-C{k}", storey, joint @ to_column, 0.05))
        # Through the beam web and the other angle leg, along joint y.
        to_beam = _frame((on_web_leg, -0.01, beam_axis_z + dz), (1, 0, 0), (0, 1, 0))
        beam_bolts.append(_bolt(author, f"Clip bolt {label}-B{k}", storey, joint @ to_beam, 0.04))
    author.connect(f"{label}-column", column, angle, column_bolts)
    author.connect(f"{label}-beam", angle, beam, beam_bolts)


def greenhouse(path: str | Path) -> Path:
    """Write chapter 3's light steel greenhouse frame to ``path`` (IFC4, metres) and return the path."""
    author = _Author("Chapter 3 light steel frame", "Greenhouse site")
    ground = author.storey("Foundation", 0.0)
    eaves = author.storey("Eaves", GREENHOUSE_COLUMN_HEIGHT)
    bay = GREENHOUSE_BAY
    for i in range(3):
        for j in range(3):
            label = f"{'ABC'[j]}{i + 1}"
            x, y = i * bay, j * bay
            _footing(author, f"Foundation {label}", ground, x, y, GREENHOUSE_FOUNDATION)
            kg = HEA100.mass_per_m * GREENHOUSE_COLUMN_HEIGHT
            _column(author, f"Column {label}", ground, x, y, 0.0, HEA100, GREENHOUSE_COLUMN_HEIGHT, kg)
    eaves_z = GREENHOUSE_COLUMN_HEIGHT + IPE120.depth / 2
    for j in range(3):  # eaves beams along x, resting on the column tops
        for i in range(2):
            start = (i * bay, j * bay, eaves_z)
            name = f"Eaves beam {'ABC'[j]}{i + 1}-{'ABC'[j]}{i + 2}"
            _beam(author, name, eaves, start, (1, 0, 0), IPE120, bay, IPE120.mass_per_m * bay)
    for i in (0, 2):  # gable beams along y, resting on the eaves beams
        for j in range(2):
            start = (i * bay, j * bay, eaves_z + IPE120.depth)
            name = f"Gable beam {'ABC'[j]}{i + 1}-{'ABC'[j + 1]}{i + 1}"
            _beam(author, name, eaves, start, (0, 1, 0), IPE120, bay, IPE120.mass_per_m * bay)
    return author.write(path, "greenhouse")


EXAMPLES = {"steel-frame": steel_frame, "greenhouse": greenhouse,
            **{f"rcan-experiment-{n}": functools.partial(rcan_experiment, n) for n in RCAN_EXPERIMENTS}}


# --------------------------------------------------------------------------------------------------
# Generated buildings (issue 38): steel frames, precast column-beam-slab frames and panel buildings of
# any size, written with ifcopenshell.api so that every command reads them like a user's model. The
# shape is drawn (seeded) by bimrobot.planning.generator; this part only writes it.
# --------------------------------------------------------------------------------------------------

#: The kinds of generated building (:class:`Layout`).
BUILDING_KINDS = ("steel", "precast", "panel")

HOLLOW_CORE_KG_PER_M2 = 280.0  # 200 mm hollow-core plank (HC200), kg per m2 of floor
PRECAST_COLUMN = (0.40, 0.40)  # m, section
PRECAST_BEAM = (0.40, 0.60)  # m, width x depth (rectangular beam carrying the planks on its top)
PANEL_THICKNESS = 0.20  # m, solid precast wall panel
PANEL_SLAB = 0.20  # m, solid precast floor slab
PLANK_THICKNESS = 0.20  # m
JOINT_GAP = 0.02  # m, grout or clearance between precast units
SPLICE_PLATE = (0.40, 0.40, 0.02)  # m, steel column splice / base plate
STEEL_CLIP = (0.20, 0.10, 0.20)  # m, clip-angle body as a box: along the beam, across, height


@dataclass(frozen=True)
class Layout:
    """The shape of a generated building (metres, kg, z up; floors stacked at ``storey_height``).

    ``kind``: ``steel`` (W columns and beams, splice or base plate under every column, a clip angle at
    every beam end, ``bolts_per_node`` bolts at every connection node), ``precast`` (column, beam and
    hollow-core plank units, each an IfcElementAssembly, joined by ``bolts_per_node`` dowels or weld
    plates) or ``panel`` (wall panels on every bay side and one floor slab per bay, each an
    IfcElementAssembly, joined by ``bolts_per_node`` dowels or welds).
    ``nx`` x ``ny``: column grid lines (steel, precast) or bays (panel). ``bay_x``, ``bay_y``: grid
    spacing (m). ``column``, ``beam``: steel sections (ignored by the concrete kinds).
    """

    kind: str
    nx: int
    ny: int
    floors: int
    bay_x: float
    bay_y: float
    storey_height: float
    bolts_per_node: int
    column: ISection = W250X73
    beam: ISection = W310X38_7
    name: str = "generated building"

    def components(self) -> int:
        """Robot-built components: the columns, beams, slabs and wall panels :func:`generated_building` writes."""
        return building_components(self.kind, self.nx, self.ny, self.floors)


def building_components(kind: str, nx: int, ny: int, floors: int) -> int:
    """Robot-built components of a ``kind`` building of ``nx`` x ``ny`` grid lines (bays for ``panel``)
    and ``floors`` floors: steel columns and beams; precast columns, beams and planks; panels and slabs."""
    if kind == "steel":
        return floors * (nx * ny + (nx - 1) * ny + nx * (ny - 1))
    if kind == "precast":
        return floors * (nx * ny + (nx - 1) * ny + (nx - 1) * (ny - 1))
    return floors * ((nx + 1) * ny + nx * (ny + 1) + nx * ny)


class _Typed:
    """Shared bodies: one IfcTypeObject per distinct shape, holding its representation and its weight
    (``NetWeight`` in the type's quantity set), so that a building of 10,000 components carries a few
    dozen bodies and the geometry pass reads each once. Each occurrence gets its own Body representation
    made of the type's one IfcMappedItem (identity transform); types are assigned in one batch per type."""

    def __init__(self, author: _Author):
        self.author = author
        self.types: dict[str, object] = {}
        self.items: dict[str, object] = {}
        self.members: dict[str, list] = {}

    def add(self, product, key: str, type_class: str, profile_fn, depth: float, kg: float, qto: str,
            along_x: bool = False) -> None:
        """Give ``product`` the body ``key``: ``profile_fn()`` extruded ``depth`` m, weighing ``kg``."""
        file = self.author.file
        if key not in self.types:
            author = self.author
            kind = ifcopenshell.api.root.create_entity(file, ifc_class=type_class, name=key)
            kind.GlobalId = ifcopenshell.guid.compress(uuid.uuid5(_GUID_NAMESPACE, f"type:{key}").hex)
            axes = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)) if along_x else (None, None)
            representation = ifcopenshell.api.geometry.add_profile_representation(
                file, context=author.body, profile=profile_fn(), depth=depth, placement_zx_axes=axes)
            ifcopenshell.api.geometry.assign_representation(file, product=kind, representation=representation)
            author.weight(kind, qto, kg)
            origin = file.create_entity("IfcCartesianPoint", Coordinates=(0.0, 0.0, 0.0))
            operator = file.create_entity("IfcCartesianTransformationOperator3D", LocalOrigin=origin)
            self.items[key] = file.create_entity("IfcMappedItem", MappingSource=kind.RepresentationMaps[0],
                                                 MappingTarget=operator)
            self.types[key] = kind
            self.members[key] = []
        body = file.create_entity("IfcShapeRepresentation", ContextOfItems=self.author.body, RepresentationIdentifier="Body",
                                  RepresentationType="MappedRepresentation", Items=[self.items[key]])
        product.Representation = file.create_entity("IfcProductDefinitionShape", Representations=[body])
        self.members[key].append(product)

    def assign(self) -> None:
        for key, kind in self.types.items():
            ifcopenshell.api.type.assign_type(self.author.file, related_objects=self.members[key], relating_type=kind,
                                              should_map_representations=False)


class _Builder:
    """Writes one generated building. The project, units, storeys, types, bodies, quantities, containment,
    aggregation, materials and type assignments go through ifcopenshell.api (the last four in one batch
    per storey, assembly, material or type); the many occurrences, their placements and their fasteners
    are created directly (``file.create_entity``), as ifcopenshell.api's per-product calls take 5-10 ms
    each and a 10,000-component building has some 40,000 products and 100,000 fasteners."""

    def __init__(self, layout: Layout):
        self.layout = layout
        self.author = _Author(layout.name, "Generated site")
        self.typed = _Typed(self.author)
        self.storeys = [self.author.storey(f"Level {k + 1}", k * layout.storey_height) for k in range(layout.floors + 1)]
        self.contained: dict[int, list] = {}
        self.parts: list[tuple[object, list]] = []
        self.placed: list[tuple[object, object, np.ndarray]] = []  # product, parent placement holder, world matrix
        self.materials: dict[int, list] = {}
        self.counter = 0

    def _id(self, name: str) -> str:
        return ifcopenshell.guid.compress(uuid.uuid5(_GUID_NAMESPACE, name).hex)

    def product(self, ifc_class: str, name: str, storey: int | None, matrix: np.ndarray, material,
                predefined_type: str | None = None, parent=None):
        """A new product at the world ``matrix``: contained in ``storey``, or a part of ``parent``."""
        product = self.author.file.create_entity(ifc_class, GlobalId=self._id(name), Name=name)
        if predefined_type is not None:
            product.PredefinedType = predefined_type
        if storey is not None:
            self.contained.setdefault(storey, []).append(product)
        self.placed.append((product, self.storeys[storey] if parent is None else parent, matrix))
        if material is not None:
            self.materials.setdefault(material.id(), [material]).append(product)
        return product

    def unit(self, ifc_class: str, name: str, storey: int, matrix: np.ndarray, material, predefined_type: str):
        """(assembly, part): an IfcElementAssembly (a precast unit lifted as one) and its concrete part
        ``ifc_class``, both at the world ``matrix``; the part's body is given by the caller."""
        assembly = self.product("IfcElementAssembly", f"{name} unit", storey, matrix, None, predefined_type="USERDEFINED")
        assembly.ObjectType = "PRECAST_UNIT"
        part = self.product(ifc_class, name, None, matrix, material, predefined_type=predefined_type, parent=assembly)
        self.parts.append((assembly, [part]))
        return part

    def connect(self, relating, related, storey: int, fastener: str, connection_type: str) -> None:
        """``relating`` supports ``related`` through ``bolts_per_node`` fasteners (no bodies of their own)."""
        file = self.author.file
        fasteners = []
        ifc_class = "IfcMechanicalFastener" if connection_type == "BOLTED" else "IfcFastener"
        for _ in range(self.layout.bolts_per_node):
            self.counter += 1
            fasteners.append(file.create_entity(ifc_class, GlobalId=self._id(f"fastener:{self.counter}"),
                                                Name=f"{fastener} {self.counter}"))
        self.contained.setdefault(storey, []).extend(fasteners)
        name = f"{relating.Name} - {related.Name}"
        file.create_entity(
            "IfcRelConnectsWithRealizingElements", GlobalId=self._id(f"rel:{name}"),
            Name=name, RelatingElement=relating, RelatedElement=related, RealizingElements=fasteners,
            ConnectionType=connection_type,
        )

    def write(self, path: str | Path) -> Path:
        file = self.author.file
        for storey, products in self.contained.items():  # before any placement: nothing to re-localise
            ifcopenshell.api.spatial.assign_container(file, products=products, relating_structure=self.storeys[storey])
        for assembly, parts in self.parts:
            ifcopenshell.api.aggregate.assign_object(file, products=parts, relating_object=assembly)
        world = {s.id(): np.linalg.inv(ifcopenshell.util.placement.get_local_placement(s.ObjectPlacement))
                 for s in self.storeys}
        for product, parent, matrix in self.placed:  # parents come first: storeys, then units, then parts
            inverse = world[parent.id()]  # world -> parent frame
            world[product.id()] = np.linalg.inv(matrix)
            relative = inverse @ matrix
            product.ObjectPlacement = file.create_entity(
                "IfcLocalPlacement", PlacementRelTo=parent.ObjectPlacement, RelativePlacement=_axis2placement(file, relative))
        for material, *products in self.materials.values():
            ifcopenshell.api.material.assign_material(file, products=products, type="IfcMaterial", material=material)
        self.typed.assign()
        layout = self.layout
        return self.author.write(path, f"generated {layout.kind} {layout.nx}x{layout.ny}x{layout.floors}")


def _axis2placement(file, matrix: np.ndarray):
    """An IfcAxis2Placement3D of the 4x4 ``matrix`` (metres): origin, z axis, x axis."""
    def direction(v) -> object:
        return file.create_entity("IfcDirection", DirectionRatios=tuple(float(round(c, 12)) for c in v))

    origin = file.create_entity("IfcCartesianPoint", Coordinates=tuple(float(round(c, 9)) for c in matrix[:3, 3]))
    return file.create_entity("IfcAxis2Placement3D", Location=origin, Axis=direction(matrix[:3, 2]),
                              RefDirection=direction(matrix[:3, 0]))


def generated_building(path: str | Path, layout: Layout) -> Path:
    """Write the building of ``layout`` to ``path`` (IFC4, metres, kg) and return the path.

    Storey k ("Level k+1", elevation k x ``storey_height``) holds the columns or wall panels of floor k;
    the beams and slabs at the top of floor k belong to the storey above (as Revit and Tekla export).
    Every joint is an IfcRelConnectsWithRealizingElements whose relating element supports the related
    one; its fasteners are IfcMechanicalFastener (bolts, dowels) or IfcFastener (welds) without bodies.
    """
    from bimrobot.core.errors import InputError

    if layout.kind not in BUILDING_KINDS:
        raise InputError(f"building kind must be one of {', '.join(BUILDING_KINDS)}, got {layout.kind!r}")
    builder = _Builder(layout)
    {"steel": _steel_building, "precast": _precast_building, "panel": _panel_building}[layout.kind](builder)
    return builder.write(path)


def _steel_building(b: _Builder) -> None:
    """Columns on plates (base plates on floor 0, splice plates on the column below), beams between
    neighbouring columns at the top of each floor on clip angles: component -> connector relations, as
    the built-in frame's (``column -> plate``, ``lower column -> plate``, ``column -> clip``, ``beam -> clip``)."""
    lay, author, typed = b.layout, b.author, b.typed
    col, beam_section = lay.column, lay.beam
    plate_t = SPLICE_PLATE[2]
    col_len = lay.storey_height - plate_t
    half = col.depth / 2
    grid = [(i, j, i * lay.bay_x, j * lay.bay_y) for i in range(lay.nx) for j in range(lay.ny)]
    columns: dict[tuple[int, int, int], object] = {}
    for k in range(lay.floors):
        z0, z1 = k * lay.storey_height, (k + 1) * lay.storey_height
        for i, j, x, y in grid:
            if k == 0:  # a concrete pad, top face at z = 0: work of others (prebuilt), joined to nothing
                footing = b.product("IfcFooting", f"Footing {i}-{j}", 0, _translation(x, y, -FOOTING_SIZE[2]),
                                    author.concrete, predefined_type="PAD_FOOTING")
                _box_body(typed, author, footing, "Pad footing 1.2x1.2x0.6", "IfcFootingType", FOOTING_SIZE,
                          FOOTING_SIZE[0] * FOOTING_SIZE[1] * FOOTING_SIZE[2] * CONCRETE_DENSITY, "Qto_FootingBaseQuantities")
            plate = b.product("IfcPlate", f"{'Base' if k == 0 else 'Splice'} plate {k}-{i}-{j}", k,
                              _translation(x, y, z0), author.steel, predefined_type="USERDEFINED")
            plate.ObjectType = "BASE_PLATE" if k == 0 else "SPLICE_PLATE"
            typed.add(plate, "Plate 400x400x20", "IfcPlateType", lambda: author.rectangle(*SPLICE_PLATE[:2]),
                      plate_t, SPLICE_PLATE[0] * SPLICE_PLATE[1] * plate_t * STEEL_DENSITY, "Qto_PlateBaseQuantities")
            column = b.product("IfcColumn", f"Column {k}-{i}-{j}", k, _translation(x, y, z0 + plate_t), author.steel,
                               predefined_type="COLUMN")
            typed.add(column, f"{col.name} column {col_len:.3f} m", "IfcColumnType", lambda: author.i_profile(col),
                      col_len, col.mass_per_m * col_len, "Qto_ColumnBaseQuantities")
            columns[k, i, j] = column
            b.connect(column, plate, k, "Bolt", "BOLTED")
            if k > 0:
                b.connect(columns[k - 1, i, j], plate, k, "Bolt", "BOLTED")
        axis_z = z1 - beam_section.depth / 2
        for i, j, x, y in grid:
            for di, dj in ((1, 0), (0, 1)):
                if i + di >= lay.nx or j + dj >= lay.ny:
                    continue
                direction = np.array([di, dj, 0.0])
                span = lay.bay_x if di else lay.bay_y
                length = round(span - 2 * (half + BEAM_END_GAP), 4)
                start = np.array([x, y, axis_z]) + direction * (half + BEAM_END_GAP)
                beam = b.product("IfcBeam", f"Beam {k}-{'xy'[dj]}-{i}-{j}", k + 1, _frame(start, direction), author.steel,
                                 predefined_type="BEAM")
                typed.add(beam, f"{beam_section.name} beam {length:.3f} m", "IfcBeamType",
                          lambda: author.i_profile(beam_section), length, beam_section.mass_per_m * length,
                          "Qto_BeamBaseQuantities", along_x=True)
                for end, (ci, cj) in enumerate(((i, j), (i + di, j + dj))):
                    into = direction if end == 0 else -direction
                    origin = np.array([ci * lay.bay_x, cj * lay.bay_y, axis_z - STEEL_CLIP[2] / 2]) + into * half
                    clip = b.product("IfcMember", f"Clip angle {k}-{'xy'[dj]}-{i}-{j}-{end}", k + 1,
                                     _frame(origin, into), author.steel, predefined_type="USERDEFINED")
                    clip.ObjectType = "CLIP_ANGLE"
                    typed.add(clip, "Clip angle L89x89x9.5", "IfcMemberType",
                              lambda: author.rectangle(STEEL_CLIP[0], STEEL_CLIP[1]), STEEL_CLIP[2],
                              (0.089 + 0.089 - 0.0095) * 0.0095 * 0.20 * STEEL_DENSITY, "Qto_MemberBaseQuantities")
                    b.connect(columns[k, ci, cj], clip, k + 1, "Bolt", "BOLTED")
                    b.connect(beam, clip, k + 1, "Bolt", "BOLTED")


def _box_body(typed: _Typed, author: _Author, product, key: str, type_class: str, size, kg: float, qto: str) -> None:
    """A box body ``size`` (x, y, z; metres) with its local origin at the centre of its bottom face."""
    typed.add(product, key, type_class, lambda: author.rectangle(size[0], size[1]), size[2], kg, qto)


def _precast_building(b: _Builder) -> None:
    """Column units (storey-high, each on the one below), beam units along x between column faces at the
    top of each floor, one hollow-core plank unit per bay resting on the two beams (cut around the
    columns); each unit an IfcElementAssembly of its concrete part. Joints: lower column -> column and column -> beam by dowels, beam -> plank by welds."""
    lay, author, typed = b.layout, b.author, b.typed
    cw, cd = PRECAST_COLUMN
    bw, bd = PRECAST_BEAM
    concrete = author.concrete
    units: dict[tuple, object] = {}
    for k in range(lay.floors):
        z0, z1 = k * lay.storey_height, (k + 1) * lay.storey_height
        height, base = lay.storey_height, z0  # a column stands on the one below; planks are cut around it
        for i in range(lay.nx):
            for j in range(lay.ny):
                x, y = i * lay.bay_x, j * lay.bay_y
                part = b.unit("IfcColumn", f"Precast column {k}-{i}-{j}", k, _translation(x, y, base), concrete, "COLUMN")
                _box_body(typed, author, part, f"Precast column {cw:.2f}x{cd:.2f}x{height:.3f}", "IfcColumnType",
                          (cw, cd, height), cw * cd * height * CONCRETE_DENSITY, "Qto_ColumnBaseQuantities")
                units["c", k, i, j] = part
                if k:
                    b.connect(units["c", k - 1, i, j], part, k, "Grouted dowel", "BOLTED")
        length = round(lay.bay_x - cw - 2 * JOINT_GAP, 4)
        for i in range(lay.nx - 1):
            for j in range(lay.ny):
                start = (i * lay.bay_x + cw / 2 + JOINT_GAP + length / 2, j * lay.bay_y, z1 - bd)
                part = b.unit("IfcBeam", f"Precast beam {k}-{i}-{j}", k + 1, _translation(*start), concrete, "BEAM")
                _box_body(typed, author, part, f"Precast beam {length:.3f}x{bw:.2f}x{bd:.2f}", "IfcBeamType",
                          (length, bw, bd), length * bw * bd * CONCRETE_DENSITY, "Qto_BeamBaseQuantities")
                units["b", k, i, j] = part
                for ci in (i, i + 1):
                    b.connect(units["c", k, ci, j], part, k + 1, "Grouted dowel", "BOLTED")
        span = round(lay.bay_y - 2 * JOINT_GAP, 4)  # from beam axis to beam axis: it bears on both
        width = round(lay.bay_x - cw - 2 * JOINT_GAP, 4)
        for i in range(lay.nx - 1):
            for j in range(lay.ny - 1):
                centre = ((i + 0.5) * lay.bay_x, (j + 0.5) * lay.bay_y, z1)
                part = b.unit("IfcSlab", f"Hollow-core plank {k}-{i}-{j}", k + 1, _translation(*centre), concrete, "FLOOR")
                _box_body(typed, author, part, f"Hollow-core plank {width:.3f}x{span:.3f}", "IfcSlabType",
                          (width, span, PLANK_THICKNESS), width * span * HOLLOW_CORE_KG_PER_M2, "Qto_SlabBaseQuantities")
                for bj in (j, j + 1):
                    b.connect(units["b", k, i, bj], part, k + 1, "Weld plate", "WELDED")


def _panel_building(b: _Builder) -> None:
    """Wall panels on every side of every bay (storey-high, between slabs), one solid floor slab per
    bay on the walls; each an IfcElementAssembly of its concrete part. Joints: slab below -> wall by
    dowels, wall -> slab above by welds."""
    lay, author, typed = b.layout, b.author, b.typed
    t = PANEL_THICKNESS
    concrete = author.concrete
    slabs: dict[tuple[int, int, int], object] = {}
    for k in range(lay.floors):
        z0, z1 = k * lay.storey_height, (k + 1) * lay.storey_height
        base = z0 + (PANEL_SLAB if k else 0.0)
        height = round(z1 - base, 4)
        walls: dict[tuple, object] = {}
        for axis, (count_i, count_j) in (("x", (lay.nx, lay.ny + 1)), ("y", (lay.nx + 1, lay.ny))):
            span = lay.bay_x if axis == "x" else lay.bay_y
            length = round(span - t - 2 * JOINT_GAP, 4)
            for i in range(count_i):
                for j in range(count_j):
                    if axis == "x":
                        centre, size = ((i + 0.5) * lay.bay_x, j * lay.bay_y, base), (length, t, height)
                    else:
                        centre, size = (i * lay.bay_x, (j + 0.5) * lay.bay_y, base), (t, length, height)
                    part = b.unit("IfcWall", f"Wall panel {k}-{axis}-{i}-{j}", k, _translation(*centre), concrete, "SOLIDWALL")
                    _box_body(typed, author, part, f"Wall panel {size[0]:.3f}x{size[1]:.3f}x{height:.3f}", "IfcWallType",
                              size, size[0] * size[1] * height * CONCRETE_DENSITY, "Qto_WallBaseQuantities")
                    walls[axis, i, j] = part
                    for bay in _bays_beside(axis, i, j, lay.nx, lay.ny):
                        if k:
                            b.connect(slabs[(k - 1, *bay)], part, k, "Grouted dowel", "BOLTED")
        width, depth = round(lay.bay_x - t - 2 * JOINT_GAP, 4), round(lay.bay_y - t - 2 * JOINT_GAP, 4)
        for i in range(lay.nx):
            for j in range(lay.ny):
                centre = ((i + 0.5) * lay.bay_x, (j + 0.5) * lay.bay_y, z1)
                part = b.unit("IfcSlab", f"Floor slab {k}-{i}-{j}", k + 1, _translation(*centre), concrete, "FLOOR")
                _box_body(typed, author, part, f"Floor slab {width:.3f}x{depth:.3f}", "IfcSlabType",
                          (width, depth, PANEL_SLAB), width * depth * PANEL_SLAB * CONCRETE_DENSITY, "Qto_SlabBaseQuantities")
                slabs[k, i, j] = part
                for wall in (("x", i, j), ("x", i, j + 1), ("y", i, j), ("y", i + 1, j)):
                    b.connect(walls[wall], part, k + 1, "Weld plate", "WELDED")


def _bays_beside(axis: str, i: int, j: int, nx: int, ny: int) -> list[tuple[int, int]]:
    """The bays (i, j) on either side of wall ``(axis, i, j)`` that exist."""
    if axis == "x":
        candidates = [(i, j - 1), (i, j)]
    else:
        candidates = [(i - 1, j), (i, j)]
    return [(a, c) for a, c in candidates if 0 <= a < nx and 0 <= c < ny]
