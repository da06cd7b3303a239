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
from pathlib import Path

import numpy as np

import ifcopenshell.api.material

from bimrobot.bim.example_parts import (  # noqa: F401 (the parts are importable from here too)
    BASE_PLATE_SIZE, BEAM_END_GAP, BEAM_WEIGHTS, BOLT_DIAMETER, CLIP_ANGLE, COLUMN_LENGTH, COLUMN_WEIGHT,
    CONCRETE_DENSITY, FOOTING_SIZE, FRAME_SPAN_X, FRAME_SPAN_Y, GREENHOUSE_BAY, GREENHOUSE_COLUMN_HEIGHT,
    GREENHOUSE_FOUNDATION, HEA100, IPE120, STEEL_DENSITY, W250X73, W310X38_7, ISection, _Author, _beam, _bolt,
    _column, _footing, _frame, _translation)
from bimrobot.bim.generated_buildings import (  # noqa: F401 (generated buildings, importable from here too)
    BUILDING_KINDS, FLOOR_PLATE_THICKNESS, HOLLOW_CORE_KG_PER_M2, JOINT_GAP, PANEL_SLAB, PANEL_THICKNESS, PLANK_THICKNESS, PRECAST_BEAM,
    PRECAST_COLUMN, SPLICE_PLATE, STEEL_CLIP, Layout, building_components, generated_building)

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
    column_top = BASE_PLATE_SIZE[2] + COLUMN_LENGTH
    level_2 = author.storey("Level 2", column_top)
    corners = [(0.0, 0.0), (FRAME_SPAN_X, 0.0), (FRAME_SPAN_X, FRAME_SPAN_Y), (0.0, FRAME_SPAN_Y)]
    columns = [_frame_column(author, level_1, index, x, y, bolts_per_node) for index, (x, y) in enumerate(corners, start=1)]
    _frame_beams(author, level_2, corners, columns, column_top - W310X38_7.depth / 2, bolts_per_node)
    return author.write(path, "steel-frame" if bolts_per_node is None else f"steel-frame, {bolts_per_node} bolts per node")


def _frame_column(author: _Author, level_1, index: int, x: float, y: float, bolts_per_node: int | None):
    """Footing F<index>, base plate P<index> and column C<index> at corner (x, y) (metres) with the bolts
    joining them (none at the footing when ``bolts_per_node`` is given); returns the column."""
    plate_thickness = BASE_PLATE_SIZE[2]
    footing = _footing(author, f"Footing F{index}", level_1, x, y, FOOTING_SIZE)
    plate = author.entity("IfcPlate", f"Base plate P{index}", predefined_type="BASE_PLATE")
    author.place(plate, level_1, _translation(x, y, 0.0), author.steel)
    author.extrusion(plate, author.rectangle(BASE_PLATE_SIZE[0], BASE_PLATE_SIZE[1]), plate_thickness)
    plate_volume = BASE_PLATE_SIZE[0] * BASE_PLATE_SIZE[1] * plate_thickness
    author.weight(plate, "Qto_PlateBaseQuantities", plate_volume * STEEL_DENSITY)
    column = _column(author, f"Column C{index}", level_1, x, y, plate_thickness, W250X73, COLUMN_LENGTH, COLUMN_WEIGHT)

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
    return column


def _frame_beams(author: _Author, level_2, corners: list, columns: list, beam_axis_z: float,
                 bolts_per_node: int | None) -> None:
    """The four beams between neighbouring columns (metres; axis at ``beam_axis_z``), each end on a clip angle."""
    for start_index, end_index in [(0, 1), (1, 2), (3, 2), (0, 3)]:  # (start corner, end corner)
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
    product = author.entity(ifc_class, name, predefined_type="COLUMN" if ifc_class == "IfcColumn" else "PAD_FOOTING",
                            global_id=global_id)
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

