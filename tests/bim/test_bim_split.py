"""bimrobot split: one valid IFC per element, geometry and data equal to the original's."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest

import ifcopenshell
import ifcopenshell.validate

from bimrobot.bim import load_model
from bimrobot.bim.split import split_model
from bimrobot.errors import InputError
from bimrobot.world.names import safe_name


def _same_element(split_model_, original_element):
    element = split_model_.element(original_element.global_id)
    assert element.ifc_class == original_element.ifc_class
    assert element.vertices.shape == original_element.vertices.shape
    np.testing.assert_allclose(element.placement, original_element.placement, atol=1e-9)
    np.testing.assert_allclose(element.world_vertices, original_element.world_vertices, atol=1e-6)
    assert element.weight_kg == original_element.weight_kg
    assert element.weight_source == original_element.weight_source
    assert element.material == original_element.material
    assert element.properties == original_element.properties
    assert element.storey_id == original_element.storey_id


def _schema_errors(path: Path) -> list[str]:
    messages: list[str] = []

    class Collect(logging.Handler):
        def emit(self, record):
            messages.append(record.getMessage())

    logger = logging.getLogger(f"validate.{path.name}")
    logger.propagate = False
    logger.addHandler(Collect())
    ifcopenshell.validate.validate(ifcopenshell.open(str(path)), logger)
    return messages


def test_split_steel_frame_one_valid_file_per_element(tmp_path, steel_frame_ifc, steel_frame_model):
    out = tmp_path / "parts"
    written = split_model(steel_frame_ifc, out)
    assert len(written) == 88
    assert sorted(p.name for p in out.iterdir()) == sorted([f.path.name for f in written] + ["index.json"])
    index = json.loads((out / "index.json").read_text())
    assert {row["GlobalId"] for row in index["elements"]} == set(steel_frame_model.elements)
    for original in steel_frame_model.elements.values():
        path = out / f"{safe_name(original.global_id)}.ifc"
        part = load_model(path)
        assert part.schema == "IFC4"
        assert list(part.elements) == [original.global_id]  # exactly one element with geometry
        _same_element(part, original)
        assert [s.global_id for s in part.storeys] == [original.storey_id]


def test_split_files_pass_schema_validation(tmp_path, steel_frame_ifc, steel_frame_model):
    out = tmp_path / "parts"
    split_model(steel_frame_ifc, out, include="IfcBeam, IfcMember")
    for path in sorted(out.glob("*.ifc")):
        assert _schema_errors(path) == [], path.name


def test_split_real_files_pass_schema_validation(tmp_path, shared_ifc):
    """ifcColumn: a material shared by the element and its type, welds, Chinese names."""
    out = tmp_path / "parts"
    split_model(shared_ifc("ifcColumn.ifc"), out)
    files = sorted(out.glob("*.ifc"))
    assert len(files) == 7  # column, base plate, slab, anchor bolt and 3 curve-only welds
    for path in files:
        assert _schema_errors(path) == [], path.name


def test_split_keeps_the_connections_that_involve_the_element(tmp_path, steel_frame_ifc, steel_frame_model):
    out = tmp_path / "parts"
    split_model(steel_frame_ifc, out)
    column = next(c for c in steel_frame_model.by_class("IfcColumn") if c.name == "Column C1")
    expected = steel_frame_model.connections_of(column.global_id)
    assert len(expected) == 3  # base plate below, two clip angles above
    ifc = ifcopenshell.open(str(out / f"{safe_name(column.global_id)}.ifc"))
    relations = ifc.by_type("IfcRelConnectsWithRealizingElements")
    assert {r.GlobalId for r in relations} == {c.global_id for c in expected}
    for relation, connection in zip(sorted(relations, key=lambda r: r.GlobalId), sorted(expected, key=lambda c: c.global_id)):
        assert relation.RelatingElement.GlobalId == connection.relating_id
        assert relation.RelatedElement.GlobalId == connection.related_id
        assert tuple(r.GlobalId for r in relation.RealizingElements) == connection.realizing_ids
        assert relation.ConnectionType == "BOLTED"
    # neighbours are reference stubs without geometry: only the column has a body
    assert [p.GlobalId for p in ifc.by_type("IfcElement") if p.Representation] == [column.global_id]
    # a bolt's file names the joint it realises
    bolt_id = expected[0].realizing_ids[0]
    bolt_file = ifcopenshell.open(str(out / f"{safe_name(bolt_id)}.ifc"))
    assert [r.GlobalId for r in bolt_file.by_type("IfcRelConnectsWithRealizingElements")] == [expected[0].global_id]


def test_split_real_models_geometry_equals_original(tmp_path, shared_ifc, ifc_unit_model):
    """ifcUnit (mm, Revit) and the IFC2X3 Revit frame: every part re-opens with the same body."""
    for name in ("ifcUnit.ifc", "engine_web-ifc_example.ifc"):
        source = shared_ifc(name)
        out = tmp_path / name
        written = split_model(source, out)
        original = ifc_unit_model if name == "ifcUnit.ifc" else load_model(source)
        assert len(written) == len(original.elements) + len(original.skipped)
        schema = original.schema
        per_class: dict[str, int] = {}
        for element in original.elements.values():
            per_class[element.ifc_class] = per_class.get(element.ifc_class, 0) + 1
            if per_class[element.ifc_class] > 3:  # three of each class keeps the test short
                continue
            part = load_model(out / f"{safe_name(element.global_id)}.ifc")
            assert part.schema == schema
            _same_element(part, element)


def test_split_wall_keeps_its_openings(tmp_path, shared_ifc):
    source = shared_ifc("AC20-FZK-Haus.ifc")
    original = load_model(source, include="IfcWall")
    out = tmp_path / "walls"
    split_model(source, out, include="IfcWall")
    ifc = ifcopenshell.open(str(source))
    pierced = [w for w in original.elements.values() if ifc.by_guid(w.global_id).HasOpenings]
    assert pierced
    for wall in pierced[:4]:
        _same_element(load_model(out / f"{safe_name(wall.global_id)}.ifc"), wall)


def test_split_bad_input_leaves_no_output(tmp_path):
    bad = tmp_path / "bad.ifc"
    bad.write_text("ISO-10303-21;\nHEADER;\n")
    out = tmp_path / "parts"
    with pytest.raises(InputError, match=r"bad\.ifc is truncated"):
        split_model(bad, out)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == [bad]
