"""What a planner sees when the replay opens: the building framed, labels hidden, the unbuilt work
ghosted, a Gantt of bars, elements named by storey / class / name, one panel set per timeline, and a
large model drawn as boxes by state."""

from __future__ import annotations

import csv
import importlib.util
import json

import numpy as np
import pytest

# found, not imported (tests/conftest.py): the extras these tests need
MISSING = [name for name in ("rerun", "datafusion") if importlib.util.find_spec(name) is None]
pytestmark = pytest.mark.skipif(bool(MISSING), reason=f"needs {', '.join(MISSING)}, not installed")


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """rerun (about 1 s of imports with its dataframe API), imported when these tests run, not at collection."""
    global rr
    import rerun as rr


@pytest.fixture(scope="module")
def frame_record(frame_build):
    from bimrobot.replay.inputs import load_build

    return load_build([frame_build])


@pytest.fixture(scope="module")
def frame_static(frame_replay):
    """(entity paths, the static columns of the whole recording as one row)."""
    from rerun.server import Server

    server = Server(host="127.0.0.1", datasets={"build": [str(frame_replay[0])]})
    with server:
        client = server.client()  # kept: the dataset's queries run through it
        dataset = client.get_dataset("build")
        paths = {c.entity_path for c in dataset.schema().component_columns()}
        static = dataset.filter_contents(["/building/**", "/ghost", "/gantt/**"]).reader(index=None).to_pandas()
        timed = dataset.filter_contents(["/building/**"]).reader(index="sim_time").to_pandas()
    return paths, static, timed


def first_value(frame, column):
    """The first value logged in ``column`` (its first instance)."""
    return frame[column].dropna().iloc[0][0]


def test_elements_are_named_by_storey_class_and_name_with_the_global_id_as_a_property(frame_build, frame_static):
    """Each element's GlobalId, class, name and storey come with its mesh (the element's one chunk)."""
    paths, _, timed = frame_static
    report = json.loads((frame_build / "package" / "report.json").read_text())
    by_id = {e["global_id"]: e for e in report["converted"]}
    building = sorted(p for p in paths if p.startswith("/building/"))
    assert len(building) == len(by_id) == 88
    seen = set()
    for path in building:
        gid = first_value(timed, f"{path}:global_id")
        assert first_value(timed, f"{path}:ifc_class") == by_id[gid]["ifc_class"]
        storey, ifc_class, name = [part.replace("\\ ", " ") for part in path.split("/")[2:]]
        assert ifc_class == by_id[gid]["ifc_class"] and storey in ("Level 1", "Level 2")
        assert name.split(" (")[0] == (by_id[gid]["name"] or gid) and gid not in path
        seen.add(gid)
    assert seen == set(by_id)


def test_robots_and_nodes_record_their_labels_hidden(frame_replay):
    from rerun.server import Server

    server = Server(host="127.0.0.1", datasets={"build": [str(frame_replay[0])]})
    with server:
        client = server.client()
        frame = client.get_dataset("build").filter_contents(["/robots/**", "/nodes/**"]).reader(
            index="sim_time").to_pandas()
    shows = [c for c in frame.columns if c.endswith(":show_labels")]
    labels = [c for c in frame.columns if c.endswith(":labels")]
    assert len(shows) == len(labels) > 6  # every robot and node that has a label hides it
    values = {bool(v[0]) for c in shows for v in frame[c].dropna()}
    assert values == {False}


