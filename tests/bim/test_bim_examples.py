"""The example buildings hold what the thesis says they hold (chapter 4 frame, chapter 3 greenhouse)."""

from __future__ import annotations

import numpy as np
import pytest

import ifcopenshell

from bimrobot.bim.examples import steel_frame
from bimrobot.bim.model import WeightSource


def test_steel_frame_has_the_thesis_components(steel_frame_model):
    counts = steel_frame_model.class_counts()
    assert counts["IfcFooting"] == 4
    assert counts["IfcColumn"] == 4
    assert counts["IfcBeam"] == 4
    assert counts["IfcPlate"] == 4  # base plates
    assert counts["IfcMember"] == 8  # one clip angle per beam end
    assert counts["IfcMechanicalFastener"] == 4 * 8 + 8 * 4  # anchor + column bolts, clip-angle bolts
    assert steel_frame_model.units["length_scale_to_m"] == 1.0


def test_steel_frame_columns_and_beams_weigh_what_the_thesis_says(steel_frame_model):
    columns = steel_frame_model.by_class("IfcColumn")
    assert [c.weight_kg for c in columns] == [289.81] * 4
    assert all(c.weight_source is WeightSource.QUANTITY for c in columns)
    heights = [c.world_bounds[1, 2] - c.world_bounds[0, 2] for c in columns]
    assert heights == pytest.approx([4.0] * 4, abs=1e-6)
    beams = steel_frame_model.by_class("IfcBeam")
    assert sorted(b.weight_kg for b in beams) == [105.49, 105.49, 134.39, 134.39]


def test_section_meshes_match_catalogue_areas(steel_frame_model, greenhouse_model):
    """Mesh volume / length = the section's catalogue area (fillets included) within 0.5 to 1 %."""
    from bimrobot.bim.model import mesh_volume

    column = steel_frame_model.by_class("IfcColumn")[0]
    assert mesh_volume(column.vertices, column.faces) / 4.0 == pytest.approx(9290e-6, rel=0.005)  # W250x73
    beam = next(b for b in steel_frame_model.by_class("IfcBeam") if b.name == "Beam B12")
    length = np.ptp(beam.local_bounds[:, 0])
    assert mesh_volume(beam.vertices, beam.faces) / length == pytest.approx(4930e-6, rel=0.005)  # W310x38.7
    hea = greenhouse_model.by_class("IfcColumn")[0]
    # HEA100: its 12 mm fillets are large for the section and their chords add 0.5 %
    assert mesh_volume(hea.vertices, hea.faces) / 2.5 == pytest.approx(2124e-6, rel=0.01)


def test_steel_frame_beams_span_between_column_centres(steel_frame_model):
    columns = steel_frame_model.by_class("IfcColumn")
    centres = {tuple(np.round(c.position[:2], 3)) for c in columns}
    assert centres == {(0.0, 0.0), (2.846, 0.0), (2.846, 3.5), (0.0, 3.5)}
    for beam in steel_frame_model.by_class("IfcBeam"):
        bounds = beam.world_bounds
        # the beam top is flush with the column tops (4.025 m) and it is a 310 mm deep section
        assert bounds[1, 2] == pytest.approx(4.025, abs=1e-6)
        assert bounds[1, 2] - bounds[0, 2] == pytest.approx(0.310, abs=1e-6)


def test_steel_frame_uses_real_i_sections(steel_frame_ifc):
    ifc = ifcopenshell.open(str(steel_frame_ifc))
    profiles = {p.ProfileName: p for p in ifc.by_type("IfcIShapeProfileDef")}
    assert profiles["W250x73"].OverallDepth == pytest.approx(0.253)
    assert profiles["W310x38.7"].OverallWidth == pytest.approx(0.165)


def test_steel_frame_joints_are_bolted_connections_with_their_bolts(steel_frame_model):
    model = steel_frame_model
    assert len(model.connections) == 24
    assert {c.connection_type for c in model.connections} == {"BOLTED"}
    for connection in model.connections:
        assert connection.realizing_ids
        assert all(model.element(r).ifc_class == "IfcMechanicalFastener" for r in connection.realizing_ids)
    pairs = {(model.element(c.relating_id).ifc_class, model.element(c.related_id).ifc_class) for c in model.connections}
    assert pairs == {("IfcFooting", "IfcPlate"), ("IfcPlate", "IfcColumn"), ("IfcColumn", "IfcMember"), ("IfcMember", "IfcBeam")}


