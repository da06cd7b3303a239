"""`convert --target mujoco`: the MJCF scene loads in MuJoCo, holds the BIM masses, and stands still."""

import importlib.util

import numpy as np
import pytest

# found, not imported: MuJoCo is imported when the tests run, not at collection
if importlib.util.find_spec("mujoco") is None:
    pytest.skip("mujoco not installed (the physics extra)", allow_module_level=True)

from bimrobot.bim.model import Element, WeightSource  # noqa: E402
from bimrobot.export.gazebo.package import ConvertOptions, build_package  # noqa: E402

from mujoco_helpers import world_fixtures  # noqa: E402

frame_model, translation = world_fixtures.frame_model, world_fixtures.translation


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """MuJoCo, and trimesh with SciPy for the bodies (about 1.5 s of imports), imported when these tests
    run, not at collection."""
    global mujoco, collision_pieces, Body
    import mujoco

    from bimrobot.export.inertia import Body
    from bimrobot.export.mujoco.collision import collision_pieces

ANGLE_ID = "3Angle$000000000000000"


def angle_element(length=1.2, leg=0.1, thickness=0.01) -> Element:
    """An L angle (a concave member) as a closed prism along x: the thesis frame's clip angles, scaled."""
    outline = np.array([[0, 0], [leg, 0], [leg, thickness], [thickness, thickness], [thickness, leg], [0, leg]])
    n = len(outline)
    vertices = np.array([[x, y, z] for x in (0.0, length) for y, z in outline])
    fan = [(3, k, k + 1) for k in (4, 0, 1)] + [(3, 5, 0)]  # from the inner corner: the L is star-shaped there
    near = [(a, c, b) for a, b, c in fan]
    far = [(a + n, b + n, c + n) for a, b, c in fan]
    sides = []
    for k in range(n):
        j = (k + 1) % n
        sides += [(k, j, j + n), (k, j + n, k + n)]
    faces = np.array(near + far + sides)
    body = Body(vertices, faces)
    if body.mass_properties(1.0).volume < 0:
        faces = faces[:, ::-1]
    return Element(global_id=ANGLE_ID, ifc_class="IfcMember", name="Angle L100x10", storey_id="3storey1$$$$$$$$$$$$$$",
                   placement=translation(1.0, 1.0, 0.5), vertices=vertices, faces=faces, material="Steel",
                   weight_kg=17.9, weight_source=WeightSource.QUANTITY)


def model_with_angle():
    model = frame_model()
    model.elements[ANGLE_ID] = angle_element()
    return model


def load(out):
    model = mujoco.MjModel.from_xml_path(str(out / "mujoco" / "scene.xml"))
    return model, mujoco.MjData(model)


def run(model, data, seconds: float) -> np.ndarray:
    """Body positions (world, m) before and after ``seconds`` of simulation."""
    mujoco.mj_forward(model, data)
    before = data.xpos.copy()
    for _ in range(int(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)
    return before, data.xpos.copy()


def test_an_angle_is_decomposed_and_a_box_keeps_its_hull():
    angle = collision_pieces(Body(angle_element().vertices, angle_element().faces))
    assert angle.method.startswith("CoACD") and len(angle.pieces) >= 2
    assert angle.fill_ratio < 1.3  # the hull of an L100x10 holds 5x its steel; the pieces hug it
    box = frame_model().elements["0Col0$abc_defghijklmno"]
    assert collision_pieces(Body(box.vertices, box.faces)).method == "convex hull"


def test_installed_scene_loads_with_bim_masses_and_stands_still(tmp_path):
    model_in = model_with_angle()
    report = build_package(model_in, tmp_path / "scene", ConvertOptions(target="mujoco", maps=False))
    model, data = load(tmp_path / "scene")
    for gid, element in model_in.elements.items():
        body = model.body(gid)  # one body per element, named by its GlobalId
        entry = next(e for e in report["converted"] if e["global_id"] == gid)
        assert model.body_mass[body.id] == pytest.approx(entry["mass_kg"])
        assert body.jntnum[0] == 0  # installed: fixed to the world
    column = model.body("0Col0$abc_defghijklmno").id
    assert model.body_mass[column] == pytest.approx(289.81)
    before, after = run(model, data, 5.0)
    assert np.abs(after - before).max() < 1e-3
    assert report["mujoco"]["collision"][ANGLE_ID].startswith("CoACD")


def test_yard_components_are_free_and_come_to_rest(tmp_path):
    report = build_package(model_with_angle(), tmp_path / "yard",
                           ConvertOptions(target="mujoco", layout="yard", maps=False))
    model, data = load(tmp_path / "yard")
    assert report["mujoco"]["free_bodies"] == len(report["converted"])
    assert model.njnt == len(report["converted"])  # one free joint each
    run(model, data, 1.0)
    before, after = run(model, data, 1.0)
    assert np.abs(after - before).max() < 1e-3, "a component on the yard is still moving after 1 s"
    assert np.abs(data.qvel).max() < 1e-2
    for entry in report["converted"]:  # on the ground, where the layout put it
        assert abs(data.body(entry["global_id"]).xpos[2] - entry["pose_xyz_rpy"][2]) < 5e-3


@pytest.mark.slow
@pytest.mark.parametrize("layout", ["installed", "yard"])
def test_steel_frame_stands_still_and_its_yard_comes_to_rest(tmp_path, layout):
    from bimrobot.bim import load_model
    from bimrobot.bim.examples import steel_frame

    ifc = steel_frame(tmp_path / "frame.ifc")
    model_in = load_model(ifc, exclude="IfcMechanicalFastener" if layout == "yard" else None)
    report = build_package(model_in, tmp_path / "scene", ConvertOptions(target="mujoco", layout=layout, maps=False))
    model, data = load(tmp_path / "scene")
    before, after = run(model, data, 5.0)
    assert np.linalg.norm(after - before, axis=1).max() < 1e-3 if layout == "installed" else True
    if layout == "yard":  # settled after 5 s: no body moves 1 mm in the next second
        before, after = run(model, data, 1.0)
        assert np.linalg.norm(after - before, axis=1).max() < 1e-3
    assert report["mujoco"]["collision_methods"].get("CoACD", 0) >= 8  # the W sections and angles


@pytest.mark.slow
def test_ifc_unit_stands_still(tmp_path, shared_ifc):
    from bimrobot.bim import load_model

    model_in = load_model(shared_ifc("ifcUnit.ifc"))
    build_package(model_in, tmp_path / "scene", ConvertOptions(target="mujoco", maps=False))
    model, data = load(tmp_path / "scene")
    assert model.nbody - 1 == len(model_in.elements)
    before, after = run(model, data, 5.0)
    assert np.linalg.norm(after - before, axis=1).max() < 1e-3