def test_the_unbuilt_work_is_ghosted_from_the_start(frame_record, frame_static):
    """/ghost: one static translucent mesh of every element the build places (the prebuilt footings
    stand in their own colour instead), each a little inside its installed body."""
    from bimrobot.replay.elements import drawn_record
    from bimrobot.replay.record import GHOST_RGBA, ghost_pieces

    paths, static, _ = frame_static
    assert "/ghost" in paths
    vertices = np.array([list(v) for v in static["/ghost:Mesh3D:vertex_positions"].iloc[0]])
    albedo = int(static["/ghost:Mesh3D:albedo_factor"].iloc[0][0])
    assert (albedo & 0xFF) == GHOST_RGBA[3] < 255  # RGBA packed: the alpha makes it translucent
    record, _ = drawn_record(frame_record)
    ghosted = ghost_pieces(record)
    footings = [g for g, p in record.pieces.items() if p.ifc_class == "IfcFooting"]
    assert footings and not set(footings) & set(ghosted)
    assert len(vertices) == 3 * sum(len(record.pieces[g].triangles) for g in ghosted)
    boxes = np.array([record.pieces[g].world_bounds(record.pieces[g].installed_pose) for g in ghosted])
    assert np.all(vertices.min(axis=0) >= boxes[:, 0].min(axis=0) - 1e-4)
    assert np.all(vertices.max(axis=0) <= boxes[:, 1].max(axis=0) + 1e-4)


def test_the_gantt_has_one_bar_per_activity_at_its_times(frame_build, frame_record, frame_static):
    from bimrobot.replay.gantt import chart_width

    paths, static, _ = frame_static
    rows = list(csv.DictReader((frame_build / "simulation" / "schedule.csv").open()))
    makespan = max(float(r["Finish"]) for r in rows)
    scale = chart_width(len(frame_record.robots)) / makespan
    total = 0
    for row_index, robot in enumerate(frame_record.robots):
        path = "/gantt/" + rr.escape_entity_path_part(robot)
        mine = sorted((float(r["Start"]), float(r["Finish"])) for r in rows if r["Robot"] == robot)
        if not mine:
            continue
        halves = np.array([list(v) for v in static[f"{path}:Boxes2D:half_sizes"].iloc[0]])
        centres = np.array([list(v) for v in static[f"{path}:Boxes2D:centers"].iloc[0]])
        starts = sorted((centres[:, 0] - halves[:, 0]) / scale)
        assert len(starts) == len(mine)
        assert starts == pytest.approx([s for s, _ in mine], abs=0.01)
        assert np.allclose(centres[:, 1], row_index)  # the robot's row
        total += len(mine)
    assert total == len(rows) > 12  # every activity of the schedule, on its robot


def test_the_eye_frames_the_building_and_the_panels_follow_the_timeline(frame_record):
    """Seen through the 3D view's eye (Rerun's: 55 degrees vertical, a view 1.5 times as wide as
    high), every corner of every element's box is on screen, the building is centred and fills 85-90 %
    of the view's height or width (MULTICOM-Prefab's eye once kept it to a third of the view in the
    browser: a cone inside the vertical field of view, around its bounding box's empty corners); the
    schedule's panels come first for a build."""
    from bimrobot.replay.layout import (EYE_DIRECTION, FILL, VIEW_ASPECT, building_eye, building_points,
                                        main_timeline, screen_position)

    eye = building_eye(frame_record)
    position = np.array(eye.position.as_arrow_array().to_pylist()[0])
    target = np.array(eye.look_target.as_arrow_array().to_pylist()[0])
    assert np.allclose((position - target) / np.linalg.norm(position - target),
                       EYE_DIRECTION / np.linalg.norm(EYE_DIRECTION))  # from the south-east, above
    seen = screen_position(position, target, building_points(frame_record))
    # independent of screen_position: a camera of Rerun's built from position and target alone
    forward = (target - position) / np.linalg.norm(target - position)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    rays = building_points(frame_record) - position
    depth = rays @ forward
    assert depth.min() > 0  # nothing behind the eye
    half = np.tan(np.radians(55.0) / 2)
    seen_again = np.stack([rays @ right / depth / (half * VIEW_ASPECT), rays @ up / depth / half], axis=1)
    assert np.allclose(seen, seen_again)
    reach = np.abs(seen).max(axis=0)
    assert reach.max() == pytest.approx(FILL, abs=0.01) and FILL >= 0.85  # fills the height or the width
    assert np.all(reach <= FILL + 0.01)  # nothing cut off
    middle = (seen.min(axis=0) + seen.max(axis=0)) / 2
    assert np.abs(middle).max() < 0.02  # centred
    assert main_timeline(frame_record) == "sim_time"


