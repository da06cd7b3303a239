"""A picture of a converted package: every model's visual mesh at its world pose (Pillow, no GPU).

Reads what a simulator would read (the world SDF's includes and each model's DAE), so the picture
shows the package, not the IFC file.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from bimrobot.core import io
from bimrobot.core.frames import sdf_pose_matrix as pose_matrix  # the SDF pose's transform, said in bimrobot.core.frames


def _pose_matrix(text: str) -> np.ndarray:
    return pose_matrix(*(float(v) for v in text.split()))


def world_triangles(package: Path, world_file: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """All visual triangles of the world in world coordinates (k, 3, 3) and their RGBA colours (k, 4)."""
    from bimrobot.export.gazebo.check import read_models  # reading a package back: not convert's own picture

    package = Path(package)
    world_path = package / world_file if world_file else sorted((package / "worlds").glob("*"))[0]
    world = ET.parse(world_path).getroot()
    poses = {inc.findtext("name"): _pose_matrix(inc.findtext("pose")) for inc in world.iter("include")}
    triangles, colours = [], []
    for info in read_models(package):
        if info.sdf_file.name != "model.sdf" or info.name not in poses:
            continue
        dae_file = next(f for f in info.mesh_files if f.suffix == ".dae")
        local, colour = dae_triangles(dae_file)
        pose = poses[info.name]
        triangles.append(local @ pose[:3, :3].T + pose[:3, 3])
        colours.append(np.tile(colour, (len(local), 1)))
    return np.concatenate(triangles), np.concatenate(colours)


def mesh_triangles(models: list[tuple[str, str, np.ndarray, np.ndarray, str]]) -> tuple[np.ndarray, np.ndarray]:
    """What :func:`world_triangles` reads back from a package, computed from the meshes in memory
    while the package is being written (no file read back), with the same numbers in the same order.

    ``models``: (model name, its include's SDF pose text, local vertices (n, 3) and faces (m, 3) as
    its DAE holds them, the DAE's colour text "r g b a"). The vertices are rounded as the DAE text
    rounds them (:data:`bimrobot.export.gazebo.meshes.POSITION_FORMAT`); the models come in the order of
    :func:`bimrobot.export.gazebo.check.read_models` (by folder name)."""
    from bimrobot.export.gazebo.meshes import POSITION_FORMAT, number_text

    triangles, colours = [], []
    rounded: dict[tuple[int, int], np.ndarray] = {}  # models sharing a mesh (the same arrays) share its corners
    for _, pose_text, vertices, faces, colour_text in sorted(models, key=lambda m: Path(m[0], "model.sdf")):
        key = (id(vertices), id(faces))
        if key not in rounded:
            positions = np.array(number_text(POSITION_FORMAT, vertices.ravel().tolist()).split(), float).reshape(-1, 3)
            rounded[key] = positions[faces.ravel()].reshape(-1, 3, 3)
        local = rounded[key]
        pose = _pose_matrix(pose_text)
        triangles.append(local @ pose[:3, :3].T + pose[:3, 3])
        colours.append(np.tile(np.array(colour_text.split(), float), (len(local), 1)))
    return np.concatenate(triangles), np.concatenate(colours)


_DAE = "{http://www.collada.org/2005/11/COLLADASchema}"


def dae_triangles(dae_file: Path) -> tuple[np.ndarray, np.ndarray]:
    """The triangles of a model's COLLADA visual in its local frame (k, 3, 3), metres, and its RGBA
    colour (4,), 0..1 (the first diffuse colour; grey when it has none).

    Reads the triangle lists of every geometry (the form bimrobot writes) directly with ElementTree,
    which is about ten times quicker than pycollada here; a file in any other form goes to pycollada."""
    root = ET.parse(dae_file).getroot()
    colour_text = root.findtext(f".//{_DAE}diffuse/{_DAE}color")
    colour = np.array(colour_text.split(), float) if colour_text else np.array([0.6, 0.6, 0.6, 1.0])
    pieces = []
    for mesh in root.iter(f"{_DAE}mesh"):
        arrays = {a.get("id"): a.text or "" for a in mesh.iter(f"{_DAE}float_array")}
        vertices = {v.get("id"): v.find(f"{_DAE}input[@semantic='POSITION']") for v in mesh.iter(f"{_DAE}vertices")}
        if mesh.find(f"{_DAE}polylist") is not None or mesh.find(f"{_DAE}polygons") is not None:
            return _dae_triangles_pycollada(dae_file)
        for triangles in mesh.iter(f"{_DAE}triangles"):
            inputs = triangles.findall(f"{_DAE}input")
            vertex = next(i for i in inputs if i.get("semantic") == "VERTEX")
            source = vertices[vertex.get("source").lstrip("#")].get("source").lstrip("#")
            positions = np.array(arrays[f"{source}-array"].split(), float).reshape(-1, 3)
            stride = 1 + max(int(i.get("offset", 0)) for i in inputs)
            indices = np.array((triangles.findtext(f"{_DAE}p") or "").split(), int)
            corners = indices.reshape(-1, stride)[:, int(vertex.get("offset", 0))]
            pieces.append(positions[corners].reshape(-1, 3, 3))
    triangles = np.concatenate(pieces) if pieces else np.zeros((0, 3, 3))
    return triangles, colour


def _dae_triangles_pycollada(dae_file: Path) -> tuple[np.ndarray, np.ndarray]:
    import collada

    dae = collada.Collada(str(dae_file))
    colour = dae.effects[0].diffuse if dae.effects else (0.6, 0.6, 0.6, 1.0)
    sets = [p.triangleset() if hasattr(p, "triangleset") else p for g in dae.geometries for p in g.primitives]
    pieces = [t.vertex[t.vertex_index] for t in sets if len(t.vertex_index)]
    triangles = np.concatenate(pieces) if pieces else np.zeros((0, 3, 3))
    return np.asarray(triangles, float), np.asarray(colour, float)


def _view_axes(elevation: float, azimuth: float) -> np.ndarray:
    """Rows: screen right, screen up and towards the eye, for an eye at ``elevation`` degrees above
    the horizon and ``azimuth`` degrees about z from +x (matplotlib's ``view_init`` convention)."""
    el, az = np.radians(elevation), np.radians(azimuth)
    towards_eye = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    right = np.array([-np.sin(az), np.cos(az), 0.0])
    return np.array([right, np.cross(towards_eye, right), towards_eye])


def _scale_bar_m(span_m: float) -> float:
    """A round length (1, 2 or 5 x 10^n m) of about a fifth of ``span_m``."""
    rough = max(span_m / 5, 1e-3)
    power = 10 ** np.floor(np.log10(rough))
    return float(min((f * power for f in (1, 2, 5, 10)), key=lambda length: abs(length - rough)))


def render_package(package: Path, png: Path, world_file: str | None = None, elevation: float = 22,
                   azimuth: float = -58, size: tuple[float, float] = (8, 6), title: str | None = None) -> Path:
    """Render the package's world to ``png``: an orthographic view from ``elevation``/``azimuth``
    (degrees), shaded by a fixed light, with a scale bar in metres and the x/y/z axes; ``size`` in
    inches at 110 dpi. Triangles are painted far to near (Pillow; no 3-D library to import).

    ``png`` follows :mod:`bimrobot.core.io`'s policy: a picture bimrobot drew is replaced, any other
    existing file is refused (checked before drawing)."""
    io.check_output(png, folder=False, inputs=[package])
    triangles, colours = world_triangles(package, world_file)
    return paint(triangles, colours, png, [package], elevation, azimuth, size, title)


def paint(triangles: np.ndarray, colours: np.ndarray, png: Path, inputs: list, elevation: float = 22,
          azimuth: float = -58, size: tuple[float, float] = (8, 6), title: str | None = None) -> Path:
    """Draw world triangles (k, 3, 3; metres) in their RGBA colours (k, 4; 0..1) into ``png`` as
    :func:`render_package` describes; ``inputs``: the paths the picture must not replace."""
    from PIL import Image, ImageDraw, PngImagePlugin

    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    light = np.array([0.4, -0.6, 0.7]) / np.linalg.norm([0.4, -0.6, 0.7])
    shade = 0.45 + 0.55 * np.abs(normals @ light)
    rgb = np.clip(colours[:, :3] * shade[:, None] * 255, 0, 255).astype(np.uint8)

    width, height = int(size[0] * 110), int(size[1] * 110)
    axes = _view_axes(elevation, azimuth)
    view = triangles @ axes.T  # (k, 3, 3): screen x, screen y, depth towards the eye
    lower, upper = view[..., :2].reshape(-1, 2).min(axis=0), view[..., :2].reshape(-1, 2).max(axis=0)
    top, margin = 40, 30
    scale = min((width - 2 * margin) / max(upper[0] - lower[0], 1e-6),
                (height - top - 2 * margin) / max(upper[1] - lower[1], 1e-6))
    centre = (lower + upper) / 2
    pixels = np.empty(view.shape[:2] + (2,))
    pixels[..., 0] = width / 2 + (view[..., 0] - centre[0]) * scale
    pixels[..., 1] = (height + top) / 2 - (view[..., 1] - centre[1]) * scale

    image = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(image)
    order = np.argsort(view[..., 2].mean(axis=1), kind="stable")  # far to near
    # What ImageDraw.polygon(corners, fill=colour) does for an RGB image, without its per-call checks of
    # the outline and the colour's kind (a third of the painting's time): Pillow's own ink and fill.
    ink, fill_polygon = draw.draw.draw_ink, draw.draw.draw_polygon
    for corners, colour in zip(pixels[order].reshape(-1, 6).tolist(), rgb[order].tolist()):
        fill_polygon(corners, ink(tuple(colour)), 1)
    if title:
        draw.text((margin, 12), title, fill="black")
    bar_m = _scale_bar_m(float(max(upper - lower)))
    x0, y0 = margin, height - margin
    draw.line([(x0, y0), (x0 + bar_m * scale, y0)], fill="black", width=3)
    draw.text((x0, y0 + 4), f"{bar_m:g} m", fill="black")
    origin = np.array([width - margin - 40, height - margin - 10.0])
    for axis, name, colour in ((0, "x", (200, 30, 30)), (1, "y", (30, 150, 30)), (2, "z", (30, 60, 200))):
        tip = origin + np.array([axes[0, axis], -axes[1, axis]]) * 30
        draw.line([tuple(origin), tuple(tip)], fill=colour, width=2)
        draw.text(tuple(tip + 2), name, fill=colour)

    info = PngImagePlugin.PngInfo()
    info.add_text("Software", io.signature("world render"))
    png = Path(png)
    # Through the output policy: a PNG bimrobot drew (its signature in a text chunk) is replaced,
    # any other existing file is refused.
    with io.atomic_output_file(png, inputs=inputs) as tmp:
        image.save(tmp, format="PNG", pnginfo=info)
    return png


#: Above this many visual triangles `convert` skips its preview picture (Pillow paints every one).
PREVIEW_MAX_TRIANGLES = 60_000


def render_preview(package: Path, triangles: int) -> str | None:
    """Draw ``package/preview.png`` (the world seen from above a corner of the site) for a package
    being written, whose visuals have ``triangles`` triangles in all; return its name, or None when
    the world is too large to draw in a few seconds (PREVIEW_MAX_TRIANGLES)."""
    package = Path(package)
    worlds = sorted((package / "worlds").glob("*.sdf"))
    if not worlds or triangles > PREVIEW_MAX_TRIANGLES:
        return None
    render_package(package, package / "preview.png", world_file=str(worlds[0].relative_to(package)),
                   title=f"{worlds[0].stem} (metres, z up)")
    return "preview.png"


def draw_preview(package: Path, world_name: str, models: list[tuple[str, str, np.ndarray, np.ndarray, str]]) -> str:
    """Draw ``package/preview.png`` as :func:`render_preview` does, from the models' meshes in memory
    (:func:`mesh_triangles`), so that it can be drawn while the package's files are still being
    written; the same picture, byte for byte. Returns its name."""
    package = Path(package)
    triangles, colours = mesh_triangles(models)
    paint(triangles, colours, package / "preview.png", [package], title=f"{world_name} (metres, z up)")
    return "preview.png"
