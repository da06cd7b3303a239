"""A large model's components drawn as a few entities: one set of boxes per state.

Rerun's web viewer takes a recording in chunk by chunk and redraws between them; under software
rendering (a machine without a GPU) each frame of a scene with a hundred entities that change over
time is slow, so the time a replay takes to open grows with the number of such entities, not with
their triangles (MULTICOM-Prefab, docs/evidence/replay.md). A build of more than
:data:`COMPACT_FROM` drawn pieces (an assembly's parts count as one) is therefore written as:

- ``/building/<state>``: the components in that state (:data:`bimrobot.replay.inputs.STATES`), each as
  its oriented bounding box (its drawn mesh's principal axes,
  :func:`bimrobot.replay.elements.principal_box`) where it stands, in the state's colour
  (:data:`bimrobot.replay.elements.STATE_COLOURS`); a component's storey, class, name and GlobalId are
  its box's label, shown on hover. A row whenever a component enters or leaves the state or one of
  its components moves;
- ``/building/not in the schedule``: the pieces no robot builds (prebuilt footings, elements outside the
  simulated selection) are the existing context, not work: drawn as the meshes mode draws them, their
  real shapes at their installed places in their own colours from 0 s, all in one mesh
  (:func:`log_context`; their GlobalIds its ``global_id`` property);
- the real shapes of the work in the ghost (``/ghost``, static, unchanged), which the boxes cover as the
  building grows.

Frames: boxes in the model frame (metres, z up); times in seconds on the replay's timelines.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from bimrobot.replay.elements import (STATE_COLOURS, UNSCHEDULED, element_properties, entity, mesh_arrays,
                                       own_rgb, piece_timelines, principal_box)
from bimrobot.replay.inputs import INSTALLED, BuildRecord

#: Above this many drawn pieces (an assembly's parts joined into one) a build is drawn compact (module
#: docstring; `replay --help` says it too). The steel frame (88) keeps its meshes, MULTICOM-Prefab (118) not.
COMPACT_FROM = 100


def is_large(record: BuildRecord) -> bool:
    """Whether ``record`` (as drawn: an assembly one piece) is drawn compact."""
    return len(record.pieces) > COMPACT_FROM


def piece_events(record: BuildRecord, poses: dict, node_times: dict) -> dict[str, list[tuple[float, str, object]]]:
    """Piece -> [(time s, "pose" or "state", 4x4 pose or state name)] of the pieces the build places, as
    the full replay draws them (bimrobot.replay.record._log_pieces): a component's poses and states; a
    joint's bolt or plate in place from its joint's assembly start, assembling, then installed at its
    end. The pieces no robot builds are not here (:func:`context_pieces`)."""
    out = {}
    for gid, (kind, when) in piece_timelines(record, node_times).items():
        piece = record.pieces[gid]
        if kind == "component":
            events = [(t, "pose", pose) for t, pose in poses.get(gid) or []] + [(t, "state", s) for t, s in when]
        elif kind == "joint":
            begin, end = when
            events = [(begin, "pose", piece.installed_pose), (begin, "state", "WorkingInAssembly"), (end, "state", INSTALLED)]
        else:
            continue
        out[gid] = sorted(events, key=lambda event: event[0])
    return out


def context_pieces(record: BuildRecord, node_times: dict) -> list[str]:
    """The pieces no robot builds (:data:`bimrobot.replay.elements.UNSCHEDULED`), in the record's order."""
    return [gid for gid, (kind, _) in piece_timelines(record, node_times).items() if kind == "model"]


def state_rows(events: dict[str, list[tuple[float, str, object]]]) -> dict[str, list[tuple[float, list[str], list]]]:
    """State -> [(time s, pieces in that state then, their poses)], a row at each time the state's set of
    pieces or one of their poses changes (pieces in ``events``' order; a piece with no pose yet is left out)."""
    by_time = defaultdict(list)
    for gid, history in events.items():
        for t, kind, value in history:
            by_time[t].append((gid, kind, value))
    pose, state, rows = {}, {}, defaultdict(list)
    for t in sorted(by_time):
        touched = {}
        for gid, kind, value in by_time[t]:
            touched.setdefault(gid, state.get(gid))
            (pose if kind == "pose" else state)[gid] = value
        for name in sorted(({*touched.values()} | {state.get(g) for g in touched}) - {None}):
            members = [g for g in events if state.get(g) == name and g in pose]
            rows[name].append((t, members, [pose[g] for g in members]))
    return dict(rows)


