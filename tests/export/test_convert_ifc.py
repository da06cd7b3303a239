"""End to end from real IFC files: the built-in examples and the shared test models."""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from bimrobot.bim import examples
from bimrobot.cli import main
from bimrobot.export.gazebo.check import problems, read_models, sdf_validator, validate_sdf, validate_world
from bimrobot.export.gazebo.naming import GENERIC_SITE_NAMES
from bimrobot.export.gazebo.conversion import ConvertOptions, convert
from output_checks import snapshot

needs_ign = pytest.mark.skipif(sdf_validator() is None, reason="`ign sdf` is not installed (ignition-tools)")


@pytest.fixture(scope="module")
def frame_package(tmp_path_factory, steel_frame_ifc):
    out = tmp_path_factory.mktemp("frame") / "frame_pkg"
    return out, convert(steel_frame_ifc, out, ConvertOptions(target="both"))


def test_steel_frame_package_holds_the_thesis_weights(frame_package):
    out, report = frame_package
    assert problems(out) == []
    masses = sorted(round(info.mass, 2) for info in read_models(out) if info.sdf_file.name == "model.sdf")
    assert masses.count(289.81) == 4  # the W250x73 columns
    assert masses.count(105.49) == 2 and masses.count(134.39) == 2  # the W310x38.7 beams
    assert report["counts"]["by_class"]["IfcColumn"] == 4


@pytest.mark.sdf
@needs_ign
def test_steel_frame_world_validates(frame_package):
    out, report = frame_package
    valid, output = validate_sdf(out / report["world_files"]["sim"], out / "models")
    assert valid, output


def test_ifc_unit_beam_mass_comes_from_revit_exact_weight(tmp_path, shared_ifc):
    out = tmp_path / "unit"
    report = convert(shared_ifc("ifcUnit.ifc"), out, ConvertOptions(maps=False))
    beams = [e for e in report["converted"] if e["ifc_class"] == "IfcBeam"]
    assert len(beams) == 8
    infos = {i.name: i for i in read_models(out)}
    short = [e for e in beams if e["weight_source"] == "weight property" and abs(e["bim_weight_kg"] - 109.28) < 0.01]
    assert short, "the 2.82 m W310X38.7 beam with Structural/Exact Weight 109.28 kg is missing"
    assert infos[short[0]["model"]].mass == pytest.approx(109.28, rel=0.005)
    # The angle cleats are exported as IfcColumn: they still become models.
    cleats = [e for e in report["converted"] if e["ifc_class"] == "IfcColumn" and "Cleat" in e["name"]]
    assert len(cleats) == 16
    # The four curve-only welds are reported, not converted.
    welds = [s for s in report["skipped"] if s["ifc_class"] == "IfcFastener"]
    assert len(welds) == 4 and all("curve" in s["reason"] for s in welds)
    assert problems(out) == []


@pytest.fixture
def cli(capsys, monkeypatch):
    """Run ``bimrobot ARGS`` in-process in a folder: (exit status, stdout, stderr)."""

    def run(*args: str, cwd: Path) -> tuple[int, str, str]:
        monkeypatch.chdir(cwd)
        status = main(list(args))
        captured = capsys.readouterr()
        return status, captured.out, captured.err

    return run


def test_cli_converts_and_prints_where_and_what(tmp_path, cli):
    ifc = examples.greenhouse(tmp_path / "greenhouse.ifc")
    status, out, err = cli("convert", str(ifc), "-o", "gh_pkg", "--include", "IfcColumn, IfcBeam", "--layout", "yard",
                           "--validate", cwd=tmp_path)
    assert status == 0, err
    assert "wrote gh_pkg/" in out and "19 (10 IfcBeam, 9 IfcColumn)" in out
    assert "check:    19 models: meshes present, masses and inertia physical" in out
    if sdf_validator():
        assert "ign sdf -k worlds/" in out and ": Valid" in out
    report = json.loads((tmp_path / "gh_pkg" / "report.json").read_text())
    assert report["counts"]["by_class"] == {"IfcBeam": 10, "IfcColumn": 9}
    assert report["yard"] is not None
    world = ET.parse(tmp_path / "gh_pkg" / report["world_files"]["sim"]).getroot()
    assert len(world.findall("world/include")) == 19


@pytest.mark.parametrize(
    "setup, args, message",
    [
        (None, ["missing.ifc"], "missing.ifc: no such file"),
        ("not IFC at all\n", ["bad.ifc"], "bad.ifc"),
        ("ISO-10303-21;\nHEADER;\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n#1=IFCPROJECT('0", ["bad.ifc"], "bad.ifc"),
        ("", ["frame.ifc", "--include", "Column"], "--include 'Column' is not a valid IfcOpenShell selector"),
        ("", ["frame.ifc", "--include", "IfcColumm"], "--include names 'IfcColumm', which is not an IFC4 class"),
        ("", ["frame.ifc", "--map-band", "2", "1"], "--map-band"),
    ],
)
def test_cli_bad_input_exits_2_with_one_sentence_and_no_output(tmp_path, cli, setup, args, message, steel_frame_ifc):
    if setup is not None and args[0] == "bad.ifc":
        (tmp_path / "bad.ifc").write_text(setup)
    if args[0] == "frame.ifc":
        shutil.copyfile(steel_frame_ifc, tmp_path / "frame.ifc")
    status, _, err = cli("convert", *args, "-o", "out_pkg", "--no-progress", cwd=tmp_path)
    assert status == 2, err
    assert message in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out_pkg").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out_pkg")]


