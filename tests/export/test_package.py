"""The Gazebo package written from a BuildingModel: files, SDF content, validator verdicts, maps."""

from __future__ import annotations

import json
import py_compile
import xml.etree.ElementTree as ET
from pathlib import Path

import collada
import numpy as np
import pytest

from bimrobot.core.errors import InputError
from bimrobot.export.gazebo.check import problems, read_models, sdf_validator, validate_sdf
from bimrobot.export.gazebo.navmap import read_map
from bimrobot.export.gazebo.package import ConvertOptions, build_package

from .conftest import COLUMN_SIZE, COLUMN_XY, box_element, frame_model

needs_ign = pytest.mark.skipif(sdf_validator() is None, reason="`ign sdf` is not installed (ignition-tools)")


@pytest.fixture(scope="module")
def package(tmp_path_factory):
    out = tmp_path_factory.mktemp("pkg") / "frame_pkg"
    report = build_package(frame_model(), out, ConvertOptions(target="both"))
    return out, report


def test_every_element_becomes_a_model_with_existing_meshes(package):
    out, report = package
    models = sorted(p.name for p in (out / "models").iterdir())
    assert len(models) == 7 == report["counts"]["converted"]
    assert problems(out) == []
    for model_dir in (out / "models").iterdir():
        config = ET.parse(model_dir / "model.config").getroot()
        assert {e.get("version"): e.text for e in config.findall("sdf")} == {"1.9": "model.sdf", "1.6": "model-1_6.sdf"}


def test_model_and_link_are_named_by_the_safe_global_id(package):
    out, _ = package
    for info in read_models(out):
        assert info.name == info.link_name == info.sdf_file.parent.name
        assert "$" not in info.name


def test_masses_equal_the_bim_weights_and_inertia_is_physical(package):
    out, report = package
    model = frame_model()
    by_name = {e["model"]: e for e in report["converted"]}
    for info in read_models(out):
        element = model.element(by_name[info.name]["global_id"])
        if element.weight_kg:
            assert info.mass == pytest.approx(element.weight_kg, rel=1e-9)
        else:
            assert by_name[info.name]["weight_source"].startswith("assumed")
            assert info.mass == pytest.approx(0.4 * 0.4 * 0.02 * 7850)  # a steel base plate (IfcPlate)
        moments = np.linalg.eigvalsh(info.inertia)
        assert moments.min() > 0
        assert moments[0] + moments[1] >= moments[2] * (1 - 1e-9)


def test_column_pose_is_its_placement(package):
    out, report = package
    column = next(e for e in report["converted"] if e["ifc_class"] == "IfcColumn" and e["pose_xyz_rpy"][0] == 3.5)
    world = ET.parse(out / report["world_files"]["sim"]).getroot()
    include = next(i for i in world.iter("include") if i.findtext("name") == column["model"])
    assert include.findtext("uri") == f"model://{column['model']}"
    assert [float(v) for v in include.findtext("pose").split()] == [3.5, 0, 0, 0, 0, 0]


def test_visual_dae_is_z_up_in_metres_and_holds_the_local_mesh(package):
    out, report = package
    column = next(e for e in report["converted"] if e["ifc_class"] == "IfcColumn")
    dae = collada.Collada(str(out / "models" / column["model"] / "meshes" / f"{column['model']}.dae"))
    assert dae.assetInfo.upaxis == "Z_UP"
    assert dae.assetInfo.unitmeter == 1.0
    vertices = dae.geometries[0].primitives[0].vertex
    np.testing.assert_allclose(vertices.min(axis=0), [-0.125, -0.125, 0.0], atol=1e-6)
    np.testing.assert_allclose(vertices.max(axis=0), [0.125, 0.125, 4.0], atol=1e-6)


def test_report_says_what_was_skipped_and_where_each_weight_came_from(package):
    out, report = package
    on_disk = json.loads((out / "report.json").read_text())
    assert on_disk["skipped"] == [
        {"global_id": "0Weld$0000000000000000", "ifc_class": "IfcFastener", "name": "weld",
         "reason": "curve-only geometry (no solid)"}
    ]
    assert on_disk["counts"]["weight_sources"] == {
        "IfcQuantityWeight": 6,
        "assumed: volume x steel 7850 kg/m3 (--unknown-weight)": 1,
    }
    assert on_disk["counts"]["total_mass_kg"] == pytest.approx(4 * 289.81 + 2 * 134.39 + 0.4 * 0.4 * 0.02 * 7850)
    unknown = on_disk["unknown_weight"]
    assert unknown["rule"].startswith("assume volume x 2400 kg/m3, or by class and material") and unknown["by_class"] == {"IfcPlate": 1}
    assert unknown["elements"] == {"2Plate$000000000000000": pytest.approx(0.4 * 0.4 * 0.02 * 7850)}
    assert unknown["message"].startswith("1 element(s) have no weight in the model (1 IfcPlate)")


