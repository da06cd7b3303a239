"""Mass and inertia of element bodies: the values an SDF <inertial> block must carry."""

import numpy as np
import pytest

from bimrobot.export.gazebo.check import inertia_problem

from .conftest import box_element, translation


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """trimesh and SciPy (about 1 s of imports, with networkx), imported when these tests run, not at collection."""
    global trimesh, DEFAULT_DENSITY_KG_M3, mass_properties
    import trimesh

    from bimrobot.export.inertia import DEFAULT_DENSITY_KG_M3, mass_properties


def test_box_beam_gets_its_bim_mass_and_the_exact_box_tensor():
    beam = box_element("1Beam$0000000000000000", "IfcBeam", (3.5, 0.15, 0.3), translation(0, 0, 0), 134.39)
    props = mass_properties(beam)
    assert props.mass == pytest.approx(134.39)
    assert not props.mass_assumed
    assert props.inertia_method == "solid mesh"
    expected = 134.39 / 12 * np.diag([0.15**2 + 0.3**2, 3.5**2 + 0.3**2, 3.5**2 + 0.15**2])
    np.testing.assert_allclose(props.inertia, expected, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(props.center_of_mass, [0, 0, 0.15], atol=1e-12)


def test_rotated_body_has_off_diagonal_products_and_stays_physical():
    box = trimesh.creation.box(extents=(3.0, 0.2, 0.4))
    box.apply_transform(trimesh.transformations.rotation_matrix(0.5, [0.3, 0.2, 1.0]))
    element = box_element("1Rot$00000000000000000", "IfcMember", (1, 1, 1), np.eye(4), 50.0)
    element.vertices, element.faces = np.asarray(box.vertices), np.asarray(box.faces)
    props = mass_properties(element)
    assert abs(props.inertia[0, 1]) > 1.0
    assert inertia_problem(props.inertia) is None
    # The principal moments are those of the unrotated box.
    expected = sorted(50.0 / 12 * np.array([0.2**2 + 0.4**2, 3.0**2 + 0.4**2, 3.0**2 + 0.2**2]))
    np.testing.assert_allclose(np.linalg.eigvalsh(props.inertia), expected, rtol=1e-9)


def test_missing_weight_uses_the_documented_default_density():
    plate = box_element("2Plate$000000000000000", "IfcPlate", (0.4, 0.4, 0.02), np.eye(4))
    props = mass_properties(plate)
    assert props.mass_assumed
    assert props.mass == pytest.approx(0.4 * 0.4 * 0.02 * DEFAULT_DENSITY_KG_M3)


def test_open_mesh_falls_back_to_its_convex_hull():
    box = trimesh.creation.box(extents=(1.0, 2.0, 0.5))
    element = box_element("1Open$0000000000000000", "IfcSlab", (1, 1, 1), np.eye(4), 100.0)
    element.vertices, element.faces = np.asarray(box.vertices), np.asarray(box.faces[:-2])  # one side missing
    props = mass_properties(element)
    assert props.inertia_method == "convex hull"
    assert props.volume == pytest.approx(1.0)
    assert props.mass == pytest.approx(100.0)


def test_flat_body_gets_a_positive_definite_tensor():
    flat = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    element = box_element("1Flat$0000000000000000", "IfcCovering", (1, 1, 1), np.eye(4), 5.0)
    element.vertices, element.faces = np.asarray(flat.vertices, float), np.asarray(flat.faces)
    props = mass_properties(element)
    assert props.inertia_method == "bounding box"
    assert props.mass == 5.0
    assert inertia_problem(props.inertia) is None


def test_beam_dropped_in_mujoco_rests_on_its_flange_at_half_its_depth():
    pytest.importorskip("mujoco")
    from bimrobot.export.inertia import Body
    from bimrobot.export.mujoco.scene import drop_on_ground

    beam = box_element("1Beam$0000000000000000", "IfcBeam", (3.5, 0.15, 0.31), np.eye(4), 109.28, base_at_origin=False)
    body = Body(beam.vertices, beam.faces)
    start = np.eye(4)
    start[:3, 3] = (0.0, 0.0, 0.5)
    rest = drop_on_ground([body.hull], mass_properties(beam, body), start, seconds=2.0)
    assert rest.center_of_mass[2] == pytest.approx(0.155, abs=2e-3)  # half its depth above the ground
    assert rest.speed < 1e-3 and rest.angular_speed < 1e-2
    np.testing.assert_allclose(rest.pose[:3, :3], np.eye(3), atol=1e-3)  # it fell flat, did not tip
