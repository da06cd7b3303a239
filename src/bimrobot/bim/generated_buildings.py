"""Generated buildings (issue 38): steel frames, precast column-beam-slab frames and panel buildings of
any size, written with ifcopenshell.api so that every command reads them like a user's model. The
shape is drawn (seeded) by :mod:`bimrobot.site.generated`; this module only writes it (metres, kg, z up).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.type
import ifcopenshell.util.placement

from bimrobot.bim.example_parts import (BEAM_END_GAP, CONCRETE_DENSITY, FOOTING_SIZE, STEEL_DENSITY,
                                        W250X73, W310X38_7, ISection, _Author, _frame, _translation)

#: The kinds of generated building (:class:`Layout`).
BUILDING_KINDS = ("steel", "precast", "panel", "plates")

HOLLOW_CORE_KG_PER_M2 = 280.0  # 200 mm hollow-core plank (HC200), kg per m2 of floor
PRECAST_COLUMN = (0.40, 0.40)  # m, section
PRECAST_BEAM = (0.40, 0.60)  # m, width x depth (rectangular beam carrying the planks on its top)
PANEL_THICKNESS = 0.20  # m, solid precast wall panel
PANEL_SLAB = 0.20  # m, solid precast floor slab
PLANK_THICKNESS = 0.20  # m
#: Precast floor plate (wide-slab, "breedplaat", filigree): the 70 mm shell a crane sets; the topping is cast
#: later on site (not robot work), so the plate's weight is its shell's.
FLOOR_PLATE_THICKNESS = 0.07  # m
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
    IfcElementAssembly, joined by ``bolts_per_node`` dowels or welds) or ``plates`` (a cross-wall building:
    bearing wall panels along y, precast floor plates spanning between them, side by side; wall panels of
    a line joined to each other, plates to the walls they bear on and to the plates beside them).
    ``nx`` x ``ny``: column grid lines (steel, precast), bays (panel), or bays between bearing-wall lines
    x plates per bay (plates). ``bay_x``, ``bay_y``: grid spacing (m; plates: span x plate width).
    ``column``, ``beam``: steel sections (ignored by the concrete kinds).
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
    and ``floors`` floors: steel columns and beams; precast columns, beams and planks; panels and slabs;
    for ``plates``, wall panels and floor plates (``nx`` bays between wall lines, ``ny`` plates per bay)."""
    if kind == "steel":
        return floors * (nx * ny + (nx - 1) * ny + nx * (ny - 1))
    if kind == "precast":
        return floors * (nx * ny + (nx - 1) * ny + (nx - 1) * (ny - 1))
    if kind == "plates":
        return floors * ((nx + 1) * ny + nx * ny)
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
            kind.GlobalId = author.stable_id(f"type:{key}")
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
        return self.author.stable_id(name)

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
    one, or, between two units side by side (plates, wall panels of a line), the first of them; its
    fasteners are IfcMechanicalFastener (bolts, dowels) or IfcFastener (welds) without bodies.
    """
    from bimrobot.core.errors import InputError

    if layout.kind not in BUILDING_KINDS:
        raise InputError(f"building kind must be one of {', '.join(BUILDING_KINDS)}, got {layout.kind!r}")
    builder = _Builder(layout)
    {"steel": _steel_building, "precast": _precast_building, "panel": _panel_building,
     "plates": _plates_building}[layout.kind](builder)
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


def _storey_walls(lay: Layout, k: int, floor_thickness: float) -> tuple[float, float, float]:
    """Where storey ``k``'s walls stand (metres, z up): (base, top, height), from the floor below
    (``floor_thickness`` above the storey's level; none on the ground) to the storey's top, where the
    floor above rests."""
    z0, z1 = k * lay.storey_height, (k + 1) * lay.storey_height
    base = z0 + (floor_thickness if k else 0.0)
    return base, z1, round(z1 - base, 4)


def _panel_building(b: _Builder) -> None:
    """Wall panels on every side of every bay (storey-high, between slabs), one solid floor slab per
    bay on the walls; each an IfcElementAssembly of its concrete part. Joints: slab below -> wall by
    dowels, wall -> slab above by welds."""
    lay, author, typed = b.layout, b.author, b.typed
    t = PANEL_THICKNESS
    concrete = author.concrete
    slabs: dict[tuple[int, int, int], object] = {}
    for k in range(lay.floors):
        base, z1, height = _storey_walls(lay, k, PANEL_SLAB)
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


def _plates_building(b: _Builder) -> None:
    """A cross-wall building: on each of the ``nx + 1`` wall lines (x = i x ``bay_x``) ``ny`` wall panels
    side by side along y (storey-high, each on the one below), and in each of the ``nx`` bays ``ny`` precast
    floor plates (:data:`FLOOR_PLATE_THICKNESS`), each ``bay_y`` wide, spanning from wall to wall; each an
    IfcElementAssembly of its concrete part. Joints: neighbouring wall panels of a line and lower wall ->
    wall by grouted dowels, each plate to the two walls it bears on and neighbouring plates by weld plates.
    Units side by side carry nothing of each other, so the order they are set in is free, as in a real
    floor of plates (GEELEN-Breedplaat) and unlike the other kinds, where every joint waits for its upper part."""
    lay, author, typed = b.layout, b.author, b.typed
    t = PANEL_THICKNESS
    concrete = author.concrete
    walls: dict[tuple[int, int, int], object] = {}
    for k in range(lay.floors):
        base, z1, height = _storey_walls(lay, k, FLOOR_PLATE_THICKNESS)
        length = round(lay.bay_y - JOINT_GAP, 4)
        for i in range(lay.nx + 1):
            for j in range(lay.ny):
                part = b.unit("IfcWall", f"Bearing wall {k}-{i}-{j}", k, _translation(i * lay.bay_x, (j + 0.5) * lay.bay_y, base),
                              concrete, "SOLIDWALL")
                _box_body(typed, author, part, f"Bearing wall {t:.3f}x{length:.3f}x{height:.3f}", "IfcWallType",
                          (t, length, height), t * length * height * CONCRETE_DENSITY, "Qto_WallBaseQuantities")
                walls[k, i, j] = part
                if k:
                    b.connect(walls[k - 1, i, j], part, k, "Grouted dowel", "BOLTED")
                if j:
                    b.connect(walls[k, i, j - 1], part, k, "Grouted dowel", "BOLTED")
        span, width = round(lay.bay_x - t - 2 * JOINT_GAP, 4), round(lay.bay_y - JOINT_GAP, 4)
        for i in range(lay.nx):
            previous = None
            for j in range(lay.ny):
                centre = ((i + 0.5) * lay.bay_x, (j + 0.5) * lay.bay_y, z1)
                part = b.unit("IfcSlab", f"Floor plate {k}-{i}-{j}", k + 1, _translation(*centre), concrete, "FLOOR")
                _box_body(typed, author, part, f"Floor plate {span:.3f}x{width:.3f}", "IfcSlabType",
                          (span, width, FLOOR_PLATE_THICKNESS), span * width * FLOOR_PLATE_THICKNESS * CONCRETE_DENSITY,
                          "Qto_SlabBaseQuantities")
                for wall in (walls[k, i, j], walls[k, i + 1, j]):
                    b.connect(wall, part, k + 1, "Weld plate", "WELDED")
                if previous is not None:
                    b.connect(previous, part, k + 1, "Weld plate", "WELDED")
                previous = part


def _bays_beside(axis: str, i: int, j: int, nx: int, ny: int) -> list[tuple[int, int]]:
    """The bays (i, j) on either side of wall ``(axis, i, j)`` that exist."""
    if axis == "x":
        candidates = [(i, j - 1), (i, j)]
    else:
        candidates = [(i - 1, j), (i, j)]
    return [(a, c) for a, c in candidates if 0 <= a < nx and 0 <= c < ny]
