"""Where each component waits on the yard, read from a world package (``bimrobot convert --layout yard``).

The package's ``report.json`` gives every converted element its pose on the yard (``pose_xyz_rpy``: x, y,
z in metres and roll, pitch, yaw in radians, fixed axes, world frame) and its centre of mass in its own
frame; the pick-up position of an element is that centre of mass on the yard, and of an assembly the
mass-weighted mean of its parts' (they are laid out part by part). One site then serves the world, the
graph and RCAN: the robots drive to where the world shows the components.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from bimrobot.core.errors import InputError
from bimrobot.core.frames import sdf_pose_matrix


def pick_up_positions(package: Path, model, model_path: Path | None = None) -> dict[str, tuple[float, float, float]]:
    """GlobalId (element or assembly of ``model``) -> pick-up position (m, world frame) on the yard of
    ``package``. InputError when the folder is no world package, was not laid out on the yard, or
    converted none of the model's elements (another model's package)."""
    report_path = Path(package) / "report.json"
    try:
        report = json.loads(report_path.read_text(encoding="utf-8"))
        converted, layout = report["converted"], report["options"]["layout"]
    except (OSError, ValueError, KeyError, TypeError):
        raise InputError(f"--package {package} is not a world package of `bimrobot convert` (no readable report.json)") from None
    if layout != "yard":
        raise InputError(f"--package {package} was converted with --layout {layout}: pick-up positions need --layout yard")
    centres, masses = {}, {}
    for entry in converted:
        gid = entry.get("global_id")
        if gid in model.elements and entry.get("pose_xyz_rpy") and entry.get("center_of_mass_m"):
            x, y, z, roll, pitch, yaw = (float(v) for v in entry["pose_xyz_rpy"])
            pose = sdf_pose_matrix(x, y, z, roll, pitch, yaw)
            centres[gid] = (pose @ np.append(np.asarray(entry["center_of_mass_m"], dtype=float), 1.0))[:3]
            masses[gid] = float(entry.get("mass_kg") or 0.0)
    if not centres:
        shown = model_path or model.source or "the model"
        raise InputError(f"--package {package} converted none of the elements of {shown}: give the package of the same model")
    positions = {gid: tuple(round(float(v), 6) for v in xyz) for gid, xyz in centres.items()}
    for gid, assembly in getattr(model, "assemblies", {}).items():
        parts = [p for p in assembly.part_ids if p in centres]
        if parts:
            weights = np.array([masses[p] for p in parts]) if sum(masses[p] for p in parts) > 0 else np.ones(len(parts))
            mean = np.average(np.array([centres[p] for p in parts]), axis=0, weights=weights)
            positions[gid] = tuple(round(float(v), 6) for v in mean)
    return positions