def world_boxes(shapes: dict, members: list[str], poses: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centres (n, 3), half sizes (n, 3), quaternions (n, 4) xyzw) of the pieces ``members`` at ``poses``
    (4x4, model frame); ``shapes``: piece -> :func:`principal_box` in its local frame."""
    from scipy.spatial.transform import Rotation

    if not members:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 4))
    centres, halves, turns = [], [], []
    for gid, pose in zip(members, poses):
        centre, axes, half = shapes[gid]
        turn = pose[:3, :3] @ axes
        if np.linalg.det(turn) < 0:  # a mirrored placement: the same box with one axis reversed
            turn[:, 0] = -turn[:, 0]
        centres.append(pose[:3, :3] @ centre + pose[:3, 3])
        halves.append(half)
        turns.append(turn)
    quaternions = Rotation.from_matrix(np.array(turns)).as_quat()  # x, y, z, w (Rerun's order)
    return np.array(centres), np.array(halves), quaternions


def label(record: BuildRecord, gid: str) -> str:
    """A box's label: storey / IFC class / name (GlobalId)."""
    p = element_properties(record, gid)
    return f"{p['storey'] or 'no storey'} / {p['ifc_class']} / {p['name'] or gid} ({gid})"


def log_compact(rec, clock, record: BuildRecord, poses: dict, node_times: dict) -> int:
    """Log the building as ``/building/<state>`` boxes and its context (module docstring); returns the
    entities written. ``clock``: the replay's time columns (bimrobot.replay.record._Clock)."""
    import rerun as rr

    context = context_pieces(record, node_times)
    if context:
        rec.send_columns(entity("building", UNSCHEDULED), indexes=clock.columns([0.0]),
                         columns=context_columns(rr, record, context, UNSCHEDULED))

    shapes = {gid: principal_box(piece.triangles) for gid, piece in record.pieces.items()}
    labels = {gid: label(record, gid) for gid in record.pieces}
    rows = state_rows(piece_events(record, poses, node_times))
    for name, timeline in rows.items():
        boxes = [world_boxes(shapes, members, member_poses) for _, members, member_poses in timeline]
        lengths = [len(members) for _, members, _ in timeline]
        rgb = STATE_COLOURS[name]
        columns = list(rr.Boxes3D.columns(
            centers=np.concatenate([b[0] for b in boxes]), half_sizes=np.concatenate([b[1] for b in boxes]),
            quaternions=np.concatenate([b[2] for b in boxes]),
            labels=[labels[g] for _, members, _ in timeline for g in members]).partition(lengths))
        rec.log(entity("building", name), rr.Boxes3D.from_fields(colors=[rgb], fill_mode="solid", show_labels=False),
                static=True)
        rec.send_columns(entity("building", name), indexes=clock.columns([t for t, _, _ in timeline]), columns=columns)
    return len(rows) + bool(context)


def context_mesh(record: BuildRecord, gids: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(triangles (k, 3, 3) in the model frame, m; RGB 0-255 per vertex (3k, 3)) of the pieces ``gids``
    at their installed places, each in its own colour: one mesh for many pieces that never change."""
    triangles, colours = [], []
    for gid in gids:
        piece = record.pieces[gid]
        pose = piece.installed_pose
        triangles.append(piece.triangles @ pose[:3, :3].T + pose[:3, 3])
        colours.append(np.repeat([own_rgb(piece)], 3 * len(piece.triangles), axis=0))
    return np.concatenate(triangles), np.concatenate(colours).astype(np.uint8)


def context_columns(rr, record: BuildRecord, gids: list[str], state: str) -> list:
    """The columns of one row drawing the pieces ``gids`` as :func:`context_mesh` (flat shaded), with
    their GlobalIds as its ``global_id`` property and ``state`` as its ``state``."""
    triangles, colours = context_mesh(record, gids)
    vertices, indices, normals = mesh_arrays(triangles)
    columns = [*rr.Mesh3D.columns(vertex_positions=vertices, triangle_indices=indices, vertex_normals=normals,
                                  vertex_colors=colours),
               *rr.AnyValues.columns(global_id=list(gids)), *rr.AnyValues.columns(state=[state])]
    return [c.partition([len(c.component_batch.as_arrow_array())]) for c in columns]