@pytest.mark.sdf
@needs_ign
def test_worlds_and_models_pass_the_sdformat_validator(package):
    out, report = package
    for world in report["world_files"].values():
        valid, output = validate_sdf(out / world, out / "models")
        assert valid, output
    for info in read_models(out):
        valid, output = validate_sdf(info.sdf_file, out / "models")
        assert valid, f"{info.sdf_file}: {output}"


@pytest.mark.sdf
@needs_ign
def test_classic_target_writes_a_valid_sdf_1_6_world(tmp_path):
    out = tmp_path / "classic"
    report = build_package(frame_model(), out, ConvertOptions(target="classic"))
    assert report["world_files"] == {"classic": "worlds/test_site.world"}
    root = ET.parse(out / "worlds" / "test_site.world").getroot()
    assert root.get("version") == "1.6"
    assert {info.version for info in read_models(out)} == {"1.6"}
    valid, output = validate_sdf(out / "worlds" / "test_site.world", out / "models")
    assert valid, output
    assert (out / "launch" / "gazebo_classic.launch").exists()
    assert not (out / "launch" / "gz_sim.launch.py").exists()


def test_map_shows_the_columns_at_their_pixels_and_free_space_between(package):
    out, report = package
    level_1 = next(m for m in report["maps"] if m["storey_name"] == "Level 1")
    meta, occupied = read_map(out / level_1["yaml"])
    assert meta["resolution"] == 0.05 and meta["mode"] == "trinary"
    origin_x, origin_y = meta["origin"][:2]
    rows = occupied.shape[0]

    def cell(x, y):
        return rows - 1 - int(np.floor((y - origin_y) / 0.05)), int(np.floor((x - origin_x) / 0.05))

    for x, y in COLUMN_XY:
        assert occupied[cell(x, y)], f"column at ({x}, {y}) is not on the map"
        assert occupied[cell(x + 0.08, y - 0.08)]
        assert not occupied[cell(x + COLUMN_SIZE[0] / 2 + 0.1, y)]
    assert not occupied[cell(1.75, 1.4)]  # the middle of the bay
    # 4 columns of 0.25 m x 0.25 m: 5 x 5 cells each, 6 x 6 where their faces split cells (the plate
    # lies below the band).
    assert 4 * 25 <= occupied.sum() <= 4 * 36
    level_2 = next(m for m in report["maps"] if m["storey_name"] == "Level 2")
    assert level_2["occupied_cells"] == 0  # beams at 3.7-4.0 m lie below Level 2's band (4.1-5.5 m)


def test_lowering_the_band_puts_the_beams_on_the_map(tmp_path):
    report = build_package(frame_model(), tmp_path / "p", ConvertOptions(map_band=(-0.5, 0.5)))
    level_2 = next(m for m in report["maps"] if m["storey_name"] == "Level 2")
    _, occupied = read_map(tmp_path / "p" / level_2["yaml"])
    # Two 3.5 m x 0.15 m beams plus the column tops (3.5-4.0 m) in the 3.5-4.5 m band.
    assert 2 * 70 * 3 <= occupied.sum() <= 2 * 72 * 5 + 4 * 36


def test_launch_files_point_at_the_worlds_and_models(package):
    out, report = package
    launch_py = out / "launch" / "gz_sim.launch.py"
    py_compile.compile(str(launch_py), doraise=True)
    text = launch_py.read_text()
    assert "GZ_SIM_RESOURCE_PATH" in text and "ros_gz_sim" in text and "gz_sim.launch.py" in text
    assert "'test_site.sdf'" in text
    ros1 = ET.parse(out / "launch" / "gazebo_classic.launch").getroot()
    assert ros1.find("env").get("name") == "GAZEBO_MODEL_PATH"
    assert ros1.find("arg").get("default").endswith("/worlds/test_site.world")
    package_xml = ET.parse(out / "package.xml").getroot()
    assert package_xml.findtext("name") == "frame_pkg"
    assert "install(DIRECTORY launch models worlds maps" in (out / "CMakeLists.txt").read_text()