@pytest.mark.parametrize("option", ["--unknown-weight", "--default-density"])
def test_cli_refuses_an_impossible_density(tmp_path, cli, option, steel_frame_ifc):
    shutil.copyfile(steel_frame_ifc, tmp_path / "frame.ifc")
    with pytest.raises(SystemExit) as exited:  # argparse: usage line and the error, exit 2
        cli("convert", "frame.ifc", "-o", "out_pkg", option, "0", cwd=tmp_path)
    assert exited.value.code == 2
    assert not (tmp_path / "out_pkg").exists()


@pytest.mark.parametrize(
    "output, message",
    [
        (".", "is the current directory"),
        ("frame.ifc", "is an input of this command"),
        ("..", "a folder that contains the current directory"),
        ("notes", "a folder that bimrobot did not write and it is not empty"),
        ("notes/thesis.txt", "is an existing file, not a folder"),
        ("notes/thesis.txt/pkg", "is a file, not a folder, so nothing can be written under it"),
        ("linked", "a folder that bimrobot did not write and it is not empty"),
    ],
)
def test_cli_refuses_outputs_that_would_destroy_data_and_leaves_them_byte_for_byte(tmp_path, cli, output, message,
                                                                                  steel_frame_ifc):
    project = tmp_path / "project"
    project.mkdir()
    shutil.copyfile(steel_frame_ifc, project / "frame.ifc")
    (project / "notes").mkdir()
    (project / "notes" / "thesis.txt").write_text("precious")
    (project / "linked").symlink_to(project / "notes")
    before = snapshot(tmp_path)
    status, out, err = cli("convert", "frame.ifc", "-o", output, cwd=project)
    assert status == 2, out
    assert message in err and len(err.strip().splitlines()) == 1
    assert snapshot(tmp_path) == before
    assert sorted(p.name for p in project.iterdir()) == ["frame.ifc", "linked", "notes"]


def test_cli_refuses_the_folder_holding_the_input_before_reading_it(tmp_path, cli, steel_frame_ifc):
    """The path is checked before the model is read: a huge model would otherwise be read for nothing."""
    (tmp_path / "models").mkdir()
    shutil.copyfile(steel_frame_ifc, tmp_path / "models" / "frame.ifc")
    status, _, err = cli("convert", "models/frame.ifc", "-o", "models", cwd=tmp_path)
    assert status == 2 and "contains an input of this command" in err
    (tmp_path / "models" / "frame.ifc").write_text("not IFC")  # refused before it is read: no parse error
    status, _, err = cli("convert", "models/frame.ifc", "-o", "models", cwd=tmp_path)
    assert status == 2 and "contains an input of this command" in err


def test_cli_replaces_its_own_package_and_says_so(tmp_path, cli):
    examples.greenhouse(tmp_path / "gh.ifc")
    assert cli("convert", "gh.ifc", "-o", "pkg", "--no-maps", cwd=tmp_path)[0] == 0
    (tmp_path / "pkg" / "notes.txt").write_text("the user's own")
    status, _, err = cli("convert", "gh.ifc", "-o", "pkg", "--no-maps", "--include", "IfcColumn", cwd=tmp_path)
    assert status == 2 and "notes.txt" in err  # a file added since is the user's: the folder is not replaced
    assert (tmp_path / "pkg" / "notes.txt").read_text() == "the user's own"
    (tmp_path / "pkg" / "notes.txt").unlink()
    status, _, err = cli("convert", "gh.ifc", "-o", "pkg", "--no-maps", "--include", "IfcColumn", cwd=tmp_path)
    assert status == 0
    (line,) = err.strip().splitlines()
    assert line.startswith("bimrobot: replacing pkg (convert output of gh.ifc, written ")
    assert line.endswith("the new one is from gh.ifc")
    assert len(list((tmp_path / "pkg" / "models").iterdir())) == 9


