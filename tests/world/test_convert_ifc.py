"""End to end from real IFC files: the built-in examples and the shared test models."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from bimrobot.bim import examples
from bimrobot.cli import main
from bimrobot.world.check import problems, read_models, sdf_validator, validate_sdf
from bimrobot.world.package import ConvertOptions, convert

SHARED_IFC = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "ifc"

needs_ign = pytest.mark.skipif(sdf_validator() is None, reason="`ign sdf` is not installed (ignition-tools)")
SHARED_FILES = sorted(p.name for p in SHARED_IFC.glob("*.ifc")) if SHARED_IFC.exists() else []


@pytest.fixture(scope="module")
def frame_package(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("frame")
    ifc = examples.steel_frame(tmp / "frame.ifc")
    out = tmp / "frame_pkg"
    return out, convert(ifc, out, ConvertOptions(target="both"))


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


def test_converted_beam_dropped_in_pybullet_rests_at_half_its_height(frame_package):
    pybullet = pytest.importorskip("pybullet")
    out, report = frame_package
    beam = next(e for e in report["converted"] if e["ifc_class"] == "IfcBeam")
    info = next(i for i in read_models(out) if i.name == beam["model"] and i.sdf_file.name == "model.sdf")
    stl = next(f for f in info.mesh_files if f.suffix == ".stl")
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
        plane = pybullet.createCollisionShape(pybullet.GEOM_PLANE, physicsClientId=client)
        pybullet.createMultiBody(0, plane, physicsClientId=client)
        shape = pybullet.createCollisionShape(pybullet.GEOM_MESH, fileName=str(stl), physicsClientId=client)
        # The link frame is the beam's local IFC frame; keep the installed orientation (web vertical)
        # and drop it from 0.5 m above the ground.
        pose = np.array(beam["pose_xyz_rpy"])
        orientation = pybullet.getQuaternionFromEuler(pose[3:].tolist())
        body = pybullet.createMultiBody(
            baseMass=info.mass,
            baseCollisionShapeIndex=shape,
            basePosition=[0, 0, 0.5 + 0.3],
            baseOrientation=orientation,
            baseInertialFramePosition=info.center_of_mass.tolist(),
            physicsClientId=client,
        )
        for _ in range(2400):  # 10 s at 240 Hz
            pybullet.stepSimulation(physicsClientId=client)
        lower, upper = pybullet.getAABB(body, physicsClientId=client)
        height = upper[2] - lower[2]
        com, _ = pybullet.getBasePositionAndOrientation(body, physicsClientId=client)
        velocity, _ = pybullet.getBaseVelocity(body, physicsClientId=client)
    finally:
        pybullet.disconnect(client)
    # W310x38.7: 310 mm deep. At rest its centre of mass sits at half the section height.
    assert np.linalg.norm(velocity) < 1e-3
    assert lower[2] == pytest.approx(0.0, abs=0.01)
    assert com[2] == pytest.approx(0.31 / 2, abs=0.01)
    assert height == pytest.approx(0.31, abs=0.02)


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


@pytest.mark.slow
@pytest.mark.sdf
@needs_ign
@pytest.mark.parametrize("name", SHARED_FILES or ["(no shared data)"])
def test_every_shared_ifc_file_converts_to_a_valid_package(tmp_path, shared_ifc, name):
    out = tmp_path / "pkg"
    report = convert(shared_ifc(name), out, ConvertOptions())  # SDF 1.6 is checked on the synthetic frame
    assert report["counts"]["converted"] > 0
    assert problems(out) == []
    for world in report["world_files"].values():
        valid, output = validate_sdf(out / world, out / "models")
        assert valid, f"{name} {world}: {output}"
    for entry in report["maps"]:
        assert (out / entry["image"]).stat().st_size > 0


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
        ("", ["frame.ifc", "--include", "Column"], "--include expects IFC class names"),
        ("", ["frame.ifc", "--map-band", "2", "1"], "--map-band"),
        ("", ["frame.ifc", "--default-density", "0"], "--default-density"),
    ],
)
def test_cli_bad_input_exits_2_with_one_sentence_and_no_output(tmp_path, cli, setup, args, message):
    if setup is not None and args[0] == "bad.ifc":
        (tmp_path / "bad.ifc").write_text(setup)
    if args[0] == "frame.ifc":
        examples.steel_frame(tmp_path / "frame.ifc")
    status, _, err = cli("convert", *args, "-o", "out_pkg", "--no-progress", cwd=tmp_path)
    assert status == 2, err
    assert message in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out_pkg").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out_pkg")]


def test_cli_refuses_to_overwrite_a_folder_it_did_not_write(tmp_path, cli):
    examples.steel_frame(tmp_path / "frame.ifc")
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "thesis.txt").write_text("precious")
    status, _, err = cli("convert", "frame.ifc", "-o", "notes", cwd=tmp_path)
    assert status == 2 and "did not write" in err
    assert (tmp_path / "notes" / "thesis.txt").read_text() == "precious"


def test_steel_frame_map_shows_the_four_columns_and_a_free_bay(frame_package):
    from bimrobot.bim import load_model
    from bimrobot.world.navmap import read_map

    out, report = frame_package
    model = load_model(report["source"])
    level_1 = next(m for m in report["maps"] if m["storey_name"] == "Level 1")
    meta, occupied = read_map(out / level_1["yaml"])
    origin_x, origin_y = meta["origin"][:2]

    def occupied_at(x, y):
        row = occupied.shape[0] - 1 - int(np.floor((y - origin_y) / meta["resolution"]))
        return bool(occupied[row, int(np.floor((x - origin_x) / meta["resolution"]))])

    columns = model.by_class("IfcColumn")
    assert len(columns) == 4
    for column in columns:
        x, y = column.centroid[:2]
        assert occupied_at(x, y), f"column {column.name} at ({x:.2f}, {y:.2f}) m is not on the map"
    centre = np.mean([c.centroid[:2] for c in columns], axis=0)
    assert not occupied_at(*centre)


def test_yard_components_lie_still_on_the_ground_in_pybullet(tmp_path):
    """Every pick-up pose is a resting pose: simulated for 2 s, no component moves more than 1 cm."""
    pybullet = pytest.importorskip("pybullet")
    ifc = examples.steel_frame(tmp_path / "frame.ifc")
    out = tmp_path / "yard"
    report = convert(ifc, out, ConvertOptions(layout="yard", maps=False), exclude=["IfcMechanicalFastener"])
    infos = {i.name: i for i in read_models(out)}
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
        plane = pybullet.createCollisionShape(pybullet.GEOM_PLANE, physicsClientId=client)
        pybullet.createMultiBody(0, plane, basePosition=[0, 0, report["ground_z_m"]], physicsClientId=client)
        bodies = {}
        for entry in report["converted"]:
            info = infos[entry["model"]]
            stl = next(f for f in info.mesh_files if f.suffix == ".stl")
            shape = pybullet.createCollisionShape(pybullet.GEOM_MESH, fileName=str(stl), physicsClientId=client)
            pose = entry["pose_xyz_rpy"]
            bodies[entry["model"]] = pybullet.createMultiBody(
                baseMass=info.mass,
                baseCollisionShapeIndex=shape,
                basePosition=pose[:3],
                baseOrientation=pybullet.getQuaternionFromEuler(pose[3:]),
                baseInertialFramePosition=info.center_of_mass.tolist(),
                physicsClientId=client,
            )
        start = {name: np.array(pybullet.getBasePositionAndOrientation(b, physicsClientId=client)[0])
                 for name, b in bodies.items()}
        for _ in range(480):
            pybullet.stepSimulation(physicsClientId=client)
        moved = {name: float(np.linalg.norm(
            np.array(pybullet.getBasePositionAndOrientation(b, physicsClientId=client)[0]) - start[name]))
            for name, b in bodies.items()}
    finally:
        pybullet.disconnect(client)
    assert len(moved) == 24
    assert max(moved.values()) < 0.01, {name: round(d, 3) for name, d in moved.items() if d >= 0.01}