def test_yard_layout_lays_components_on_the_ground_beside_the_building(tmp_path):
    model = frame_model()
    report = build_package(model, tmp_path / "yard", ConvertOptions(layout="yard"))
    building_max_x = max(e.world_bounds[1][0] for e in model.elements.values())
    boxes = []
    infos = {info.name: info for info in read_models(tmp_path / "yard")}
    for entry in report["converted"]:
        element = model.element(entry["global_id"])
        pose = _matrix(entry["pose_xyz_rpy"])
        world = np.c_[element.vertices, np.ones(len(element.vertices))] @ pose.T
        lower, upper = world[:, :3].min(axis=0), world[:, :3].max(axis=0)
        assert lower[2] == pytest.approx(0.0, abs=1e-6)  # resting on the ground (lowest storey, 0 m)
        assert lower[0] > building_max_x  # beside the building
        assert upper[2] - lower[2] <= 0.3 + 1e-6  # laid flat: the 4 m columns lie down
        assert not infos[entry["model"]].static  # the yard is for picking up: dynamic by default
        boxes.append((lower, upper))
    for i, (lower_a, upper_a) in enumerate(boxes):
        for lower_b, upper_b in boxes[i + 1:]:
            overlap = np.minimum(upper_a[:2], upper_b[:2]) - np.maximum(lower_a[:2], lower_b[:2])
            assert (overlap <= 1e-9).any(), "two components overlap on the yard"
    assert report["yard"]["bounds_xy_m"][0][0] > building_max_x


def _matrix(xyz_rpy):
    from scipy.spatial.transform import Rotation

    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", xyz_rpy[3:]).as_matrix()
    matrix[:3, 3] = xyz_rpy[:3]
    return matrix


def test_static_flag_is_configurable_and_buried_dynamic_parts_are_warned_about(tmp_path):
    report = build_package(frame_model(), tmp_path / "dyn", ConvertOptions(static=False))
    assert not any(info.static for info in read_models(tmp_path / "dyn"))
    # The base plate lies 20 mm below the ground (Level 1 at 0 m): dynamic, it would be pushed up.
    assert any("1 dynamic model(s) reach below the ground plane at z = 0 m" in w for w in report["warnings"])
    assert report["unknown_weight"]["count"] == 1


def test_a_weight_no_material_can_have_is_warned_about_and_marked_in_the_report(tmp_path):
    """A column weighing 289,810 kg (grams written as kilograms): 1.2 million kg/m3 is no material."""
    model = frame_model()
    column = next(e for e in model.elements.values() if e.ifc_class == "IfcColumn")
    column.weight_kg = 289_810.0
    report = build_package(model, tmp_path / "pkg", ConvertOptions())
    (warning,) = [w for w in report["warnings"] if "not plausible" in w]
    assert warning.startswith("1 model(s) have a weight from the model that is not plausible") and column.global_id in warning
    suspect = {entry["global_id"]: entry["weight_suspect"] for entry in report["converted"] if "weight_suspect" in entry}
    assert list(suspect) == [column.global_id] and "is outside 50-8,100 kg/m3" in suspect[column.global_id]
    # the mass stays the model's: the warning says so, nothing is silently changed
    assert next(e for e in report["converted"] if e["global_id"] == column.global_id)["mass_kg"] == 289_810.0


def test_decimated_collision_respects_the_triangle_budget(tmp_path):
    import trimesh

    pytest.importorskip("fast_simplification", reason="the quadric decimator (pip install fast-simplification)")
    model = frame_model()
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.5)
    element = next(iter(model.elements.values()))
    element.vertices, element.faces = np.asarray(sphere.vertices), np.asarray(sphere.faces)
    report = build_package(model, tmp_path / "dec", ConvertOptions(collision="decimated", max_triangles=200))
    entry = next(e for e in report["converted"] if e["global_id"] == element.global_id)
    assert entry["visual_triangles"] == len(sphere.faces)
    assert entry["collision_triangles"] <= 200
    stl = trimesh.load(tmp_path / "dec" / "models" / entry["model"] / "meshes" / f"{entry['model']}_collision.stl")
    assert len(stl.faces) == entry["collision_triangles"]


