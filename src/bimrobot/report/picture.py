"""The assembled building's picture: every element of the build's package at its installed pose.

The package of a build has its components on the yard (its ``preview.png`` shows the yard); the
report shows the building finished instead. Each element's visual mesh is the package's own
(``models/<model>/meshes/<model>.dae``, the colours the simulator shows), placed by the element's
IFC placement (from the model file, read once for the report: :attr:`BuildFacts.building_model`), and
painted with :func:`bimrobot.export.gazebo.render.paint` (Pillow; metres, z up, a scale bar).
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

#: Above this many triangles the picture is painted from every n-th triangle of the larger meshes
#: (Pillow paints each one; about 10 s per 100,000 on a slow core).
MAX_TRIANGLES = 150_000


def installed_triangles(package: Path, report: dict, model) -> tuple[np.ndarray, np.ndarray]:
    """World triangles (k, 3, 3; metres, model frame) and RGBA colours (k, 4) of the package's elements
    at their installed poses (``model``: the BuildingModel). Raises OSError when a mesh cannot be read."""
    from bimrobot.export.gazebo.layout import rigid
    from bimrobot.export.gazebo.render import dae_triangles

    triangles, colours = [], []
    for entry in report.get("converted") or []:
        element = model.elements.get(entry.get("global_id"))
        dae = package / "models" / str(entry.get("model")) / "meshes" / f"{entry.get('model')}.dae"
        if element is None or not dae.is_file():
            continue  # merged static models, elements the model no longer has
        local, colour = dae_triangles(dae)
        pose = rigid(element.placement)
        triangles.append(local @ pose[:3, :3].T + pose[:3, 3])
        colours.append(np.tile(colour, (len(local), 1)))
    if not triangles:
        return np.zeros((0, 3, 3)), np.zeros((0, 4))
    return np.concatenate(triangles), np.concatenate(colours)


def draw_building(folder: Path, png: Path, facts) -> str | None:
    """Paint the assembled building of the build in ``folder`` into ``png`` (through bimrobot.core.io's
    output policy); return None when drawn, else why not, in words (no package, model file gone, ...)."""
    from bimrobot.core.errors import InputError
    from bimrobot.export.gazebo.render import paint

    package = Path(folder) / "package"
    report = facts.package
    if not report.get("converted"):
        return "the build has no package (package/report.json) to draw"
    if facts.building_model is None:
        return facts.model_note or "the model was not read"
    try:
        triangles, colours = installed_triangles(package, report, facts.building_model)
    except (OSError, InputError, ValueError) as exc:
        return f"the package's meshes could not be read ({exc})"
    if not len(triangles):
        return "the package has no element meshes"
    if len(triangles) > MAX_TRIANGLES:
        keep = np.linspace(0, len(triangles) - 1, MAX_TRIANGLES).astype(int)
        triangles, colours = triangles[keep], colours[keep]
    title = f"{facts.project or facts.model}: assembled (metres, z up)"
    paint(triangles, colours, png, [], elevation=25, azimuth=-55, size=(8, 6), title=title)
    return None