def test_large_meshes_are_simplified_within_their_bounds():
    import trimesh

    from bimrobot.replay.elements import simplify

    sphere = trimesh.creation.icosphere(subdivisions=5, radius=2.0)  # 20,480 triangles
    triangles = sphere.vertices[sphere.faces]
    small = simplify(triangles, 400)
    assert len(small) <= 420 < len(triangles)
    assert np.allclose(small.reshape(-1, 3).min(axis=0), triangles.reshape(-1, 3).min(axis=0), atol=0.05)
    assert np.allclose(small.reshape(-1, 3).max(axis=0), triangles.reshape(-1, 3).max(axis=0), atol=0.05)
    few = triangles[:100]
    assert simplify(few, 400, tiny_m=0.0) is few  # small enough: drawn as it is


def test_tiny_parts_are_drawn_as_their_oriented_box():
    """A bolt (2 cm x 10 cm, 128 triangles, turned in its local frame) becomes the 12 triangles of the
    smallest box around it: every vertex inside, no bigger than the bolt's own box."""
    import trimesh
    from scipy.spatial.transform import Rotation

    from bimrobot.replay.elements import MAX_TRIANGLES, simplify

    bolt = trimesh.creation.cylinder(radius=0.01, height=0.1, sections=32)
    turned = bolt.vertices @ Rotation.from_euler("xyz", [30, 40, 50], degrees=True).as_matrix().T
    triangles = turned[bolt.faces]
    box = simplify(triangles, MAX_TRIANGLES)
    assert box.shape == (12, 3, 3) and len(triangles) > 12
    normals = np.cross(box[:, 1] - box[:, 0], box[:, 2] - box[:, 0])
    centre = box.reshape(-1, 3).mean(axis=0)
    assert np.all(np.einsum("ij,ij->i", normals, box.mean(axis=1) - centre) > 0)  # outward, counter-clockwise
    outside = np.einsum("fk,vfk->vf", normals, turned[:, None, :] - box[None, :, 0])  # > 0: beyond a face
    assert outside.max() < 1e-9
    volume = trimesh.Trimesh(box.reshape(-1, 3), np.arange(36).reshape(-1, 3)).convex_hull.volume
    assert volume == pytest.approx(0.02 * 0.02 * 0.1, rel=0.05)  # oriented: the axis-aligned box is 5x larger


def test_a_unit_that_skips_position_fixed_ends_at_its_installed_place():
    """A precast unit's history can go from WorkingInPositioning straight to Assembled (no PositionFixed):
    its pieces still end at their installed poses (found on MULTICOM-trappen_bordessen, where 50 of 150
    pieces stayed where they had been set down)."""
    from bimrobot.replay.inputs import BuildRecord, Piece, Robot
    from bimrobot.replay.motion import component_poses, robot_tracks

    cube = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 0, 1], [0, 1, 1]]], dtype=float)
    installed, yard = np.eye(4), np.eye(4)
    installed[:3, 3], yard[:3, 3] = (5.0, 5.0, 3.0), (-5.0, 0.0, 0.0)
    piece = Piece("P", "IfcSlab", "landing", None, cube, np.ones(4), yard, installed)
    schedule = [{"Identification": "A1", "Name": "Transport U", "Activity": "transport", "GlobalId": "U",
                 "Robot": "T", "Start": 0.0, "Finish": 10.0, "TargetX": 5.0, "TargetY": 5.0, "TargetZ": 0.0},
                {"Identification": "A2", "Name": "Position U", "Activity": "position", "GlobalId": "U",
                 "Robot": "T", "Start": 10.0, "Finish": 20.0, "TargetX": 5.0, "TargetY": 5.0, "TargetZ": 3.0}]
    states = {"U": [(0.0, "OnYard"), (1.0, "InTransit"), (10.0, "Arrived"), (12.0, "WorkingInPositioning"),
                    (20.0, "Assembled")]}
    record = BuildRecord("t", {"P": piece}, {"U": ["P"]}, states, schedule,
                         {"T": Robot("T", "transport", np.zeros(2), 1.0)}, {})
    t, pose = component_poses(record, robot_tracks(record))["P"][-1]
    assert t == 20.0 and np.allclose(pose, installed)


