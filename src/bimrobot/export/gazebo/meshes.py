"""Mesh files of a Gazebo model: a COLLADA visual and a simplified STL collision mesh.

Why COLLADA for the visual: both Gazebo Sim (gz-common) and Gazebo Classic load ``.dae`` with their
own COLLADA loader, which scales by ``<asset><unit meter>`` and applies no up-axis rotation, so a
Z-up mesh in metres appears exactly where the SDF pose puts it. glTF is Y-up by specification and goes
through Assimp in Gazebo Sim only (not Classic), so one DAE serves both simulators. We still write
``<up_axis>Z_UP</up_axis>`` and ``<unit meter="1"/>`` so that tools that honour them (Blender, Assimp)
agree with Gazebo. Vertices stay in the element's local frame (the SDF link frame), metres.

STL for collision: every physics engine loads it (MuJoCo too), and it carries no material noise.
Colours are opaque on purpose: COLLADA ``<transparency>`` is read inverted by some loaders, which
makes whole models invisible.
"""

from __future__ import annotations

import logging
from pathlib import Path

from typing import TYPE_CHECKING

import numpy as np

from bimrobot.core.errors import MissingExtraError
if TYPE_CHECKING:
    from bimrobot.export.inertia import Body

CLASS_COLOURS: dict[str, tuple[float, float, float, float]] = {
    "IfcBeam": (0.45, 0.55, 0.70, 1.0),
    "IfcColumn": (0.30, 0.42, 0.62, 1.0),
    "IfcMember": (0.50, 0.60, 0.72, 1.0),
    "IfcPlate": (0.40, 0.45, 0.50, 1.0),
    "IfcMechanicalFastener": (0.80, 0.65, 0.20, 1.0),
    "IfcFastener": (0.80, 0.65, 0.20, 1.0),
    "IfcFooting": (0.70, 0.70, 0.68, 1.0),
    "IfcSlab": (0.75, 0.75, 0.73, 1.0),
    "IfcWall": (0.88, 0.84, 0.76, 1.0),
    "IfcWallStandardCase": (0.88, 0.84, 0.76, 1.0),
    "IfcRoof": (0.65, 0.30, 0.25, 1.0),
    "IfcWindow": (0.55, 0.75, 0.90, 1.0),
    "IfcDoor": (0.55, 0.38, 0.22, 1.0),
    "IfcStair": (0.70, 0.70, 0.68, 1.0),
    "IfcRailing": (0.35, 0.35, 0.35, 1.0),
}
DEFAULT_COLOUR = (0.65, 0.65, 0.65, 1.0)

log = logging.getLogger(__name__)


POSITION_FORMAT = "%.7g"
"""How the DAE writes vertex coordinates (metres): 7 significant digits, float precision."""


def colour_of(ifc_class: str) -> tuple[float, float, float, float]:
    """RGBA in 0..1 used for an IFC class in visuals and pictures."""
    return CLASS_COLOURS.get(ifc_class, DEFAULT_COLOUR)


def write_dae(path: Path, vertices: np.ndarray, faces: np.ndarray, name: str, rgba=DEFAULT_COLOUR) -> None:
    """Write a triangle mesh (local frame, metres, Z up) as COLLADA 1.4.1 with flat per-face normals."""
    Path(path).write_text(dae_text(vertices, faces, name, rgba), encoding="utf-8")


def dae_text(vertices: np.ndarray, faces: np.ndarray, name: str, rgba=DEFAULT_COLOUR) -> str:
    """COLLADA 1.4.1 text of a triangle mesh (see :func:`write_dae`)."""
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    normals = _face_normals(vertices, faces)
    positions = number_text(POSITION_FORMAT, vertices.ravel().tolist())
    normal_text = number_text("%.4g", normals.ravel().tolist())
    # Each triangle corner: vertex index, then normal index (= face index).
    indices = np.stack([faces, np.repeat(np.arange(len(faces))[:, None], 3, axis=1)], axis=2).ravel()
    index_text = number_text("%d", indices.tolist())
    r, g, b, a = rgba
    return _DAE_TEMPLATE.format(
        name=_xml_attr(name),
        nvert=len(vertices),
        ncoord=vertices.size,
        positions=positions,
        nnorm=len(normals),
        nncoord=normals.size,
        normals=normal_text,
        ntri=len(faces),
        indices=index_text,
        colour=colour_text(rgba),
        ambient=f"{r * 0.4:.3f} {g * 0.4:.3f} {b * 0.4:.3f} 1",
    )


STL_RECORD = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