def test_model_without_elements_is_refused_and_leaves_no_output(tmp_path):
    model = frame_model()
    model.elements.clear()
    with pytest.raises(InputError, match="no element with solid geometry"):
        build_package(model, tmp_path / "empty")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "options, message",
    [
        (ConvertOptions(target="gazebo"), "--target"),
        (ConvertOptions(map_band=(1.5, 0.1)), "--map-band"),
        (ConvertOptions(max_triangles=2), "--max-triangles"),
        (ConvertOptions(map_resolution=0), "--map-resolution"),
    ],
)
def test_bad_options_are_refused_with_the_option_named(tmp_path, options, message):
    with pytest.raises(InputError, match=message):
        build_package(frame_model(), tmp_path / "bad", options)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "site, source, expected",
    [
        ("Construction site", "frame.ifc", "construction_site"),
        ("Topography : Surface", "ifcUnit.ifc", "ifcunit"),  # Revit's default site name
        ("Default", "engine_web-ifc_example.ifc", "engine_web_ifc_example"),
        ("表面:335313", "ifcColumn.ifc", "ifccolumn"),
        ("Undefined", "MULTICOM-trappen_bordessen.ifc", "multicom_trappen_bordessen"),  # Tekla's default
        ("Site #1", "construction-scheduling-task.ifc", "construction_scheduling_task"),
        ("Site", "ROOT-staal.ifczip", "root_staal"),
        ("", None, "test_frame"),
        ("Undefined", "Undefined.ifc", "test_frame"),  # the file name says nothing either: the project
    ],
)
def test_world_is_named_by_the_site_unless_the_site_name_is_a_tool_default(site, source, expected):
    from bimrobot.export.gazebo.naming import world_name_of

    model = frame_model()
    model.site_name, model.source = site, Path(source) if source else None
    assert world_name_of(model) == expected


def test_unknown_weight_refuse_lists_the_classes_and_writes_nothing(tmp_path):
    from bimrobot.bim.unknown_weight import UnknownWeightRule

    with pytest.raises(InputError, match=r"1 element\(s\) have no weight in the model \(1 IfcPlate, e\.g\. 2Plate"):
        build_package(frame_model(), tmp_path / "refused", ConvertOptions(unknown_weight=UnknownWeightRule(None)))
    assert list(tmp_path.iterdir()) == []


def test_physics_fallback_uses_the_same_rule_for_a_body_without_closed_volume(tmp_path):
    """A flat plate (no closed volume): the rule cannot price it, physics does, with the same density."""
    from bimrobot.bim.unknown_weight import UnknownWeightRule

    model = frame_model()
    plate = model.element("2Plate$000000000000000")
    plate.vertices = np.array([[0, 0, 0], [0.4, 0, 0], [0.4, 0.4, 0], [0, 0.4, 0]], float)
    plate.faces = np.array([[0, 1, 2], [0, 2, 3]])
    report = build_package(model, tmp_path / "p", ConvertOptions(unknown_weight=UnknownWeightRule(1000.0), maps=False))
    entry = next(e for e in report["converted"] if e["global_id"] == plate.global_id)
    assert entry["weight_source"] == "assumed: volume x 1000 kg/m3 (--unknown-weight)"
    assert entry["mass_kg"] == pytest.approx(0.4 * 0.4 * 0.001 * 1000)  # box of the minimum thickness
    assert report["unknown_weight"]["elements"][plate.global_id] == pytest.approx(entry["mass_kg"], abs=1e-3)


