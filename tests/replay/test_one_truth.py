"""One building, one truth (issue 34): one build, one position per element in every output.

The same component must stand at the same installed position, within 1 mm, in each output of one
``bimrobot build``, and lie on the yard where the package put it. Frames of the outputs compared:

- ``simulation/schedule.csv``: ``TargetX/Y/Z`` is the component's origin installed, model frame (the
  IFC's world coordinates, metres, z up); ``FromX/Y/Z`` of a transport is the site's yard position the
  robot drives to, in the model frame too.
- ``graph.ttl``: each element's ``dice:hasQuality .../position`` is its installed origin (model frame);
  ``brc:pickUpPosition`` its centre of mass as it lies on the package's yard (model frame).
- ``package/report.json`` (the build converts with ``--layout yard``): ``pose_xyz_rpy`` is the pose on
  the yard, model frame, SDF's fixed-axis roll-pitch-yaw; the world ``.sdf`` includes each model at it.
- ``build.rrd``: each element's ``Transform3D`` on ``sim_time``, model frame: first its yard pose, last
  (installed) its origin placed.
- the MuJoCo scene of ``convert --target mujoco`` (``mujoco/scene.xml``, installed layout, as
  ``tests/physics`` writes it): each element a body named by its GlobalId at its installed origin, model
  frame; its ``report.json`` gives the same pose.
- The site (``site.yaml``, the graph's ``brc:siteDescription``) is in the site frame: ``model_offset``
  takes the model frame to it, so a yard position or robot home is at ``site - model_offset`` in the
  model frame. The offset itself must be one number in every output that carries it.
"""

from __future__ import annotations

import csv
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml

from bimrobot.cli import main

TOL_M = 1e-3  # one millimetre
BRC = "https://bimrobot.example/ns#"
DICE = "https://w3id.org/digitalconstruction/0.5/Entities#"


def schedule_targets(out: Path) -> dict[str, np.ndarray]:
    """GlobalId -> installed origin (m, model frame) from the schedule; every row of a component agrees."""
    targets: dict[str, np.ndarray] = {}
    with open(out / "simulation" / "schedule.csv", newline="", encoding="utf-8") as handle:
        for row in csv.DictReader(handle):
            xyz = np.array([float(row[f"Target{a}"]) for a in "XYZ"])
            gid = row["GlobalId"]
            assert gid not in targets or np.allclose(targets[gid], xyz, atol=TOL_M), (gid, targets[gid], xyz)
            targets.setdefault(gid, xyz)
    return targets


def graph_positions(out: Path) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], np.ndarray]:
    """({GlobalId: installed origin}, {GlobalId: pick-up centre}, model offset) from graph.ttl (rdflib)."""
    import rdflib

    graph = rdflib.Graph().parse(out / "graph.ttl", format="turtle")
    positions, pick_ups = {}, {}
    query = f"""SELECT ?gid ?kind ?x ?y ?z WHERE {{
        ?e <{BRC}globalId> ?gid .
        {{ ?e <{DICE}hasQuality> ?p . FILTER(STRENDS(STR(?p), "/position")) BIND("position" AS ?kind) }}
        UNION {{ ?e <{BRC}pickUpPosition> ?p . BIND("pick-up" AS ?kind) }}
        ?p <{DICE}hasX> ?x ; <{DICE}hasY> ?y ; <{DICE}hasZ> ?z . }}"""
    for gid, kind, x, y, z in graph.query(query):
        (positions if str(kind) == "position" else pick_ups)[str(gid)] = np.array([float(x), float(y), float(z)])
    (offset,) = graph.query(f"SELECT ?x ?y WHERE {{ ?s <{BRC}modelOffsetX> ?x ; <{BRC}modelOffsetY> ?y }}")
    return positions, pick_ups, np.array([float(v) for v in offset])


def pose_matrix(xyz_rpy) -> np.ndarray:
    """4x4 of an SDF pose (x y z roll pitch yaw: fixed axes, R = Rz(yaw) Ry(pitch) Rx(roll)), via scipy."""
    from scipy.spatial.transform import Rotation  # here, not at collection (about 0.5 s of imports)

    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", xyz_rpy[3:]).as_matrix()
    matrix[:3, 3] = xyz_rpy[:3]
    return matrix


