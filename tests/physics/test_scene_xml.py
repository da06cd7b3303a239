"""Issue 35: ``scene.xml`` was not well-formed XML (its header comment held ``--``) and took control
characters from the model raw. It parses with xml.etree and loads in MuJoCo, whatever the names."""

import importlib.util
import xml.etree.ElementTree as ET

import pytest

# found, not imported: MuJoCo is imported when the tests run, not at collection
if importlib.util.find_spec("mujoco") is None:
    pytest.skip("mujoco not installed (the physics extra)", allow_module_level=True)

from bimrobot.export.gazebo.package import ConvertOptions, build_package  # noqa: E402

from mujoco_helpers import world_fixtures  # noqa: E402


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """MuJoCo (about 0.3 s of imports), imported when these tests run, not at collection."""
    global mujoco
    import mujoco

DAMAGED_ID = "0Col0$abc_def\r\x01\x1bklmno"


def test_scene_xml_is_well_formed_with_control_characters_in_ids_and_names(tmp_path):
    model = world_fixtures.frame_model()
    column = model.elements.pop("0Col0$abc_defghijklmno")
    column.global_id, column.name = DAMAGED_ID, "Column\r\nC1 \x07"
    model.elements[DAMAGED_ID] = column
    build_package(model, tmp_path / "scene", ConvertOptions(target="mujoco", maps=False))
    path = tmp_path / "scene" / "mujoco" / "scene.xml"
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!-- written by bimrobot ") and "--target" not in text
    assert not any(ord(c) < 32 and c not in "\n\t" for c in text)  # no raw control character (the \r neither)
    root = ET.parse(path).getroot()  # well-formed: the comment holds no '--'
    names = {body.get("name") for body in root.iter("body")}
    assert "0Col0$abc_def\\r\\x01\\x1bklmno" in names  # kept, escaped, legible
    loaded = mujoco.MjModel.from_xml_path(str(path))
    assert loaded.nbody == len(model.elements) + 1  # every element and the world body
