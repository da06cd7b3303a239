"""Large packages: the same package from one process or many, merged static models, validation in batches."""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from bimrobot.core.errors import InputError
from bimrobot.export.gazebo.check import problems, read_models, sdf_validator, validate_world
from bimrobot.export.gazebo.package import ConvertOptions, build_package

from .conftest import BEAM_SIZE, frame_model


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """trimesh (about 1 s of imports with SciPy and networkx), imported when these tests run, not at collection."""
    global trimesh
    import trimesh


needs_ign = pytest.mark.skipif(sdf_validator() is None, reason="`ign sdf` is not installed (ignition-tools)")

WRITTEN_PER_RUN = {".bimrobot-output.json", "report.json"}  # the time of writing, the timings


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_package_is_the_same_whether_written_by_one_process_or_several(tmp_path):
    one = build_package(frame_model(), tmp_path / "one" / "pkg", ConvertOptions(target="both", workers=1))
    many = build_package(frame_model(), tmp_path / "many" / "pkg", ConvertOptions(target="both", workers=3))
    first, second = _files(tmp_path / "one" / "pkg"), _files(tmp_path / "many" / "pkg")
    assert first.keys() == second.keys()
    differing = [name for name in first if first[name] != second[name] and name not in WRITTEN_PER_RUN]
    assert differing == []
    assert one["converted"] == many["converted"]  # masses, poses, triangle counts per element
    assert one["maps"] == many["maps"]


def _world_includes(out: Path, report: dict) -> list[str]:
    world = ET.parse(out / report["world_files"]["sim"]).getroot()
    return [include.findtext("name") for include in world.iter("include")]


def test_merge_static_keeps_robot_parts_as_models_and_merges_the_rest_per_storey_and_class(tmp_path):
    out = tmp_path / "merged"
    report = build_package(frame_model(), out, ConvertOptions(merge_static=True, keep_separate=("IfcColumn",)))
    columns = [e["model"] for e in report["converted"] if e["ifc_class"] == "IfcColumn"]
    beams = {e["model"] for e in report["converted"] if e["ifc_class"] == "IfcBeam"}
    assert len(set(columns)) == 4 and all(c == e for c, e in zip(columns, [e["model"] for e in report["converted"]][:4]))
    assert beams == {"merged_level_1_ifcbeam"}
    assert sorted(_world_includes(out, report)) == sorted(columns + ["merged_level_1_ifcbeam", "merged_level_1_ifcplate"])
    assert report["counts"]["models"] == 6 == len(list((out / "models").iterdir()))
    assert problems(out) == []
    merged = {m["model"]: m for m in report["merged_models"]}
    assert merged["merged_level_1_ifcbeam"]["elements"] == 2
    assert merged["merged_level_1_ifcbeam"]["mass_kg"] == pytest.approx(2 * 134.39)


def test_merged_model_has_the_exact_inertia_of_its_elements_together(tmp_path):
    out = tmp_path / "merged"
    build_package(frame_model(), out, ConvertOptions(merge_static=True, keep_separate=("IfcColumn", "IfcPlate")))
    info = next(i for i in read_models(out) if i.name == "merged_level_1_ifcbeam")
    pose = np.array([float(v) for v in info.pose.split()])
    assert np.allclose(pose[3:], 0)  # a translation only: the model frame is the world frame moved
    # The two beams as one solid of uniform density (equal masses, equal volumes), in the model frame.
    beams = [trimesh.creation.box(extents=BEAM_SIZE).apply_translation((1.75, y, 4.0 - 0.15) - pose[:3]) for y in (0.0, 2.846)]
    union = trimesh.util.concatenate(beams)
    union.density = 2 * 134.39 / union.volume
    assert info.mass == pytest.approx(2 * 134.39)
    assert np.allclose(info.center_of_mass, union.center_mass, atol=1e-6)
    assert np.allclose(info.inertia, union.moment_inertia, rtol=1e-6, atol=1e-6)


