"""BuildingModels made from trimesh primitives, so the world part is tested without any IFC reader."""

from __future__ import annotations

import numpy as np
import pytest

from bimrobot.bim.model import BuildingModel, Element, SkippedProduct, Storey, WeightSource

COLUMN_XY = [(0.0, 0.0), (3.5, 0.0), (0.0, 2.846), (3.5, 2.846)]
COLUMN_SIZE = (0.25, 0.25, 4.0)  # m: a W250-like footprint, 4 m high
BEAM_SIZE = (3.5, 0.15, 0.3)  # m: along local x


def translation(x: float, y: float, z: float) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, 3] = (x, y, z)
    return matrix


def box_element(global_id, ifc_class, extents, placement, weight_kg=None, storey_id="3storey1$$$$$$$$$$$$$$",
                base_at_origin=True) -> Element:
    """An element whose local body is a box: with ``base_at_origin`` its bottom face centre is the local
    origin (like an IFC extrusion), else the box is centred."""
    import trimesh  # here, not at collection (about 1 s of imports with SciPy and networkx)

    box = trimesh.creation.box(extents=extents)
    if base_at_origin:
        box.apply_translation((0, 0, extents[2] / 2))
    return Element(
        global_id=global_id,
        ifc_class=ifc_class,
        name=f"{ifc_class} {global_id[:4]}",
        storey_id=storey_id,
        placement=placement,
        vertices=np.asarray(box.vertices, float),
        faces=np.asarray(box.faces, np.int64),
        material="Steel",
        weight_kg=weight_kg,
        weight_source=WeightSource.QUANTITY if weight_kg else WeightSource.UNKNOWN,
    )


def frame_model() -> BuildingModel:
    """Four 4 m columns (289.81 kg) and two beams (134.39 kg) on top, one storey at 0 m, plus a
    weightless plate and one curve-only weld reported as skipped by the reader."""
    elements = {}
    for index, (x, y) in enumerate(COLUMN_XY):
        gid = f"0Col{index}$abc_defghijklmno"[:22]
        elements[gid] = box_element(gid, "IfcColumn", COLUMN_SIZE, translation(x, y, 0.0), 289.81)
    for index, y in enumerate((0.0, 2.846)):
        gid = f"1Beam{index}$xyz_ABCDEFGHIJ"[:22]
        # Beam centred on its axis, placed between column centres at the column tops.
        elements[gid] = box_element(gid, "IfcBeam", BEAM_SIZE, translation(1.75, y, 4.0 - 0.15), 134.39,
                                    base_at_origin=False)
    plate = box_element("2Plate$0000000000000000"[:22], "IfcPlate", (0.4, 0.4, 0.02), translation(0.0, 0.0, -0.02))
    elements[plate.global_id] = plate
    return BuildingModel(
        source=None,
        schema="IFC4",
        project_name="Test frame",
        site_name="Test Site",
        units={"length": "METRE", "length_scale_to_m": 1.0, "mass": "KILOGRAM"},
        storeys=[Storey("3storey1$$$$$$$$$$$$$$", "Level 1", 0.0), Storey("3storey2$$$$$$$$$$$$$$", "Level 2", 4.0)],
        elements=elements,
        connections=[],
        skipped=[SkippedProduct("0Weld$0000000000000000"[:22], "IfcFastener", "weld", "curve-only geometry (no solid)")],
    )


@pytest.fixture
def frame() -> BuildingModel:
    return frame_model()