def package_poses(package: Path) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """({GlobalId: 4x4 pose}, {GlobalId: centre of mass, model frame}) of a package's report.json; the
    world .sdf includes every model at its report pose."""
    report = json.loads((package / "report.json").read_text())
    poses = {e["global_id"]: pose_matrix(e["pose_xyz_rpy"]) for e in report["converted"]}
    centres = {e["global_id"]: (poses[e["global_id"]] @ np.append(e["center_of_mass_m"], 1.0))[:3]
               for e in report["converted"]}
    gid_of_model = {e["model"]: e["global_id"] for e in report["converted"]}  # model names are file-safe
    world = ET.parse(package / "worlds" / f"{report['world']}.sdf").getroot()
    for include in world.iter("include"):
        gid = gid_of_model[include.findtext("uri").removeprefix("model://")]
        included = np.array([float(v) for v in include.findtext("pose").split()])
        assert np.allclose(included[:3], poses[gid][:3, 3], atol=TOL_M), gid
    return poses, centres


def replay_positions(rrd: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """GlobalId -> (first, last) translation (m, model frame) of each element's Transform3D on sim_time,
    read back with Rerun's dataframe API."""
    pytest.importorskip("rerun")
    pytest.importorskip("datafusion", reason="Rerun's dataframe API needs rerun-sdk[catalog] (datafusion)")
    from rerun.server import Server

    server = Server(host="127.0.0.1", datasets={"build": [str(rrd)]})
    with server:
        client = server.client()  # held while the frame is read: DataFusion needs its context alive
        dataset = client.get_dataset("build")
        frame = dataset.filter_contents(["/building/**"]).reader(index="sim_time").to_pandas()
    frame = frame[frame["sim_time"].notna()].sort_values("sim_time")
    found = {}
    for column in frame.columns:
        if not column.endswith(":global_id"):
            continue
        entity = column.removesuffix(":global_id")
        gid = str(frame[column].dropna().iloc[0][0])
        moves = frame[f"{entity}:Transform3D:translation"].dropna()
        found[gid] = (np.asarray(moves.iloc[0][0], float), np.asarray(moves.iloc[-1][0], float))
    return found


def installed_scene(model, components, tmp_path: Path) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Installed poses ({GlobalId: origin, model frame}) of ``convert --target mujoco`` for the
    ``components`` of ``model`` (a BuildingModel, changed: only they are kept): (from scene.xml's
    bodies, from the package's report.json)."""
    pytest.importorskip("mujoco")
    import bimrobot.export.mujoco.scene as scene
    from bimrobot.export.gazebo.package import ConvertOptions, build_package

    model.elements = {gid: e for gid, e in model.elements.items() if gid in components}
    model.connections, model.assemblies = [], {}
    real = scene.collision_pieces
    with pytest.MonkeyPatch.context() as patch:  # one convex hull per body: the poses do not depend on it,
        patch.setattr(scene, "collision_pieces", lambda body, budget: real(body, 1))  # CoACD takes seconds
        build_package(model, tmp_path / "scene", ConvertOptions(target="mujoco", maps=False, preview=False))
    bodies = {b.get("name"): np.array([float(v) for v in b.get("pos").split()])
              for b in ET.parse(tmp_path / "scene" / "mujoco" / "scene.xml").getroot().iter("body")}
    poses, _ = package_poses(tmp_path / "scene")
    return bodies, {gid: pose[:3, 3] for gid, pose in poses.items()}


def footprint(model) -> tuple[np.ndarray, np.ndarray]:
    """(min_xy, max_xy), model frame: the horizontal extent of every element's body (their world
    vertices, from IfcOpenShell's geometry of the file)."""
    points = np.vstack([e.world_vertices[:, :2] for e in model.elements.values()])
    return points.min(axis=0), points.max(axis=0)


def outside(xy, lower, upper) -> bool:
    """Whether the point ``xy`` lies outside the rectangle [lower, upper] (m)."""
    return bool(np.any(np.asarray(xy) < lower) or np.any(np.asarray(xy) > upper))


def check_one_truth(out: Path, ifc: Path, tmp_path: Path) -> dict:
    """Assert the module docstring on one build folder; return what was compared (for the caller's own
    checks): components, offset, footprint."""
    from bimrobot.bim.reader import load_model

    model = load_model(ifc)  # the file as the build read it (default selection)
    lower, upper = footprint(model)
    targets = schedule_targets(out)
    components = set(targets)
    positions, pick_ups, offset = graph_positions(out)
    site = yaml.safe_load((out / "site.yaml").read_text())
    summary = json.loads((out / "simulation" / "summary.json").read_text())
    package = json.loads((out / "package" / "report.json").read_text())
    rcan = json.loads((out / "rcan" / "report.json").read_text())
    # one placement, read back everywhere it is written
    for name, value in {"summary.json": summary["model_offset_xy_m"], "graph.ttl": offset,
                        "package/report.json": package["options"]["site"]["model_offset"],
                        "rcan/report.json": rcan["model_offset_xy_m"]}.items():
        assert np.allclose(value, site["model_offset"], atol=TOL_M), (name, value, site["model_offset"])
    # installed origin: schedule = graph = replay's last pose = MuJoCo scene = installed package
    replayed = replay_positions(out / "build.rrd")
    bodies, installed = installed_scene(model, components, tmp_path)
    for gid in sorted(components):
        for name, where in {"graph": positions, "replay": {g: v[1] for g, v in replayed.items()},
                            "scene.xml": bodies, "installed package": installed}.items():
            assert gid in where, f"{gid} is missing from the {name}"
            assert np.linalg.norm(where[gid] - targets[gid]) <= TOL_M, (gid, name, where[gid], targets[gid])
    # on the yard: package pose = replay's first pose; package centre of mass = graph's pick-up
    yard_poses, yard_centres = package_poses(out / "package")
    for gid in sorted(components & set(pick_ups)):
        assert np.linalg.norm(replayed[gid][0] - yard_poses[gid][:3, 3]) <= TOL_M, gid
        assert np.linalg.norm(pick_ups[gid] - yard_centres[gid]) <= TOL_M, gid
    # the yard, the robot homes and the components waiting on the yard stand outside the building
    model_offset = np.asarray(site["model_offset"], float)
    for what in ("yard", "robot_home"):
        for xy in site[what]:
            assert outside(np.asarray(xy) - model_offset, lower, upper), (what, xy, lower + model_offset, upper + model_offset)
    for gid, centre in pick_ups.items():
        assert outside(centre[:2], lower, upper), (gid, centre, lower, upper)
    return {"components": components, "offset": model_offset, "footprint": (lower, upper)}


def test_the_frames_components_stand_where_every_output_says(frame_build, tmp_path):
    """The thesis' frame (fleet2, fig. 4.11's site): 12 components, the offset of fig. 4.11 centring it."""
    seen = check_one_truth(frame_build, frame_build.parent / "frame.ifc", tmp_path)
    assert len(seen["components"]) == 12
    assert np.allclose(seen["offset"], [5.327, 3.0])


@pytest.fixture
def column_build(shared_ifc, tmp_path_factory) -> tuple[Path, Path]:
    """(build folder, model) of ifcColumn.ifc (Revit: a UC305 column on a base plate, 3 welds as
    IfcRelConnectsWithRealizingElements), built with the generic heavy fleet as tests/test_real_models.py
    builds the shared models: the smallest shared model with joints from the model (about 5 s)."""
    model = shared_ifc("ifcColumn.ifc")
    out = tmp_path_factory.mktemp("column") / "out"
    assert main(["build", str(model), "--fleet", "site-crane", "-o", str(out)]) == 0
    return out, model


def test_a_shared_models_components_stand_where_every_output_says(column_build, tmp_path):
    out, model = column_build
    seen = check_one_truth(out, model, tmp_path)
    assert len(seen["components"]) == 2


def test_an_assembly_is_installed_at_its_main_parts_origin_in_the_schedule_graph_and_rcan(shared_ifc):
    """A lifted assembly unit has one installed position: the simulation's unit takes its main (heaviest)
    part's placement and writes its origin as the schedule's TargetX/Y/Z; the graph and RCAN's plans
    (``bimrobot.bim.components.position``) give the same point. Before, they gave the bottom centre of
    the parts' bounds: on MULTICOM-trappen_bordessen's landings 0.94 m away in x and 0.08 m lower."""
    from bimrobot.bim.reader import load_model
    from bimrobot.bim import components
    from bimrobot.sco.build import build_smart_model

    model = load_model(shared_ifc("MULTICOM-trappen_bordessen.ifc"))
    smart = build_smart_model(model)
    units = [c for c in smart.components.values() if c.part_ids]
    assert len(units) == 9
    for unit in units:
        assert np.linalg.norm(components.position(model, unit.id) - unit.origin) <= TOL_M, unit.id