def test_hostile_names_and_ids_stay_out_of_the_xml_and_file_names(tmp_path):
    """Ids and names with control characters, '/', '..', '__model__' or 300 characters: every file
    name is portable, every XML file parses, no control character is written raw."""
    import re

    from bimrobot.core.names import global_id_from_safe_name, is_shortened

    model = frame_model()
    hostile = ["__model__", "../../etc/passwd", "bell\x07\x1b[31mred", "world", "x" * 300]
    originals = list(model.elements.values())
    model.elements = {}
    for element, new_id in zip(originals, hostile + [e.global_id for e in originals[len(hostile):]]):
        element.global_id = new_id
        element.name = "name with \x00 NUL, \x1b escape & <tag> and\nnewline"
        model.elements[new_id] = element
    model.site_name = "Site\x01"
    model.source = Path("weird -- \x02name.ifc")
    out = tmp_path / "p"
    report = build_package(model, out, ConvertOptions(target="both"))
    assert report["counts"]["converted"] == len(model.elements) == len(list((out / "models").iterdir()))
    for path in out.rglob("*"):
        name = path.name
        assert re.fullmatch(r"[A-Za-z0-9_.\-]+", name) and name not in (".", "..") and len(name) <= 255, name
        if path.is_file() and path.suffix in {".sdf", ".world", ".config", ".launch", ".xml", ".dae", ".py", ".yaml", ".md", ".json"}:
            text = path.read_text(encoding="utf-8")
            assert not re.search(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]", text), path
            if path.suffix in {".sdf", ".world", ".config", ".launch", ".xml", ".dae"}:
                ET.parse(path)  # well-formed XML
    py_compile.compile(str(out / "launch" / "gz_sim.launch.py"), doraise=True)
    names = {e["global_id"]: e["model"] for e in report["converted"]}
    assert names["__model__"] == "__model_.5f" and names["world"] == "worl.64"
    for global_id, name in names.items():
        if is_shortened(name):
            assert global_id == "x" * 300 and len(name) <= 200
        else:
            assert global_id_from_safe_name(name) == global_id
    config = ET.parse(out / "models" / names["world"] / "model.config").getroot()
    assert "\\x00 NUL" in config.findtext("description") and "<tag>" in config.findtext("description")
    assert not (out / "worlds" / "site.sdf").exists()


def test_maps_of_storeys_with_tool_default_names_are_numbered(tmp_path):
    from bimrobot.bim.model import Storey

    model = frame_model()
    model.storeys = [Storey("3storey1$$$$$$$$$$$$$$", "Undefined", 0.0), Storey("3storey2$$$$$$$$$$$$$$", "Level 2", 4.0)]
    report = build_package(model, tmp_path / "p", ConvertOptions())
    assert [m["yaml"] for m in report["maps"]] == ["maps/storey_1.yaml", "maps/level_2.yaml"]
    assert report["maps"][0]["storey_name"] == "Undefined"


def test_duplicate_keys_are_distinct_models(tmp_path):
    model = frame_model()
    first = next(iter(model.elements.values()))
    twin = box_element(f"{first.global_id}#99", "IfcColumn", COLUMN_SIZE, first.placement.copy(), 289.81)
    model.elements[twin.global_id] = twin
    report = build_package(model, tmp_path / "p", ConvertOptions(maps=False))
    assert report["counts"]["converted"] == 8 == len(list((tmp_path / "p" / "models").iterdir()))
    assert report["duplicate_global_ids"] == {first.global_id: [first.global_id, twin.global_id]}


def test_render_draws_a_png_it_can_replace_and_refuses_a_foreign_file(package, tmp_path):
    from PIL import Image

    from bimrobot.core import io
    from bimrobot.export.gazebo.render import render_package

    out, _ = package
    picture = render_package(out, tmp_path / "frame.png", size=(3, 2))
    assert io.has_signature(picture) and Image.open(picture).size[0] > 100
    render_package(out, picture, size=(3, 2))  # bimrobot's own picture: replaced
    photo = tmp_path / "photo.png"
    photo.write_bytes(b"\x89PNG\r\n\x1a\n not bimrobot's")
    with pytest.raises(InputError, match="existing file that bimrobot did not write"):
        render_package(out, photo)
    assert photo.read_bytes() == b"\x89PNG\r\n\x1a\n not bimrobot's"


