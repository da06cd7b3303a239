"""Smart components and connection nodes from a BuildingModel (thesis 4.4.2, fig. 4.6-4.7)."""

import numpy as np
import pytest

from bimrobot.bim.model import BuildingModel, Connection, SkippedProduct, Storey
from bimrobot.coordination.generate import box_element, generated_frame
from bimrobot.core.errors import InputError
from bimrobot.sco import State, build_smart_model


def _model(elements, connections, skipped=()):
    return BuildingModel(
        source=None, schema="IFC4", project_name="test", site_name="site", units={},
        storeys=[Storey("L1", "Level 1", 0.0), Storey("L2", "Level 2", 4.0)],
        elements={e.global_id: e for e in elements}, connections=list(connections), skipped=list(skipped),
    )


def test_generated_thesis_frame_has_the_chapter_4_objects():
    smart = build_smart_model(generated_frame(2, 2, 1))
    summary = smart.summary()
    assert summary["components"] == 12  # 4 footings, 4 columns, 4 beams
    assert sorted(summary["prebuilt"]) == [f"footing-{i}-{j}" for i in range(2) for j in range(2)]
    assert summary["connection_nodes"] == 24 and summary["joints"] == 12
    assert summary["assembly_points"] == 24 * 6  # six bolts per node, as in the thesis' example
    column = smart.components["column-0-0-0"]
    assert column.node_number == 3  # foot + two beams (thesis 4.2)
    assert {n.id for n in column.connection_nodes} == {
        "column-0-0-0:plate-0-0-0", "column-0-0-0:clip-beam-0-x-0-0-0", "column-0-0-0:clip-beam-0-y-0-0-0",
    }
    assert set(column.relative_object_ids) == {"footing-0-0", "beam-0-x-0-0", "beam-0-y-0-0"}
    assert column.weight_kg == pytest.approx(72.9 * 3.98)
    assert column.state == State.ON_YARD and smart.components["footing-0-0"].state == State.POSITION_FIXED
    # the beam is carried by its two columns; the column by its footing
    assert smart.supporters["beam-0-x-0-0"] == ("column-0-0-0", "column-0-1-0")
    assert smart.supporters["column-0-0-0"] == ("footing-0-0",)
    # the column's top joints belong to the beams' floor (Listing 4.1)
    assert smart.joints["clip-beam-0-x-0-0-0"].floor == 1 and smart.joints["plate-0-0-0"].floor == 0


def test_connectors_are_found_by_role_not_class_and_joined_cleats_form_one_joint():
    """ifcUnit's pattern: cleats exported as IfcColumn, cleat #1 bolted to cleat #2."""
    column = box_element("COL", "IfcColumn", "W250", "L1", (0, 0, 0), (0.25, 0.25, 4.0), 289.5)
    beam = box_element("BEAM", "IfcBeam", "W310", "L2", (0.3, 0, 3.7), (3.0, 0.16, 4.0), 109.3)
    cleat1 = box_element("CLEAT1", "IfcColumn", "Angle_Cleat#1", "L2", (0.25, 0, 3.75), (0.35, 0.1, 3.95), 2.0)
    cleat2 = box_element("CLEAT2", "IfcColumn", "Angle_Cleat#2", "L2", (0.25, 0.1, 3.75), (0.35, 0.2, 3.95), 2.0)
    plate = box_element("PLATE", "IfcPlate", "Baseplate", "L1", (-0.1, -0.1, -0.02), (0.35, 0.35, 0.0), 20.0)
    connections = [
        Connection("COL", "CLEAT1", ("B1",)), Connection("COL", "CLEAT2", ("B2",)),
        Connection("BEAM", "CLEAT1", ("B3", "B4")), Connection("CLEAT1", "CLEAT2", ("B5",)),
        Connection("COL", "PLATE", ("W1",)),
    ]
    skipped = [SkippedProduct(f"B{i}", "IfcMechanicalFastener", "bolt", "") for i in range(1, 6)]
    skipped.append(SkippedProduct("W1", "IfcFastener", "", "curve-only geometry"))
    smart = build_smart_model(_model([column, beam, cleat1, cleat2, plate], connections, skipped))
    assert set(smart.components) == {"COL", "BEAM"}  # cleats are connectors although IfcColumn
    assert smart.connectors == ["CLEAT1", "CLEAT2", "PLATE"]
    assert "thesis fig. 4.6" in smart.role_rule
    joint = smart.joints["CLEAT1"]
    assert joint.component_ids == ("COL", "BEAM")
    assert set(joint.node_ids) == {"COL:CLEAT1", "COL:CLEAT2", "BEAM:CLEAT1"}
    assert set(joint.realizing_ids) == {"B1", "B2", "B3", "B4", "B5"}
    assert smart.nodes["BEAM:CLEAT1"].assembly_point_number == 2
    assert smart.nodes["COL:PLATE"].assembly_method == "weld"  # IfcFastener realizing element
    assert smart.nodes["COL:CLEAT1"].assembly_method == "bolt"
    assert smart.supporters["BEAM"] == ("COL",)


