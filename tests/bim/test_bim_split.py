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
from bimrobot.core.errors import InputError
from bimrobot.core.names import safe_name
from output_checks import snapshot
from shared_data import shared_file


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
    expected = [f.path.name for f in written] + ["index.json", ".bimrobot-output.json"]  # and the output marker
    assert sorted(p.name for p in out.iterdir()) == sorted(expected)
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


# ---- precast assemblies (Tekla exports) ------------------------------------------------------------


@pytest.fixture(scope="module")
def prefab(tmp_path_factory):
    """MULTICOM-Prefab split by assembly, and the model it came from (skipped when ../shared is absent)."""
    path = shared_file("ifc", "MULTICOM-Prefab.ifc")
    out = tmp_path_factory.mktemp("prefab") / "units"
    return path, out, split_model(path, out), load_model(path)


@pytest.mark.slow
def test_split_precast_writes_one_file_per_outermost_assembly_with_all_its_parts(prefab):
    """Each file re-opens with exactly its assembly's parts, at the same place, with the same weights."""
    _, out, written, original = prefab
    assert len(original.assemblies) == 118
    assert {gid for a in original.assemblies.values() for gid in a.part_ids} == set(original.elements)  # all 301
    assert len(original.elements) == 301
    assert len(written) == 118 == len(list(out.glob("*.ifc")))
    assert {f.global_id for f in written} == set(original.assemblies)
    for assembly in original.assemblies.values():
        part = load_model(out / f"{safe_name(assembly.global_id)}.ifc")
        assert set(part.elements) == set(assembly.part_ids), assembly.global_id
        assert list(part.assemblies) == [assembly.global_id]
        for part_id in assembly.part_ids:
            copy, source = part.elements[part_id], original.elements[part_id]
            np.testing.assert_allclose(copy.world_vertices, source.world_vertices, atol=1e-6)
            assert copy.weight_kg == source.weight_kg and copy.ifc_class == source.ifc_class


def test_split_index_lists_each_assembly_and_its_parts(prefab):
    path, out, written, original = prefab
    index = json.loads((out / "index.json").read_text())
    assert index["split_by"] == "assembly" and index["files"] == 118 and index["source"] == str(path)
    rows = {row["GlobalId"]: row for row in index["elements"]}
    for assembly in original.assemblies.values():
        row = rows[assembly.global_id]
        assert row["class"] == "IfcElementAssembly" and row["file"] == f"{safe_name(assembly.global_id)}.ifc"
        assert [p["GlobalId"] for p in row["parts"]] == [p for p in assembly.part_ids]


def test_split_assembly_files_pass_schema_validation(prefab):
    _, out, written, _ = prefab
    biggest = sorted(written, key=lambda f: len(f.parts))[-3:]  # nested sub-assemblies, shared psets
    for split_file in biggest:
        assert _schema_errors(out / split_file.path.name) == [], split_file.path.name


def test_split_tekla_stairs_by_assembly_and_by_element(tmp_path, shared_ifc):
    source = shared_ifc("MULTICOM-trappen_bordessen.ifc")
    original = load_model(source)
    assert len(original.assemblies) == 9
    written = split_model(source, tmp_path / "units")
    assemblies = [f for f in written if f.ifc_class == "IfcElementAssembly"]
    assert len(assemblies) == 9
    in_assemblies = {p.global_id for f in assemblies for p in f.parts}
    assert in_assemblies >= {gid for a in original.assemblies.values() for gid in a.part_ids}
    singles = [f for f in written if not f.parts]
    assert not in_assemblies & {f.global_id for f in singles}  # every element in one file only
    assert len(list((tmp_path / "units").glob("*.ifc"))) == len(written)
    by_element = split_model(source, tmp_path / "parts", by_element=True)
    assert len(by_element) == len(list((tmp_path / "parts").glob("*.ifc")))
    assert len(by_element) == len(original.elements) + len(original.skipped)
    assert json.loads((tmp_path / "parts" / "index.json").read_text())["split_by"] == "element"


def test_split_ifczip_reads_the_model_inside(tmp_path, shared_ifc):
    source = shared_ifc("ROOT-staal.ifczip")
    written = split_model(source, tmp_path / "steel", include="IfcColumn")
    assert written and {f.ifc_class for f in written} == {"IfcColumn"}
    assert len(list((tmp_path / "steel").glob("*.ifc"))) == len(written)
    first = load_model(written[0].path)
    assert list(first.elements) == [written[0].global_id]


