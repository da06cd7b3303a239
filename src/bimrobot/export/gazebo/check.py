"""Checks of a written Gazebo package: what a user would verify before loading it into a simulator.

:func:`read_models` parses every ``models/<name>/*.sdf``; :func:`problems` lists what is wrong
(missing or empty meshes, non-positive masses, inertia tensors that are not physical);
:func:`validate_sdf` runs the sdformat validator (``ign sdf -k``, Debian ``ignition-tools`` +
``libsdformat-dev``) with ``SDF_PATH`` pointing at the package's models, so ``model://`` includes resolve.

:func:`validate_world` scales to thousands of models. libsdformat 12 (Debian 12) spends about 0.1 s
and 5 MB on every ``<include>`` (it builds the SDF specification anew for each included file) and
30-40 ms and 5 MB on every ``<model>`` element (each copies the specification's element tree), all in
one process: ``ign sdf -k`` on a world of 300 includes took 20 s and 1.7 GB here, and grows linearly.
So the world is checked as what its includes expand to, in pieces: every include is resolved as
``SDF_PATH`` would resolve it (``model://<name>`` -> ``models/<name>/model.config`` -> the model file
of the world's SDF version), include names must be unique, and the world's own elements plus every
DISTINCT included model (the same model file but for its name and pose counts once: bolts, repeated
precast parts) go through ``ign sdf -k`` in documents of :data:`BATCH_MODELS` models, the documents
checked in parallel, one process per core.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
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


BATCH_MODELS = 100
"""Models per document given to the validator: about 0.5 GB of libsdformat memory each."""

FULL_CHECK_INCLUDES = 20
"""Worlds with at most this many includes are also checked whole by ``ign sdf -k``, with libsdformat's
own include resolution (about 0.1 s per include, three times the cost of a model in a batch)."""


@dataclass
class WorldCheck:
    """What :func:`validate_world` found: ``valid``; ``includes`` and ``distinct`` (models checked by
    the validator); ``errors``: one line each."""

    world: Path
    valid: bool
    includes: int
    distinct: int
    batches: int
    errors: list[str]


def _model_file(models_dir: Path, name: str, version: str) -> Path | None:
    """The model file an ``<include><uri>model://name`` resolves to for an SDF version: model.config's
    ``<sdf>`` entry of that version (else its first entry), as SDF_PATH resolution picks it."""
    config = models_dir / name / "model.config"
    if not config.is_file():
        return None
    entries = [(e.get("version"), e.text or "") for e in ET.parse(config).getroot().iter("sdf")]
    chosen = next((text for v, text in entries if v == version), entries[0][1] if entries else None)
    path = models_dir / name / chosen.strip() if chosen else None
    return path if path is not None and path.is_file() else None


def _expanded_models(world_root: ET.Element, models_dir: Path, version: str, errors: list[str]) -> tuple[int, list[ET.Element]]:
    """(number of includes, one expanded ``<model>`` per distinct included model); unresolved includes
    and duplicate names go to ``errors``."""
    world = world_root.find("world")
    includes = world.findall("include")
    seen_names: set[str] = set()
    distinct: dict[str, ET.Element] = {}
    for include in includes:
        uri = (include.findtext("uri") or "").strip()
        name = (include.findtext("name") or uri.removeprefix("model://")).strip()
        if name in seen_names:
            errors.append(f"two models in the world are named {name!r}")
        seen_names.add(name)
        target = _model_file(models_dir, uri.removeprefix("model://"), version) if uri.startswith("model://") else None
        if target is None:
            errors.append(f"<include> {uri!r} does not resolve to a model file of SDF {version} under {models_dir}")
            continue
        text = target.read_text(encoding="utf-8")
        model = ET.fromstring(text).find("model")
        if model is None:
            errors.append(f"{target} holds no <model>")
            continue
        own_name = model.get("name") or ""
        pose = model.find("pose")
        if pose is not None:
            model.remove(pose)
        key = ET.tostring(model, encoding="unicode").replace(own_name, "\x00") if own_name else text
        if key in distinct:
            continue
        model.set("name", name)  # as <include> does: its name and pose replace the model's
        if include.find("pose") is not None:
            new_pose = ET.Element("pose")
            new_pose.text = include.findtext("pose")
            model.insert(0, new_pose)
        distinct[key] = model
    return len(includes), list(distinct.values())


def validate_world(world_file: Path, models_dir: Path, workers: int | None = None,
                   batch: int = BATCH_MODELS) -> WorldCheck:
    """Check a package's world and every distinct model it includes with ``ign sdf -k``, in parallel
    batches (see the module docstring); memory stays near ``batch`` x 5 MB per process."""
    if sdf_validator() is None:
        raise FileNotFoundError("the SDF validator `ign` is not installed (apt-get install ignition-tools libsdformat-dev)")
    world_file, models_dir = Path(world_file), Path(models_dir)
    root = ET.parse(world_file).getroot()
    version = root.get("version") or ""
    errors: list[str] = []
    count, models = _expanded_models(root, models_dir, version, errors)
    skeleton = ET.fromstring(ET.tostring(root))  # the world's own elements (physics, light, ground)
    for include in skeleton.find("world").findall("include"):
        skeleton.find("world").remove(include)
    pieces = [models[start:start + batch] for start in range(0, len(models), batch)] or [[]]
    jobs: list[tuple[Path, Path | None]] = []
    futures = []
    with tempfile.TemporaryDirectory(prefix="bimrobot-sdf-check-") as folder, \
            ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as threads:
        if count <= FULL_CHECK_INCLUDES:  # small worlds: libsdformat's own include resolution too
            jobs.append((world_file, models_dir))
            futures.append(threads.submit(validate_sdf, world_file, models_dir, 600))
        for number, piece in enumerate(pieces):  # each document is checked as soon as it is written
            document = ET.fromstring(ET.tostring(skeleton))
            document.find("world").extend(piece)
            path = Path(folder) / f"batch_{number}.sdf"
            path.write_text(ET.tostring(document, encoding="unicode"), encoding="utf-8")
            jobs.append((path, None))
            futures.append(threads.submit(validate_sdf, path, None, 600))
        outcomes = [future.result() for future in futures]
        for (path, _), (valid, output) in zip(jobs, outcomes):
            if valid:
                continue
            if path == world_file:
                errors.append(f"ign sdf -k {world_file.name}: " + " | ".join(output.splitlines()[:5]))
            else:  # name the models that fail: check the batch's models one by one
                piece = pieces[int(path.stem.removeprefix("batch_"))]
                errors += _failing_models(skeleton, piece, Path(folder)) or [
                    f"ign sdf -k {world_file.name} (models batch {path.stem}): " + " | ".join(output.splitlines()[:5])]
    return WorldCheck(world_file, not errors, count, len(models), len(pieces), errors)


def _failing_models(skeleton: ET.Element, models: list[ET.Element], folder: Path, most: int = 3) -> list[str]:
    """One line for each of the first ``most`` models that ``ign sdf -k`` refuses on their own."""
    found = []
    for model in models:
        document = ET.fromstring(ET.tostring(skeleton))
        document.find("world").append(model)
        path = folder / "single.sdf"
        path.write_text(ET.tostring(document, encoding="unicode"), encoding="utf-8")
        valid, output = validate_sdf(path, None, 600)
        if not valid:
            found.append(f"ign sdf -k: model {model.get('name')!r}: " + " | ".join(output.splitlines()[:3]))
            if len(found) >= most:
                break
    return found