def test_long_builds_are_sampled_more_coarsely():
    """Movements are sampled every 2 s on a build of up to 2,000 s (the steel frame's 1,639 s: as
    before), and every 1/1,000 of the build on a longer one (Prefab's 29,098 s: 29.1 s), at most 24
    samples per movement, both ends kept."""
    from bimrobot.replay.inputs import BuildRecord
    from bimrobot.replay.motion import MAX_SAMPLES, sample_step, sample_times

    def build(makespan_s):
        row = {"Robot": "T", "Activity": "transport", "Start": 0.0, "Finish": makespan_s}
        return BuildRecord("t", {}, {}, {}, [row], {}, {})

    assert sample_step(build(1639.0)) == 2.0
    assert sample_step(build(29098.0)) == pytest.approx(29.098)
    times = sample_times(100.0, 400.0, sample_step(build(29098.0)))
    assert times[0] == 100.0 and times[-1] == 400.0 and len(times) == 12  # 300 s in 11 steps of <= 29.1 s
    assert len(sample_times(0.0, 10_000.0, 2.0)) == MAX_SAMPLES + 1


def test_an_assembly_is_one_entity_carried_whole_from_its_main_part():
    """A precast unit of several elements is drawn as one piece (one entity, one set of poses): its
    parts' meshes joined in the frame of the part the schedule places, lying installed where the parts
    lie installed, on the yard where the package put that main part; its hover lists the parts.
    (MULTICOM-Prefab: 118 entities instead of 301, 1,467 element pose rows instead of 5,840.)"""
    from bimrobot.replay.elements import element_properties, join_units
    from bimrobot.replay.inputs import BuildRecord, Node, Piece, Robot
    from bimrobot.replay.motion import MAX_LIFT_STEPS, component_poses, robot_tracks

    triangle = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], dtype=float)

    def pose(x, y, z, turn_deg=0.0):
        from scipy.spatial.transform import Rotation

        matrix = np.eye(4)
        matrix[:3, :3] = Rotation.from_euler("z", turn_deg, degrees=True).as_matrix()
        matrix[:3, 3] = (x, y, z)
        return matrix

    slab = Piece("S", "IfcSlab", "slab", "L1", 4 * triangle, np.ones(4), pose(-20, 0, 0), pose(5, 5, 3, 90))
    anchor = Piece("A", "IfcMechanicalFastener", "anchor", "L1", triangle, np.ones(4), pose(-30, 9, 0), pose(6, 5, 3.2))
    schedule = [{"Identification": "A1", "Name": "Transport U", "Activity": "transport", "GlobalId": "U", "Robot": "T",
                 "Start": 0.0, "Finish": 100.0, "TargetX": 5.0, "TargetY": 5.0, "TargetZ": 3.0},
                {"Identification": "A2", "Name": "Position U", "Activity": "position", "GlobalId": "U", "Robot": "T",
                 "Start": 100.0, "Finish": 400.0, "TargetX": 5.0, "TargetY": 5.0, "TargetZ": 3.0}]
    states = {"U": [(0.0, "OnYard"), (1.0, "InTransit"), (100.0, "Arrived"), (100.0, "WorkingInPositioning"),
                    (400.0, "Assembled")]}
    record = BuildRecord("t", {"S": slab, "A": anchor}, {"U": ["A", "S"]}, states, schedule,
                         {"T": Robot("T", "transport", np.zeros(2), 1.0)},
                         {"n": Node("n", np.zeros(3), ("A",))}, assemblies={"U": ("IfcElementAssembly", "unit 1", "L1")})
    joined = join_units(record)
    assert list(joined.pieces) == ["U"] and joined.parts == {"U": ["U"]} and joined.nodes["n"].realizing == ("U",)
    unit = joined.pieces["U"]
    assert (unit.ifc_class, unit.name, unit.storey_id) == ("IfcElementAssembly", "unit 1", "L1")
    assert np.allclose(unit.installed_pose, slab.installed_pose) and np.allclose(unit.yard_pose, slab.yard_pose)
    world = unit.triangles @ unit.installed_pose[:3, :3].T + unit.installed_pose[:3, 3]
    parts = [p.triangles @ p.installed_pose[:3, :3].T + p.installed_pose[:3, 3] for p in (anchor, slab)]
    assert np.allclose(world, np.concatenate(parts))  # every part where the model installs it
    assert element_properties(joined, "U")["parts"] == "2: A, S"
    poses = component_poses(joined, robot_tracks(joined))["U"]
    assert np.allclose(poses[0][1], slab.yard_pose) and np.allclose(poses[-1][1], slab.installed_pose)
    assert sum(1 for t, _ in poses if 100.0 < t < 400.0) == MAX_LIFT_STEPS - 1  # a 300 s lift in 4 steps