def test_chained_relations_take_the_lighter_element_as_connector():
    """footing -> plate -> column -> clip -> beam (relations chained, not component -> connector)."""
    footing = box_element("F", "IfcFooting", "", "L1", (-0.6, -0.6, -0.6), (0.6, 0.6, 0.0), 2073.6)
    plate = box_element("P", "IfcPlate", "", "L1", (-0.2, -0.2, 0.0), (0.2, 0.2, 0.025), 30.0)
    column = box_element("C", "IfcColumn", "", "L1", (-0.12, -0.12, 0.025), (0.12, 0.12, 4.0), 289.8)
    clip = box_element("K", "IfcMember", "", "L2", (0.12, 0.0, 3.7), (0.2, 0.1, 3.9), 3.0)
    beam = box_element("B", "IfcBeam", "", "L2", (0.13, -0.08, 3.69), (3.5, 0.08, 4.0), 134.4)
    connections = [
        Connection("F", "P", ("a1", "a2", "a3", "a4"), "BOLTED"), Connection("P", "C", ("c1", "c2", "c3", "c4"), "BOLTED"),
        Connection("C", "K", ("k1", "k2"), "BOLTED"), Connection("K", "B", ("k3", "k4"), "BOLTED"),
    ]
    smart = build_smart_model(_model([footing, plate, column, clip, beam], connections))
    assert set(smart.components) == {"F", "C", "B"}
    assert "lighter" in smart.role_rule
    assert smart.components["C"].node_number == 2
    assert {n.id for n in smart.components["C"].connection_nodes} == {"P:C", "C:K"}  # ids keep relating:related
    assert smart.joints["P"].component_ids == ("F", "C")
    assert smart.summary()["assembly_points"] == 12


def test_without_relations_connections_are_inferred_from_touching_bodies():
    pytest.importorskip("fcl", reason="connection inference uses python-fcl (bimrobot's bim extra)")
    footing = box_element("F", "IfcFooting", "", "L1", (-0.6, -0.6, -0.6), (0.6, 0.6, 0.0), 2000.0)
    column = box_element("C", "IfcColumn", "", "L1", (-0.12, -0.12, 0.0), (0.12, 0.12, 4.0), 289.8)
    beam = box_element("B", "IfcBeam", "", "L2", (0.12, -0.08, 3.69), (3.5, 0.08, 4.0), 134.4)
    far = box_element("X", "IfcBeam", "", "L2", (10, 10, 3.69), (13, 10.2, 4.0), 100.0)
    smart = build_smart_model(_model([footing, column, beam, far], []), assembly_points_per_joint=8)
    assert smart.connection_source == "inferred from geometry"
    assert sorted(j.component_ids for j in smart.inferred) == [("C", "B"), ("F", "C")]
    assert smart.summary()["inferred_joints"] == [["F", "C"], ["C", "B"]]
    assert smart.nodes["C:B"].assembly_point_number == 4 and smart.nodes["B:C"].component_id == "B"
    assert smart.nodes["C:B"].assembly_point_source == "assumed"  # no fastener in the model: 8 per joint, 4 a side
    assert smart.assembly_points_by_source == {"model": {"joints": 0, "points": 0},
                                               "assumed": {"joints": 2, "points": 16, "per_joint": 8}}
    assert smart.unconnected == ["X"]
    joint = smart.joints["C:B"]
    assert np.allclose(joint.position[:2], [0.12, 0.0], atol=1e-9)  # the contact face


def test_a_model_without_buildable_elements_is_refused():
    bolt = box_element("BOLT", "IfcMechanicalFastener", "", "L1", (0, 0, 0), (0.02, 0.02, 0.1), 0.3)
    with pytest.raises(InputError, match="no buildable element"):
        build_smart_model(_model([bolt], []))


def test_size_is_measured_along_the_member_even_when_it_lies_diagonally():
    beam = box_element("B", "IfcBeam", "", "L2", (0, 0, 0), (5.0, 0.16, 0.31), 190.0)
    angle = np.pi / 4
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    beam.placement = np.eye(4)
    beam.placement[:3, :3] = rotation
    beam.placement[:3, 3] = (1.0, 2.0, 3.7)
    column = box_element("C", "IfcColumn", "", "L1", (0.8, 1.8, 0.0), (1.2, 2.2, 3.7), 289.0)
    smart = build_smart_model(_model([beam, column], [Connection("B", "C", inferred=True)]))
    assert smart.components["B"].size == pytest.approx((5.0, 0.31, 0.16))
    assert smart.components["B"].origin == pytest.approx([1.0, 2.0, 3.7])