# ---- duplicate GlobalIds, output policy --------------------------------------------------------------


def test_split_duplicate_global_ids_write_every_element(tmp_path, capsys):
    from test_bim_reader import walls_sharing_a_global_id

    from bimrobot.cli import main

    path, walls = walls_sharing_a_global_id(tmp_path / "walls.ifc")
    (_, shared), (second_id, _), _ = walls
    assert main(["split", str(path), "-o", str(tmp_path / "parts")]) == 0
    out = capsys.readouterr().out
    assert "wrote 3 IFC files" in out
    files = sorted(p.name for p in (tmp_path / "parts").glob("*.ifc"))
    assert len(files) == 3 and f"{safe_name(shared)}.ifc" in files and f"{safe_name(f'{shared}#{second_id}')}.ifc" in files
    index = json.loads((tmp_path / "parts" / "index.json").read_text())
    assert [row["GlobalId"] for row in index["elements"]][:2] == [shared, f"{shared}#{second_id}"]
    second = load_model(tmp_path / "parts" / f"{safe_name(f'{shared}#{second_id}')}.ifc")
    assert [e.name for e in second.elements.values()] == ["Wall 1"]


@pytest.mark.parametrize(
    "output, message",
    [
        ("model.ifc", "is an input of this command"),
        (".", "is the current directory"),
        ("..", "contains the current directory"),
        ("notes", "a folder that bimrobot did not write and it is not empty"),
        ("linked", "a folder that bimrobot did not write and it is not empty"),
        ("notes/thesis.txt/parts", "is a file, not a folder"),
    ],
)
def test_split_refuses_outputs_that_would_destroy_data(tmp_path, monkeypatch, capsys, greenhouse_ifc, output, message):
    from bimrobot.cli import main

    project = tmp_path / "project"
    project.mkdir()
    (project / "model.ifc").write_bytes(greenhouse_ifc.read_bytes())
    (project / "notes").mkdir()
    (project / "notes" / "thesis.txt").write_text("precious")
    (project / "linked").symlink_to(project / "notes")
    monkeypatch.chdir(project)
    before = snapshot(tmp_path)
    assert main(["split", "model.ifc", "-o", output]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert snapshot(tmp_path) == before


def test_split_refuses_the_folder_holding_its_input(tmp_path, capsys, greenhouse_ifc):
    from bimrobot.cli import main

    (tmp_path / "model.ifc").write_bytes(greenhouse_ifc.read_bytes())
    before = snapshot(tmp_path)
    assert main(["split", str(tmp_path / "model.ifc"), "-o", str(tmp_path)]) == 2
    assert "contains an input of this command" in capsys.readouterr().err
    assert snapshot(tmp_path) == before


def test_split_replaces_its_own_output_and_says_so(tmp_path, capsys, greenhouse_ifc):
    from bimrobot.cli import main

    out = tmp_path / "parts"
    assert main(["split", str(greenhouse_ifc), "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["split", str(greenhouse_ifc), "-o", str(out), "--include", "IfcColumn"]) == 0
    captured = capsys.readouterr()
    assert "wrote 9 IFC files" in captured.out
    (line,) = captured.err.strip().splitlines()
    assert line.startswith(f"bimrobot: replacing {out} (split output of {greenhouse_ifc.name}")
    assert len(list(out.glob("*.ifc"))) == 9


def test_a_window_is_split_as_one_unit_with_its_frame_and_pane(tmp_path, shared_ifc):
    """IfcOpenHouse's 5 windows aggregate 4 IfcMember and 1 IfcPlate each (IfcRelAggregates, not an
    IfcElementAssembly): one file per window with its 5 parts, as the model's lifted units are."""
    import json

    from bimrobot.bim.split import split_model

    written = split_model(shared_ifc("IfcOpenHouse_IFC4.ifc"), tmp_path / "parts")
    windows = [f for f in written if f.ifc_class == "IfcWindow"]
    assert len(windows) == 5 and all(sorted(p.ifc_class for p in f.parts) == ["IfcMember"] * 4 + ["IfcPlate"] for f in windows)
    assert not any(f.ifc_class in ("IfcMember", "IfcPlate") for f in written)  # no part written alone
    index = json.loads((tmp_path / "parts" / "index.json").read_text())
    assert index["split_by"] == "assembly" and all(len(row["parts"]) == 5 for row in index["elements"] if row["class"] == "IfcWindow")