def last_building_rows(rrd) -> dict[str, dict[str, list]]:
    """Entity path -> {component: its last logged value} of the /building entities, read with Rerun's
    chunk reader (the rows on sim_time, in time order)."""
    from rerun.chunk import RrdReader

    out: dict[str, dict[str, list]] = {}
    for chunk in RrdReader(rrd).stream():
        if not chunk.entity_path.startswith("/building/"):
            continue
        batch = chunk.to_record_batch()
        order = np.argsort(batch.column("sim_time").to_numpy(), kind="stable") if "sim_time" in batch.schema.names else [0]
        for name in batch.schema.names:
            if ":" in name:
                values = batch.column(name).to_pylist()
                out.setdefault(chunk.entity_path, {})[name.split(":")[1]] = values[int(order[-1])]
    return out


def first_building_rows(rrd) -> dict[str, dict[str, list]]:
    """Entity path -> {component: its first logged value, "sim_time": that row's time (s; None when
    static)} of the /building entities, read with Rerun's chunk reader."""
    from rerun.chunk import RrdReader

    out: dict[str, dict[str, list]] = {}
    for chunk in RrdReader(rrd).stream():
        if not chunk.entity_path.startswith("/building/"):
            continue
        batch = chunk.to_record_batch()
        names = [n for n in batch.schema.names if not n.startswith("rerun.") and n not in ("sim_time", "calendar")]
        times = batch.column("sim_time").cast("int64").to_numpy() / 1e9 if "sim_time" in batch.schema.names else None
        row = out.setdefault(chunk.entity_path, {})
        for name in names:
            values = batch.column(name).to_pylist()
            first = next((i for i, v in enumerate(values) if v is not None), None)
            if first is not None and name.split(":")[-1] not in row:
                row[name.split(":")[-1]] = values[first]
                row.setdefault("sim_time", None if times is None else float(times[first]))
    return out


def box_corners(centre, half, quaternion) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    return (signs * half) @ Rotation.from_quat(quaternion).as_matrix().T + centre


def test_a_large_model_is_few_entities_of_boxes_by_state_and_ends_as_the_same_building(frame_record, tmp_path):
    """A large model drawn compact (bimrobot.replay.compact: each component its box, grouped by state),
    so that the web viewer has a few entities to take in instead of one per element (MULTICOM-Prefab: 7
    instead of 118, docs/evidence/replay.md). The steel frame written compact: its 88 pieces (12
    components, their bolts and plates) are at most one entity per state; at the end of the build every
    piece the build places is an assembled (green) box labelled with its GlobalId, and with the pieces
    no robot builds (below) they span the building's bounding box (its meshes installed) to within 2 cm."""
    from bimrobot.replay.compact import COMPACT_FROM, is_large
    from bimrobot.replay.elements import UNSCHEDULED, drawn_record, entity
    from bimrobot.replay.inputs import STATES
    from bimrobot.replay.layout import building_bounds
    from bimrobot.replay.record import write_rrd

    record = frame_record
    drawn, _ = drawn_record(record)
    assert len(drawn.pieces) == 88 <= COMPACT_FROM and not is_large(drawn)  # the frame keeps its meshes by default
    rrd = tmp_path / "boxes.rrd"
    summary = write_rrd(record, rrd, compact=True)
    assert summary["drawn"] == "boxes by state"
    rows = last_building_rows(rrd)
    rows.pop(entity("building", UNSCHEDULED))
    context = first_building_rows(rrd)[entity("building", UNSCHEDULED)]  # one row
    assert set(rows) <= {entity("building", s) for s in STATES}
    assert summary["entities"] == len(rows) + 1 <= 10
    assert not any("vertex_positions" in row for row in rows.values())  # boxes, not meshes
    assembled = [label.rsplit("(", 1)[1].rstrip(")") for label in rows[entity("building", "Assembled")]["labels"]]
    assert len(assembled) == 76 and set(assembled) | set(context["global_id"]) == set(drawn.pieces)
    assert all(not row.get("labels") for path, row in rows.items() if path != entity("building", "Assembled"))
    corners = np.concatenate([box_corners(c, h, q) for c, h, q in zip(*(rows[entity("building", "Assembled")][k]
                                                                        for k in ("centers", "half_sizes", "quaternions")))])
    corners = np.concatenate([corners, np.array(context["vertex_positions"])])
    low, high = building_bounds(drawn)
    assert np.allclose(corners.min(axis=0), low, atol=0.02) and np.allclose(corners.max(axis=0), high, atol=0.02)