def test_steel_frame_storeys_are_column_base_and_beam_level(steel_frame_model):
    levels = {s.name: s for s in steel_frame_model.storeys}
    assert levels["Level 1"].elevation == 0.0
    assert levels["Level 2"].elevation == pytest.approx(4.025)
    for element in steel_frame_model.by_class("IfcBeam", "IfcMember"):
        assert element.storey_id == levels["Level 2"].global_id
    for element in steel_frame_model.by_class("IfcColumn", "IfcFooting", "IfcPlate"):
        assert element.storey_id == levels["Level 1"].global_id


def test_bolts_touch_both_parts_they_join(steel_frame_model):
    """Each realizing bolt's box overlaps the boxes of the two elements it joins (within 1 mm)."""
    model = steel_frame_model
    for connection in model.connections:
        for part_id in (connection.relating_id, connection.related_id):
            part = model.element(part_id).world_bounds
            for bolt_id in connection.realizing_ids:
                bolt = model.element(bolt_id).world_bounds
                gap = np.maximum(part[0] - bolt[1], bolt[0] - part[1]).max()
                assert gap < 0.001, f"{bolt_id} does not reach {part_id}"


def test_examples_have_stable_global_ids(tmp_path, steel_frame_model):
    again = steel_frame(tmp_path / "again.ifc")
    ifc = ifcopenshell.open(str(again))
    assert {p.GlobalId for p in ifc.by_type("IfcElement")} == set(steel_frame_model.elements)


def test_an_example_written_twice_is_the_same_file_but_its_header_time(tmp_path):
    # relations, property and quantity sets too: ifcopenshell.api keys them at random, the author settles them
    first, second = (steel_frame(tmp_path / name).read_text().splitlines() for name in ("a.ifc", "b.ifc"))
    differing = [(a, b) for a, b in zip(first, second) if a != b]
    assert len(first) == len(second)
    assert len(differing) == 1 and differing[0][0].startswith("FILE_NAME(")
    global_ids = [entity.GlobalId for entity in ifcopenshell.open(str(tmp_path / "a.ifc")).by_type("IfcRoot")]
    assert len(global_ids) == len(set(global_ids))


def test_greenhouse_is_nine_foundations_nine_columns_ten_beams(greenhouse_model):
    assert greenhouse_model.class_counts() == {"IfcBeam": 10, "IfcColumn": 9, "IfcFooting": 9}
    assert all(e.weight_kg and e.weight_kg > 0 for e in greenhouse_model.elements.values())
    columns = greenhouse_model.by_class("IfcColumn")
    assert {tuple(np.round(c.position[:2], 3)) for c in columns} == {(x, y) for x in (0, 3, 6) for y in (0, 3, 6)}


def test_example_and_its_split_parts_pass_schema_and_express_rules(tmp_path, greenhouse_ifc):
    """ifcopenshell.validate with the schema's WHERE rules: no error on the example or a split part."""
    import logging

    import ifcopenshell.validate

    from bimrobot.bim.split import split_model

    parts = split_model(greenhouse_ifc, tmp_path / "parts", include="IfcColumn")
    for path in (greenhouse_ifc, parts[0].path):
        messages: list[str] = []

        class Collect(logging.Handler):
            def emit(self, record):
                messages.append(record.getMessage())

        logger = logging.getLogger(f"express.{path.name}")
        logger.propagate = False
        logger.addHandler(Collect())
        ifcopenshell.validate.validate(ifcopenshell.open(str(path)), logger, express_rules=True)
        assert messages == [], path.name


def test_steel_frame_with_bolts_per_node_has_them_at_columns_and_beams_only(tmp_path, capsys):
    """Table 4.2's frame: N bolts at each column foot, column top and beam end; no relation at the footings."""
    from bimrobot.bim import load_model
    from bimrobot.cli import main

    path = tmp_path / "frame6.ifc"
    assert main(["example", "steel-frame", "--bolts-per-node", "6", "-o", str(path)]) == 0
    model = load_model(path)
    assert model.class_counts()["IfcMechanicalFastener"] == 6 * (4 + 8 + 8)
    footings = {f.global_id for f in model.by_class("IfcFooting")}
    assert not any(c.relating_id in footings or c.related_id in footings for c in model.connections)
    assert all(len(c.realizing_ids) == 6 for c in model.connections)


@pytest.mark.parametrize("args, message", [
    (["steel-frame", "--bolts-per-node", "0"], "--bolts-per-node must be from 1 to 12"),
    (["greenhouse", "--bolts-per-node", "6"], "applies to the steel-frame example only"),
])
def test_bad_bolts_per_node_is_refused_in_one_sentence(tmp_path, capsys, args, message):
    from bimrobot.cli import main

    assert main(["example", *args, "-o", str(tmp_path / "x.ifc")]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "x.ifc").exists()