def _weightless_walls(path: Path, shared_global_id: bool = False, site: str = "Undefined") -> Path:
    """Three 5 m x 3 m x 0.2 m walls with no material and no weight; optionally two share a GlobalId."""
    import ifcopenshell.api.aggregate
    import ifcopenshell.api.context
    import ifcopenshell.api.geometry
    import ifcopenshell.api.project
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial
    import ifcopenshell.api.unit

    ifc = ifcopenshell.api.project.create_file(version="IFC4")
    project = ifcopenshell.api.root.create_entity(ifc, ifc_class="IfcProject", name="Walls")
    ifcopenshell.api.unit.assign_unit(ifc)
    model = ifcopenshell.api.context.add_context(ifc, context_type="Model")
    body = ifcopenshell.api.context.add_context(ifc, context_type="Model", context_identifier="Body",
                                                target_view="MODEL_VIEW", parent=model)
    site_entity = ifcopenshell.api.root.create_entity(ifc, ifc_class="IfcSite", name=site)
    ifcopenshell.api.aggregate.assign_object(ifc, products=[site_entity], relating_object=project)
    walls = []
    for index in range(3):
        wall = ifcopenshell.api.root.create_entity(ifc, ifc_class="IfcWall", name=f"Wall {index}")
        representation = ifcopenshell.api.geometry.add_wall_representation(ifc, context=body, length=5, height=3,
                                                                           thickness=0.2)
        ifcopenshell.api.geometry.assign_representation(ifc, product=wall, representation=representation)
        matrix = np.eye(4)
        matrix[1, 3] = 2.0 * index
        ifcopenshell.api.geometry.edit_object_placement(ifc, product=wall, matrix=matrix)
        ifcopenshell.api.spatial.assign_container(ifc, products=[wall], relating_structure=site_entity)
        walls.append(wall)
    if shared_global_id:
        walls[1].GlobalId = walls[0].GlobalId
    ifc.write(str(path))
    return path


def test_cli_unknown_weight_rule_is_reported_and_refuse_lists_the_classes(tmp_path, cli):
    _weightless_walls(tmp_path / "walls.ifc")
    status, out, err = cli("convert", "walls.ifc", "-o", "pkg", "--unknown-weight", "refuse", cwd=tmp_path)
    assert status == 2
    assert "3 element(s) have no weight in the model (3 IfcWall" in err and "--unknown-weight is refuse" in err
    assert not (tmp_path / "pkg").exists()
    status, out, err = cli("convert", "walls.ifc", "-o", "pkg", "--unknown-weight", "1800", cwd=tmp_path)
    assert status == 0, err
    assert "unknown:  3 element(s) have no weight in the model (3 IfcWall): assume volume x 1800 kg/m3" in out
    report = json.loads((tmp_path / "pkg" / "report.json").read_text())
    assert report["unknown_weight"]["count"] == 3 and report["unknown_weight"]["rule"] == "assume volume x 1800 kg/m3"
    wall_kg = 5 * 3 * 0.2 * 1800
    assert list(report["unknown_weight"]["elements"].values()) == [pytest.approx(wall_kg)] * 3
    assert [info.mass for info in read_models(tmp_path / "pkg")] == [pytest.approx(wall_kg)] * 3


def test_cli_deprecated_default_density_still_works(tmp_path, cli):
    _weightless_walls(tmp_path / "walls.ifc")
    status, out, err = cli("convert", "walls.ifc", "-o", "pkg", "--no-maps", "--default-density", "7850", cwd=tmp_path)
    assert status == 0
    assert "--default-density is deprecated; use --unknown-weight" in err
    assert "assume volume x 7850 kg/m3" in out


def test_cli_duplicate_global_ids_become_distinct_models_and_are_reported(tmp_path, cli):
    """Two walls share a GlobalId: three models, not two, and the user is told which entities."""
    _weightless_walls(tmp_path / "walls.ifc", shared_global_id=True)
    status, out, err = cli("convert", "walls.ifc", "-o", "pkg", "--validate", cwd=tmp_path)
    assert status == 0, out + err
    assert "models:   3 (3 IfcWall)" in out
    report = json.loads((tmp_path / "pkg" / "report.json").read_text())
    assert report["counts"]["converted"] == 3 == len(list((tmp_path / "pkg" / "models").iterdir()))
    (shared, keys), = report["duplicate_global_ids"].items()
    assert keys[0] == shared and keys[1].startswith(f"{shared}#")
    assert "1 GlobalId(s) are shared by several elements" in out
    world = ET.parse(tmp_path / "pkg" / report["world_files"]["sim"]).getroot()
    assert len(world.findall("world/include")) == 3


def test_generic_site_name_never_names_the_world(tmp_path):
    """Tekla's 'Undefined' site: the world is named after the file, never undefined.sdf."""
    ifc = _weightless_walls(tmp_path / "Stairs Block-A.ifc", site="Undefined")
    report = convert(ifc, tmp_path / "pkg", ConvertOptions(target="both"))
    assert report["world"] == "stairs_block_a"
    assert sorted(p.name for p in (tmp_path / "pkg" / "worlds").iterdir()) == ["stairs_block_a.sdf", "stairs_block_a.world"]


def test_ifczip_converts_like_the_ifc_inside(tmp_path):
    import zipfile

    ifc = examples.greenhouse(tmp_path / "greenhouse.ifc")
    archive = tmp_path / "greenhouse.ifczip"
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as zipped:
        zipped.write(ifc, "inside/greenhouse.ifc")
    report = convert(archive, tmp_path / "pkg", ConvertOptions(maps=False))
    plain = convert(ifc, tmp_path / "plain", ConvertOptions(maps=False))
    assert report["counts"] == plain["counts"]
    assert report["world"] == plain["world"] == "greenhouse_site"
    assert report["source"] == str(archive)
