"""Read an IFC model in a forked process while this one does something else.

``bimrobot convert`` needs IfcOpenShell for the read and, for the writing, trimesh, SciPy and its package
writer: about 1.2 s of CPU to import. Read in this process, the import could only overlap the geometry
processes, and the interpreter's first half second (IfcOpenShell's import, parsing the file, reading its
materials and storeys) ran on one core while the other waited. Here one forked process reads the model
(:func:`bimrobot.bim.reader.load_model`, which forks the geometry processes in turn) from the start,
and this process imports meanwhile, on the other core. The model comes back pickled (0.69 MB and about
20 ms both ways for GEELEN's 279 elements); meshes shared by several elements stay shared. This module
imports neither IfcOpenShell nor NumPy: the forked process does.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Callable

from bimrobot.core.errors import InputError

if TYPE_CHECKING:
    from bimrobot.bim.model import BuildingModel


def load_model_meanwhile(path: str | Path, meanwhile: Callable[[], object], **options) -> BuildingModel:
    """:func:`bimrobot.bim.reader.load_model` (``path``, ``**options``) in a forked process while this one
    calls ``meanwhile()``; the same model (metres, z up, kg) and the same errors. Where fork is unsafe
    (:func:`bimrobot.core.cores.can_fork`), read here, ``meanwhile`` called while the geometry is read."""
    from bimrobot.core.cores import can_fork

    if not can_fork():
        from bimrobot.bim.reader import load_model

        return load_model(path, meanwhile=meanwhile, **options)
    from bimrobot.core.forked import Forked

    # not daemonic: the reading process forks the geometry processes of its own
    reading = Forked(_load, (path, options), daemon=False)
    try:
        meanwhile()
        model = reading.outcome(lambda exit_code: InputError(
            f"{Path(path).name}: the process reading it ended without a model (exit code {exit_code})"))
    finally:
        reading.stop()
    for element in model.elements.values():  # read-only again, as the reader made them (pickling dropped it)
        element.vertices.setflags(write=False)
        element.faces.setflags(write=False)
    return model


def _load(path: str | Path, options: dict) -> BuildingModel:
    from bimrobot.bim.reader import load_model

    return load_model(path, **options)