def test_boxes_show_what_no_robot_builds_as_the_meshes_do(frame_record, frame_replay, tmp_path):
    """The pieces no robot builds (the frame's 4 base plates and 8 clip angles, of no scheduled joint)
    are the existing context,
    as Bonsai and Synchro show elements outside the schedule, not work: the boxes by state draw them as
    the meshes do, from 0 s, each its real shape at its installed place in its own colour (they were
    grey boxes, looking like the unbuilt work's grey ghost)."""
    from bimrobot.replay.elements import UNSCHEDULED, drawn_record, entity, own_rgb
    from bimrobot.replay.record import write_rrd

    drawn, _ = drawn_record(frame_record)
    rrd = tmp_path / "boxes.rrd"
    write_rrd(frame_record, rrd, compact=True)
    context = first_building_rows(rrd)[entity("building", UNSCHEDULED)]
    assert context["sim_time"] == 0.0 and context["state"] == [UNSCHEDULED]
    gids = context["global_id"]
    assert sorted(drawn.pieces[g].ifc_class for g in gids) == ["IfcMember"] * 8 + ["IfcPlate"] * 4
    meshes = first_building_rows(frame_replay[0])  # the same pieces in the meshes mode: one entity each
    drawn_as_meshes = [row for row in meshes.values() if row.get("global_id", [None])[0] in gids]
    assert len(drawn_as_meshes) == 12 and all(row["state"] == [UNSCHEDULED] for row in drawn_as_meshes)
    # the same triangles at the same places (the meshes mode: each mesh with its installed pose; Rerun
    # keeps a 3x3 matrix column by column, so the stored rows are the rotation's columns)
    placed = [np.array(row["vertex_positions"]) @ np.array(row["mat3x3"]).reshape(3, 3) + row["translation"]
              for row in sorted(drawn_as_meshes, key=lambda row: gids.index(row["global_id"][0]))]
    assert np.allclose(np.array(context["vertex_positions"]), np.concatenate(placed), atol=1e-4)
    # each in its own colour, as the meshes mode colours it, not the ghost's grey
    assert all(rgba_bytes(row["albedo_factor"][0]) == own_rgb(drawn.pieces[row["global_id"][0]]) for row in drawn_as_meshes)
    assert set(map(rgba_bytes, context["vertex_colors"])) == {own_rgb(drawn.pieces[g]) for g in gids}


def rgba_bytes(packed: int) -> tuple[int, int, int]:
    """The RGB of a colour as Rerun stores it (0xRRGGBBAA)."""
    return packed >> 24 & 255, packed >> 16 & 255, packed >> 8 & 255


def test_a_recording_with_nothing_to_draw_gets_a_free_eye(frame_record):
    """No piece to frame (every element left out of the drawing): the layout still builds, with Rerun's own
    eye, instead of failing on an empty outline."""
    import dataclasses

    from bimrobot.replay.layout import blueprint

    assert blueprint(dataclasses.replace(frame_record, pieces={})) is not None