def write_stl(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Write a binary STL (metres; STL has no unit, Gazebo and MuJoCo read it as metres)."""
    Path(path).write_bytes(stl_bytes(vertices, faces))


def stl_bytes(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    """Binary STL content of a triangle mesh (see :func:`write_stl`)."""
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    records = np.zeros(len(faces), dtype=STL_RECORD)
    records["normal"] = _face_normals(vertices, faces)
    records["corners"] = vertices[faces]
    header = b"bimrobot collision mesh, metres".ljust(80, b" ")
    return header + np.uint32(len(faces)).tobytes() + records.tobytes()


def collision_mesh(body: Body, method: str, max_triangles: int) -> tuple[np.ndarray, np.ndarray]:
    """A simplified collision body (vertices, faces): the convex hull of ``body``, or ``body``
    decimated to ``max_triangles``.

    ``method`` is "convex" or "decimated". Either result has at most ``max_triangles`` faces where
    the input allows (a hull over budget is rebuilt from a decimated mesh). Flat or degenerate bodies
    that have no hull keep their own (possibly decimated) triangles.
    """
    if method == "convex":
        if body.hull is None:
            return _decimated(body.vertices, body.faces, max_triangles)
        vertices, faces = body.hull
        if len(faces) > max_triangles:
            from bimrobot.export.inertia import convex_hull  # SciPy's Qhull: imported by the work that needs it

            try:
                smaller = convex_hull(_decimated(body.vertices, body.faces, max_triangles)[0])
            except MissingExtraError:  # without the decimator a hull over budget is still a hull
                log.warning("collision hull of %d triangles kept over the budget of %d", len(faces), max_triangles)
                smaller = None
            if smaller is not None and len(smaller[1]) < len(faces):
                vertices, faces = smaller
        return vertices, faces
    if method == "decimated":
        return _decimated(body.vertices, body.faces, max_triangles)
    raise ValueError(f"unknown collision method {method!r} (expected 'convex' or 'decimated')")


def _decimated(vertices: np.ndarray, faces: np.ndarray, max_triangles: int) -> tuple[np.ndarray, np.ndarray]:
    if len(faces) <= max_triangles:
        return vertices, faces
    _require_decimator()
    import trimesh  # imported by the work that needs it (about 1 s with SciPy and networkx)

    try:
        mesh = trimesh.Trimesh(vertices, faces, process=False).simplify_quadric_decimation(face_count=max_triangles)
    except Exception:  # the decimator refuses some degenerate meshes: keep the full body
        return vertices, faces
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def colour_text(rgba) -> str:
    """The DAE's diffuse colour text of an RGBA colour (0..1)."""
    r, g, b, a = rgba
    return f"{r:.3f} {g:.3f} {b:.3f} {a:.3f}"


def number_text(pattern: str, values: list) -> str:
    """Numbers as space-separated text (one %-format call: the fastest way in CPython)."""
    if not values:
        return ""
    return ((pattern + " ") * len(values) % tuple(values))[:-1]


def _require_decimator() -> None:
    """trimesh's quadric decimation runs on the fast-simplification package."""
    try:
        import fast_simplification  # noqa: F401
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise MissingExtraError(
            "decimating collision meshes needs the package fast-simplification: pip install fast-simplification"
        ) from exc


def _face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    corners = vertices[faces]
    normals = cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross products of (n, 3) arrays: the same floating-point operations, in the same order,
    as ``np.cross`` (so the same bits), without its per-call axis handling, which costs more than the
    arithmetic on the small meshes of building elements."""
    result = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a, b))
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    result[..., 0] = a1 * b2 - a2 * b1
    result[..., 1] = a2 * b0 - a0 * b2
    result[..., 2] = a0 * b1 - a1 * b0
    return result


def _xml_attr(text: str) -> str:
    return text.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;").replace(">", "&gt;")


_DAE_TEMPLATE = """<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset>
    <contributor><authoring_tool>bimrobot</authoring_tool></contributor>
    <unit name="meter" meter="1"/>
    <up_axis>Z_UP</up_axis>
  </asset>
  <library_effects>
    <effect id="effect">
      <profile_COMMON>
        <technique sid="common">
          <phong>
            <ambient><color>{ambient}</color></ambient>
            <diffuse><color>{colour}</color></diffuse>
            <specular><color>0.1 0.1 0.1 1</color></specular>
            <shininess><float>10</float></shininess>
          </phong>
        </technique>
      </profile_COMMON>
    </effect>
  </library_effects>
  <library_materials>
    <material id="material" name="material"><instance_effect url="#effect"/></material>
  </library_materials>
  <library_geometries>
    <geometry id="geometry" name="{name}">
      <mesh>
        <source id="positions">
          <float_array id="positions-array" count="{ncoord}">{positions}</float_array>
          <technique_common>
            <accessor source="#positions-array" count="{nvert}" stride="3">
              <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <source id="normals">
          <float_array id="normals-array" count="{nncoord}">{normals}</float_array>
          <technique_common>
            <accessor source="#normals-array" count="{nnorm}" stride="3">
              <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="vertices"><input semantic="POSITION" source="#positions"/></vertices>
        <triangles count="{ntri}" material="material">
          <input semantic="VERTEX" source="#vertices" offset="0"/>
          <input semantic="NORMAL" source="#normals" offset="1"/>
          <p>{indices}</p>
        </triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="scene">
      <node id="node" name="{name}">
        <instance_geometry url="#geometry">
          <bind_material><technique_common>
            <instance_material symbol="material" target="#material"/>
          </technique_common></bind_material>
        </instance_geometry>
      </node>
    </visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
"""
