"""Checks of a written Gazebo package: what a user would verify before loading it into a simulator.

:func:`read_models` parses every ``models/<name>/*.sdf``; :func:`problems` lists what is wrong
(missing or empty meshes, non-positive masses, inertia tensors that are not physical);
:func:`validate_sdf` runs the sdformat validator (``ign sdf -k``, Debian ``ignition-tools`` +
``libsdformat-dev``) with ``SDF_PATH`` pointing at the package's models, so ``model://`` includes resolve.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class ModelInfo:
    """What one model SDF file says: names, static flag, pose text, mass (kg), inertia (3x3, kg m^2)
    about the centre of mass, mesh URIs and the files they resolve to."""

    sdf_file: Path
    version: str
    name: str
    link_name: str
    static: bool
    pose: str
    mass: float
    center_of_mass: np.ndarray
    inertia: np.ndarray
    mesh_uris: list[str]
    mesh_files: list[Path]


def read_model(sdf_file: Path, models_dir: Path) -> ModelInfo:
    """Parse one model SDF file of a package."""
    root = ET.parse(sdf_file).getroot()
    model = root.find("model")
    link = model.find("link")
    inertial = link.find("inertial")
    tensor = inertial.find("inertia")
    value = {tag: float(tensor.findtext(tag, "0")) for tag in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    inertia = np.array([
        [value["ixx"], value["ixy"], value["ixz"]],
        [value["ixy"], value["iyy"], value["iyz"]],
        [value["ixz"], value["iyz"], value["izz"]],
    ])
    com = np.array([float(v) for v in (inertial.findtext("pose") or "0 0 0 0 0 0").split()[:3]])
    uris = [uri.text for uri in link.iter("uri")]
    files = [models_dir / uri.removeprefix("model://") for uri in uris]
    return ModelInfo(
        sdf_file=sdf_file,
        version=root.get("version"),
        name=model.get("name"),
        link_name=link.get("name"),
        static=(model.findtext("static") or "false").strip() == "true",
        pose=model.findtext("pose") or "",
        mass=float(inertial.findtext("mass")),
        center_of_mass=com,
        inertia=inertia,
        mesh_uris=uris,
        mesh_files=files,
    )


def read_models(package: Path) -> list[ModelInfo]:
    """Every model SDF file in ``package/models`` (model.sdf and any model-1_6.sdf)."""
    models_dir = Path(package) / "models"
    return [read_model(path, models_dir) for path in sorted(models_dir.glob("*/*.sdf"))]


def inertia_problem(inertia: np.ndarray) -> str | None:
    """Why an inertia tensor is not physical (None if it is): symmetric, positive definite, and the
    principal moments satisfy the triangle inequality (each at most the sum of the other two)."""
    if not np.allclose(inertia, inertia.T):
        return "inertia tensor is not symmetric"
    moments = np.linalg.eigvalsh(inertia)
    if moments.min() <= 0:
        return f"inertia tensor is not positive definite (principal moments {moments})"
    a, b, c = moments
    tolerance = 1e-9 * c
    if a + b < c - tolerance:
        return f"principal moments {moments} break the triangle inequality"
    return None


def problems(package: Path) -> list[str]:
    """Everything wrong with a package's models; an empty list when it is sound."""
    found = []
    for info in read_models(package):
        where = info.sdf_file.relative_to(package)
        if info.mass <= 0:
            found.append(f"{where}: mass {info.mass} kg is not positive")
        issue = inertia_problem(info.inertia)
        if issue:
            found.append(f"{where}: {issue}")
        for uri, path in zip(info.mesh_uris, info.mesh_files):
            if not path.is_file():
                found.append(f"{where}: mesh {uri} does not exist")
            elif path.stat().st_size == 0:
                found.append(f"{where}: mesh {uri} is empty")
    return found


def sdf_validator() -> str | None:
    """Path of the ``ign`` command when the sdformat validator is installed, else None."""
    return shutil.which("ign")


def validate_sdf(sdf_file: Path, models_dir: Path | None = None, timeout: float = 120) -> tuple[bool, str]:
    """Run ``ign sdf -k`` on a world or model file; (valid, validator output)."""
    ign = sdf_validator()
    if ign is None:
        raise FileNotFoundError("the SDF validator `ign` is not installed (apt-get install ignition-tools libsdformat-dev)")
    env = dict(os.environ)
    if models_dir is not None:
        env["SDF_PATH"] = str(models_dir)
    result = subprocess.run([ign, "sdf", "-k", str(sdf_file)], capture_output=True, text=True, env=env, timeout=timeout)
    output = "\n".join(
        line for line in (result.stdout + result.stderr).splitlines() if "libignition-tools-backward" not in line
    )
    return result.returncode == 0 and "Valid." in result.stdout, output.strip()
