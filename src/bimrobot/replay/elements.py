"""The building's elements as the replay draws them in Rerun: entity paths, properties, state colours
and light meshes.

- :func:`drawn_record`: the record as drawn. A component made of several elements (an assembly: a
  precast unit with its inserts and anchors, a steel sub-frame) is one entity, its parts' meshes
  joined in the frame of its main part, which the schedule places (:func:`join_units`); every mesh is
  lightened (:func:`simplify`);
- :func:`element_paths`: ``/building/<storey>/<IFC class>/<name>`` per element or unit;
- :func:`element_properties`: GlobalId, class, name, storey (and an assembly's parts) shown on hover;
- :func:`mesh3d`, :func:`transform3d`: Rerun archetypes of a mesh (local frame, m) and a pose (4x4).

Frames: a mesh is in its element's local frame (metres, z up); poses take it to the model frame.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from bimrobot.replay.inputs import BuildRecord, Piece

#: Colours of the thesis' states (RGB): yard grey, transport blue, on site teal, positioning orange,
#: fixed yellow, assembling red, assembled green.
STATE_COLOURS = {
    "OnYard": (150, 150, 150), "InTransit": (66, 133, 244), "Arrived": (0, 172, 193), "InLocation": (0, 172, 193),
    "WorkingInPositioning": (255, 152, 0), "PositionFixed": (253, 216, 53), "WaitForAssembly": (253, 216, 53),
    "WorkingInAssembly": (229, 57, 53), "Assembled": (67, 160, 71),
}

#: Most triangles one element is drawn with: a larger mesh is simplified (quadric decimation) to this
#: many, so that a model of hundreds of elements opens in the web viewer in seconds (docs/replay.md).
MAX_TRIANGLES = 200
#: An element whose mesh spans less than this in every direction (m; bolts, anchors, inserts) is drawn
#: as its oriented bounding box (12 triangles): at a building's scale it is a few pixels wide.
TINY_M = 0.3


def entity(*parts: str) -> str:
    """A Rerun entity path from unescaped parts (GlobalIds may hold ``$``)."""
    import rerun as rr

    return "/" + "/".join(rr.escape_entity_path_part(p) for p in parts)


def element_paths(record: BuildRecord) -> dict[str, str]:
    """GlobalId -> entity path ``/building/<storey>/<IFC class>/<name>`` (module docstring): the storey's
    name (``no storey`` without one), the element's name (its GlobalId when it has none); elements
    sharing all three get `` (2)``, `` (3)``, ... in file order."""
    out: dict[str, str] = {}
    used: set[str] = set()
    for gid, piece in record.pieces.items():
        storey = record.storeys.get(piece.storey_id or "", piece.storey_id or "no storey")
        name = piece.name.strip() or gid
        path, number = entity("building", storey, piece.ifc_class, name), 1
        while path in used:
            number += 1
            path = entity("building", storey, piece.ifc_class, f"{name} ({number})")
        used.add(path)
        out[gid] = path
    return out


def drawn_record(record: BuildRecord, max_triangles: int = MAX_TRIANGLES) -> tuple[BuildRecord, int]:
    """``record`` as the replay draws it: every mesh lightened (:func:`simplify`), then each component of
    several elements joined into one (:func:`join_units`); and how many meshes were lightened."""
    pieces, count = {}, 0
    for gid, piece in record.pieces.items():
        triangles = simplify(piece.triangles, max_triangles)
        count += triangles is not piece.triangles
        pieces[gid] = dataclasses.replace(piece, triangles=triangles) if triangles is not piece.triangles else piece
    return join_units(dataclasses.replace(record, pieces=pieces)), count


def join_units(record: BuildRecord) -> BuildRecord:
    """``record`` with each component of several elements (an assembly) as one piece under the
    component's GlobalId: its parts' meshes joined in the frame of its main part (:func:`main_part`),
    standing where the main part stands (on the yard and installed), its class, name and storey the
    assembly's, ``part_ids`` its parts. The parts keep their installed places relative to each other,
    on the yard too: the unit is lifted and carried whole. One entity and one set of poses per unit
    instead of one per part (MULTICOM-Prefab: 118 entities instead of 301)."""
    units = {c: gids for c, gids in record.parts.items() if len(gids) > 1}
    if not units:
        return record
    pieces = {gid: piece for gid, piece in record.pieces.items()
              if not any(gid in gids for gids in units.values())}
    for component, gids in units.items():
        pieces[component] = _unit_piece(record, component, gids)
    joined = {g: component for component, gids in units.items() for g in gids}
    nodes = {node_id: dataclasses.replace(node, realizing=tuple(dict.fromkeys(joined.get(r, r) for r in node.realizing)))
             for node_id, node in record.nodes.items()}
    parts = {c: [c] if c in units else gids for c, gids in record.parts.items()}
    return dataclasses.replace(record, pieces=pieces, parts=parts, nodes=nodes)


def _unit_piece(record: BuildRecord, component: str, gids: list[str]) -> Piece:
    """One piece of the parts ``gids`` of ``component`` (:func:`join_units`)."""
    main = record.pieces[main_part(record, component, gids)]
    to_main = np.linalg.inv(main.installed_pose)
    triangles = []
    for gid in gids:
        relative = to_main @ record.pieces[gid].installed_pose
        triangles.append(record.pieces[gid].triangles @ relative[:3, :3].T + relative[:3, 3])
    ifc_class, name, storey_id = record.assemblies.get(component, ("IfcElementAssembly", "", main.storey_id))
    return Piece(global_id=component, ifc_class=ifc_class, name=name, storey_id=storey_id or main.storey_id,
                 triangles=np.concatenate(triangles), colour=main.colour, yard_pose=main.yard_pose,
                 installed_pose=main.installed_pose, part_ids=tuple(gids))


def main_part(record: BuildRecord, component: str, gids: list[str]) -> str:
    """The part whose placement the schedule gives the component (its ``TargetX/Y/Z`` is the main part's
    installed origin, model frame); without a schedule row, the part of the largest bounding box."""
    row = next((r for r in record.schedule if r["GlobalId"] == component), None)
    if row is not None:
        target = np.array([row["TargetX"], row["TargetY"], row["TargetZ"]])
        return min(gids, key=lambda g: float(np.linalg.norm(record.pieces[g].installed_pose[:3, 3] - target)))
    return max(gids, key=lambda g: float(np.prod(np.ptp(record.pieces[g].triangles.reshape(-1, 3), axis=0))))


def simplify(triangles: np.ndarray, max_triangles: int, tiny_m: float = TINY_M) -> np.ndarray:
    """Triangles (k, 3, 3), local frame (m), lightened: a tiny part (:data:`TINY_M`) becomes its oriented
    bounding box (12 triangles), a mesh of more than ``max_triangles`` is reduced to about that many
    (trimesh's quadric decimation, through fast-simplification, on the welded mesh). The mesh itself
    (the same array) when it is small enough or the decimator refuses it."""
    span = np.ptp(triangles.reshape(-1, 3), axis=0) if len(triangles) else np.zeros(3)
    if len(triangles) > 12 and span.max() < tiny_m:
        return oriented_box(triangles)
    if len(triangles) <= max_triangles:
        return triangles
    mesh = _welded(triangles)
    try:
        small = mesh.simplify_quadric_decimation(face_count=max_triangles)
    except Exception:  # noqa: BLE001 - the decimator refuses some degenerate meshes: keep the full one
        return triangles
    if not 0 < len(small.faces) < len(triangles):
        return triangles
    return np.asarray(small.vertices)[np.asarray(small.faces)]


def _welded(triangles: np.ndarray):
    import trimesh

    soup = triangles.reshape(-1, 3)
    return trimesh.Trimesh(soup, np.arange(len(soup)).reshape(-1, 3), process=True)  # welds shared corners


def oriented_box(triangles: np.ndarray) -> np.ndarray:
    """The 12 triangles (outward, counter-clockwise) of a box around ``triangles`` along their principal
    axes (the eigenvectors of the vertices' covariance: a bolt's box follows the bolt, however it is
    turned in its local frame)."""
    centre, axes, half = principal_box(triangles)
    corners = np.array([[(-half, half)[i >> k & 1][k] for k in range(3)] for i in range(8)]) @ axes.T + centre
    return corners[BOX_FACES]


def principal_box(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre (3,), axes (3, 3), half sizes (3,)) of the box around ``triangles`` along their principal
    axes (:func:`oriented_box`), in the triangles' frame (m): ``axes``' columns are the box's x, y, z
    (a right-handed rotation) and ``centre`` the box's middle."""
    points = np.unique(triangles.reshape(-1, 3), axis=0)
    mean = points.mean(axis=0)
    _, axes = np.linalg.eigh(np.cov((points - mean).T) if len(points) > 1 else np.eye(3))
    if np.linalg.det(axes) < 0:  # a right-handed frame keeps the faces' winding outward
        axes[:, 0] = -axes[:, 0]
    local = (points - mean) @ axes
    low, high = local.min(axis=0), local.max(axis=0)
    return mean + axes @ ((low + high) / 2), axes, (high - low) / 2


#: The box's 12 triangles as corner indices (corner i has bit k set where it is at the high end of axis k),
#: counter-clockwise seen from outside.
BOX_FACES = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                      [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])


