"""A picture of a converted package: every model's visual mesh at its world pose (matplotlib, no GPU).

Reads what a simulator would read (the world SDF's includes and each model's DAE), so the picture
shows the package, not the IFC file.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from bimrobot import io
from bimrobot.world.check import read_models


def _pose_matrix(text: str) -> np.ndarray:
    return pose_matrix(*(float(v) for v in text.split()))


def pose_matrix(x: float, y: float, z: float, roll: float, pitch: float, yaw: float) -> np.ndarray:
    """4x4 local-to-world matrix of an SDF pose (metres, radians; rotation = Rz(yaw) Ry(pitch) Rx(roll))."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    matrix = np.eye(4)
    matrix[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    matrix[:3, 3] = (x, y, z)
    return matrix


def world_triangles(package: Path, world_file: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """All visual triangles of the world in world coordinates (k, 3, 3) and their RGBA colours (k, 4)."""
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


def dae_triangles(dae_file: Path) -> tuple[np.ndarray, np.ndarray]:
    """The triangles of a model's COLLADA visual in its local frame (k, 3, 3), metres, and its RGBA
    colour (4,), 0..1 (the first effect's diffuse colour; grey when it has none)."""
    import collada

    dae = collada.Collada(str(dae_file))
    colour = dae.effects[0].diffuse if dae.effects else (0.6, 0.6, 0.6, 1.0)
    pieces = [p.vertex[p.vertex_index] for g in dae.geometries for p in g.primitives if len(p.vertex_index)]
    triangles = np.concatenate(pieces) if pieces else np.zeros((0, 3, 3))
    return np.asarray(triangles, float), np.asarray(colour, float)


def render_package(package: Path, png: Path, world_file: str | None = None, elevation: float = 22,
                   azimuth: float = -58, size: tuple[float, float] = (8, 6), title: str | None = None) -> Path:
    """Render the package's world to ``png`` (shaded by a fixed light; metres on the axes).

    ``png`` follows :mod:`bimrobot.io`'s policy: a picture bimrobot drew is replaced, any other
    existing file is refused (checked before drawing)."""
    io.check_output(png, folder=False, inputs=[package])
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    triangles, colours = world_triangles(package, world_file)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    light = np.array([0.4, -0.6, 0.7]) / np.linalg.norm([0.4, -0.6, 0.7])
    shade = 0.45 + 0.55 * np.abs(normals @ light)
    shaded = colours.copy()
    shaded[:, :3] *= shade[:, None]
    figure = plt.figure(figsize=size, dpi=110)
    axes = figure.add_subplot(projection="3d")
    axes.add_collection3d(Poly3DCollection(triangles, facecolors=shaded, edgecolors="none"))
    lower, upper = triangles.reshape(-1, 3).min(axis=0), triangles.reshape(-1, 3).max(axis=0)
    axes.set_xlim(lower[0], upper[0])
    axes.set_ylim(lower[1], upper[1])
    axes.set_zlim(lower[2], upper[2])
    axes.set_box_aspect(np.maximum(upper - lower, 1e-3))
    axes.view_init(elev=elevation, azim=azimuth)
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.set_zlabel("z (m)")
    if title:
        axes.set_title(title)
    figure.tight_layout()
    png = Path(png)
    try:
        # Through the output policy: a PNG bimrobot drew (its signature in a text chunk) is replaced,
        # any other existing file is refused.
        with io.atomic_output_file(png, inputs=[package]) as tmp:
            figure.savefig(tmp, format="png", metadata={"Software": io.signature("world render")})
    finally:
        plt.close(figure)
    return png


#: Above this many visual triangles `convert` skips its preview picture (matplotlib draws every one).
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