def test_keep_separate_takes_subclasses_and_refuses_unknown_classes(tmp_path):
    report = build_package(frame_model(), tmp_path / "kept", ConvertOptions(merge_static=True,
                                                                          keep_separate=("IfcBuildingElement",)))
    assert "merged_models" not in report and report["counts"]["models"] == 7  # columns, beams, plate: all building elements
    with pytest.raises(InputError, match="--keep-separate names 'IfcColumm'.*IfcBeam, IfcColumn, IfcPlate"):
        build_package(frame_model(), tmp_path / "bad", ConvertOptions(merge_static=True, keep_separate=("IfcColumm",)))
    assert not (tmp_path / "bad").exists()


def test_merge_static_is_refused_for_dynamic_models(tmp_path):
    with pytest.raises(InputError, match="--merge-static merges static models"):
        build_package(frame_model(), tmp_path / "yard", ConvertOptions(merge_static=True, layout="yard"))


@pytest.mark.sdf
@needs_ign
def test_validate_world_checks_each_distinct_model_once_and_names_what_fails(tmp_path):
    out = tmp_path / "pkg"
    report = build_package(frame_model(), out, ConvertOptions())
    world = out / report["world_files"]["sim"]
    result = validate_world(world, out / "models", batch=2)
    # 4 identical columns, 2 identical beams and a plate: 3 distinct models, in 2 documents of at most 2.
    assert result.valid, result.errors
    assert (result.includes, result.distinct, result.batches) == (7, 3, 2)

    beam = next(e["model"] for e in report["converted"] if e["ifc_class"] == "IfcBeam")
    sdf_file = out / "models" / beam / "model.sdf"
    sdf_file.write_text(sdf_file.read_text().replace("<static>true</static>", "<static>maybe</static>"))
    broken = validate_world(world, out / "models")
    assert not broken.valid and broken.distinct == 4  # the edited beam is no longer its twin's copy
    assert [line for line in broken.errors if "ign sdf -k" in line and repr(beam) in line]  # named

    shutil.rmtree(out / "models" / beam)
    missing = validate_world(world, out / "models")
    assert not missing.valid
    assert any(f"'model://{beam}' does not resolve" in line for line in missing.errors)


@pytest.mark.sdf
@needs_ign
def test_merged_package_passes_the_validator(tmp_path):
    out = tmp_path / "merged"
    report = build_package(frame_model(), out, ConvertOptions(target="both", merge_static=True))
    for world in report["world_files"].values():
        result = validate_world(out / world, out / "models")
        assert result.valid, result.errors
        assert result.includes == 3  # columns, beams, plate: one model each on the one storey
    assert json.loads((out / "report.json").read_text())["counts"]["models"] == 3


def test_cli_merge_static_keeps_the_named_classes_and_validates(tmp_path, monkeypatch, capsys, steel_frame_ifc):
    from bimrobot.cli import main

    ifc = steel_frame_ifc
    monkeypatch.chdir(tmp_path)
    status = main(["convert", str(ifc), "-o", "pkg", "--merge-static", "--keep-separate", "IfcColumn, IfcBeam",
                   "--validate", "--no-progress"])
    out = capsys.readouterr().out
    assert status == 0, out
    report = json.loads((tmp_path / "pkg" / "report.json").read_text())
    separate = report["counts"]["by_class"]["IfcColumn"] + report["counts"]["by_class"]["IfcBeam"]
    merged = report["merged_models"]
    assert report["counts"]["models"] == separate + len(merged)
    assert {m["ifc_class"] for m in merged} == set(report["counts"]["by_class"]) - {"IfcColumn", "IfcBeam"}
    assert f"merged:   {report['counts']['converted'] - separate} static elements into {len(merged)} models" in out
    if sdf_validator():
        assert ": Valid (" in out and "distinct models" in out


def test_cli_keep_separate_takes_class_names_only(tmp_path, capsys):
    from bimrobot.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main(["convert", str(tmp_path / "x.ifc"), "-o", str(tmp_path / "pkg"), "--merge-static",
              "--keep-separate", "beams"])
    assert exit_info.value.code == 2
    assert "--keep-separate: expected IFC class names" in capsys.readouterr().err
    assert not (tmp_path / "pkg").exists()