def mesh_arrays(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices, triangle indices, normals) of a flat-shaded mesh: every triangle its own three
    vertices with the face normal (float32 / uint32)."""
    vertices = triangles.reshape(-1, 3)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    return (vertices.astype(np.float32), np.arange(len(vertices), dtype=np.uint32).reshape(-1, 3),
            np.repeat(normals, 3, axis=0).astype(np.float32))


def mesh3d(rr, triangles: np.ndarray, rgb, alpha: int = 255) -> object:
    """A flat-shaded mesh (:func:`mesh_arrays`) of one colour (RGB 0-255, ``alpha`` 0-255)."""
    vertices, indices, normals = mesh_arrays(triangles)
    return rr.Mesh3D(vertex_positions=vertices, triangle_indices=indices, vertex_normals=normals,
                     albedo_factor=[*rgb, alpha])


def own_rgb(piece: Piece) -> tuple[int, int, int]:
    """The piece's own colour (the model's, RGB 0-255): how an element no robot builds is drawn."""
    return tuple(int(round(255 * c)) for c in piece.colour[:3])


def transform3d(rr, pose: np.ndarray):
    return rr.Transform3D(translation=pose[:3, 3].astype(np.float32), mat3x3=pose[:3, :3].astype(np.float32))


#: The state of a piece the fleet does not build (work of others, or outside the simulated selection).
UNSCHEDULED = "not in the schedule"


def piece_timelines(record: BuildRecord, node_times: dict[str, tuple[float, float]]) -> dict[str, tuple]:
    """Piece -> how a build shows it, for every way of drawing it (meshes or boxes by state):

    - ``("component", [(time s, state)])``: a part of a component the schedule builds, with that
      component's states;
    - ``("joint", (begin s, end s))``: a bolt, plate or weld of a joint the schedule assembles
      (``node_times``: node -> its first assembly start and last finish), brought from ``begin``;
    - ``("model", None)``: not built by the fleet, as the model has it from 0 s (:data:`UNSCHEDULED`)."""
    changes = {gid: history for component, history in record.states.items() for gid in record.parts.get(component, [])}
    realizing = {r: node for node in record.nodes.values() for r in node.realizing}
    out = {}
    for gid in record.pieces:
        if gid in changes:
            out[gid] = ("component", changes[gid])
        elif gid in realizing and realizing[gid].node_id in node_times:
            out[gid] = ("joint", node_times[realizing[gid].node_id])
        else:
            out[gid] = ("model", None)
    return out


def element_properties(record: BuildRecord, gid: str) -> dict[str, str]:
    """An element's properties shown on hover and selection: GlobalId, IFC class, name, storey; a unit
    of several elements (:func:`join_units`) also ``parts``, its parts' GlobalIds."""
    piece = record.pieces[gid]
    out = {"global_id": gid, "ifc_class": piece.ifc_class, "name": piece.name,
           "storey": record.storeys.get(piece.storey_id or "", piece.storey_id or "")}
    if piece.part_ids:
        out["parts"] = f"{len(piece.part_ids)}: " + ", ".join(piece.part_ids)
    return out