def test_model_files_are_the_text_elementtree_would_write():
    """model.sdf and model.config come from text templates (fast): the same bytes as serialising the
    ElementTree, escaping of hostile names and descriptions included."""
    from bimrobot.export.gazebo import sdf

    rotation = np.eye(4)
    rotation[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    rotation[:3, 3] = (1.25, -3e-7, 1e6)
    for name, static in (("2O2Fr-t4X7Zf8NOew3FLOH", True), ('a&b<c>"d\x01\n\té', False)):
        spec = sdf.ModelSpec(name=name, pose=rotation, static=static, mass=1234.5678901,
                             center_of_mass=np.array([0.1, -0.0, 1e-19]),
                             inertia=np.array([[1.0, -2e-17, 0.3], [-2e-17, 2.0, 0.0], [0.3, 0.0, 3.0]]),
                             visual_uri=f"model://{name}/meshes/{name}.dae",
                             collision_uri=f"model://{name}/meshes/{name}_collision.stl")
        for version in (sdf.SIM_VERSION, sdf.CLASSIC_VERSION):
            tree = ET.Element("sdf", version=version)
            tree.append(sdf.model_element(spec))
            assert sdf.model_sdf(spec, version) == sdf._to_text(tree)
        versions = {sdf.SIM_VERSION: "model.sdf", sdf.CLASSIC_VERSION: "model-1_6.sdf"}
        description = f'IfcBeam "{name}" & <more> (IFC GlobalId x) from /tmp/a&b.ifc'
        assert sdf.model_config(name, versions, description) == sdf._to_text(sdf.model_config_tree(name, versions, description))


def test_preview_is_a_picture_of_the_world_unless_switched_off(tmp_path):
    from PIL import Image

    drawn = build_package(frame_model(), tmp_path / "drawn", ConvertOptions())
    assert drawn["preview"] == "preview.png"
    picture = np.asarray(Image.open(tmp_path / "drawn" / "preview.png").convert("L"), float)
    assert picture.shape == (660, 880) and picture.std() > 10  # the structure drawn on white, not a blank page
    assert (picture < 200).mean() > 0.05
    none = build_package(frame_model(), tmp_path / "none", ConvertOptions(preview=False))
    assert none["preview"] is None and not (tmp_path / "none" / "preview.png").exists()


def test_preview_drawn_from_memory_is_the_picture_the_written_files_give(tmp_path):
    """convert draws preview.png from the meshes in memory while the models are being written; it must
    be the very picture that the package's own files (world includes, model DAEs) give when read back."""
    from bimrobot.export.gazebo.render import render_package

    report = build_package(frame_model(), tmp_path / "pkg", ConvertOptions(target="both", workers=2))
    again = render_package(tmp_path / "pkg", tmp_path / "again.png", world_file=report["world_files"]["sim"],
                           title=f"{report['world']} (metres, z up)")
    assert (tmp_path / "pkg" / "preview.png").read_bytes() == again.read_bytes()


def test_a_failing_conversion_leaves_nothing(tmp_path, monkeypatch):
    from bimrobot.export.gazebo import package as package_module

    def fail(*args, **kwargs):
        raise InputError("stop here")

    monkeypatch.setattr(package_module, "package_report", fail)  # after the models are written
    with pytest.raises(InputError, match="stop here"):
        build_package(frame_model(), tmp_path / "pkg", ConvertOptions())
    assert list(tmp_path.iterdir()) == []


def test_mesh_normals_use_the_same_cross_products_as_numpy():
    """meshes.cross (faster on small meshes) gives np.cross's bits, so DAE and STL files are unchanged."""
    from bimrobot.export.gazebo.meshes import cross

    rng = np.random.default_rng(7)
    for rows in (1, 12, 500):
        a = rng.normal(size=(rows, 3)) * rng.uniform(1e-6, 1e6, size=(rows, 1))
        b = rng.normal(size=(rows, 3))
        assert cross(a, b).tobytes() == np.cross(a, b).tobytes()


def test_bodies_holding_the_same_numbers_are_meshed_once(tmp_path, monkeypatch):
    """Elements whose bodies hold the same numbers in arrays of their own (Tekla writes each precast part's
    body anew: MULTICOM-Prefab's 301 elements have 121 distinct bodies) share one hull, mass integrals, STL
    and DAE: the frame's four columns (four boxes made one by one), two beams and a plate give three hulls,
    and the four columns' mesh files are the same bytes, each model with its own BIM weight."""
    from bimrobot.export import inertia

    hulls = []
    real_hull = inertia.convex_hull
    monkeypatch.setattr(inertia, "convex_hull", lambda vertices: hulls.append(len(vertices)) or real_hull(vertices))
    build_package(frame_model(), tmp_path / "pkg", ConvertOptions(workers=1))
    assert len(hulls) == 3
    columns = sorted((tmp_path / "pkg" / "models").glob("0Col*"))
    assert len(columns) == 4
    meshes = {(next(c.glob("meshes/*.dae")).read_bytes(), next(c.glob("meshes/*.stl")).read_bytes()) for c in columns}
    assert len(meshes) == 1
    masses = [float(ET.parse(c / "model.sdf").getroot().findtext(".//inertial/mass")) for c in columns]
    assert masses == [289.81] * 4
