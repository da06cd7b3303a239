"""``convert``: an IFC file to its Gazebo package, the model read in one process while this one loads the writer.

This module is light on purpose (no IfcOpenShell, no NumPy-heavy writer, no trimesh or SciPy at import):
``bimrobot convert`` forks a process that reads the model (:mod:`bimrobot.bim.forked_read`: IfcOpenShell's
import, the parse, then the geometry in processes of its own) and, meanwhile, imports the package writer
(:mod:`bimrobot.export.gazebo.package`) and the bodies' mass and hull libraries, about 1.2 CPU s. Before,
this process read the model itself and imported the writer only once the geometry processes ran: its
first half second (IfcOpenShell's import and the parse) kept one core busy while the other waited. On
GEELEN (305 products) the geometry processes now start at the same time as before, and the model is in
hand when the writer is (docs/world.md). Units: metres, kg, seconds; z up.
"""

from __future__ import annotations

import time
from pathlib import Path

from bimrobot.core import io
from bimrobot.core.cores import frozen_heap
from bimrobot.export.gazebo.options import ConvertOptions


def convert(
    ifc_path: str | Path,
    out_dir: str | Path,
    options: ConvertOptions | None = None,
    include: list[str] | str | None = None,
    exclude: list[str] | str | None = None,
    progress: bool = False,
) -> dict:
    """Read an IFC file (``.ifc`` or ``.ifczip``) and write its Gazebo package to ``out_dir``; return
    the report (also in ``out_dir/report.json``). ``include`` / ``exclude``: IfcOpenShell selectors
    (:mod:`bimrobot.bim.selection`). Bad input raises InputError and leaves no ``out_dir``."""
    from bimrobot.bim.forked_read import load_model_meanwhile  # light: the forked process imports IfcOpenShell

    options = options or ConvertOptions()
    options.validate()
    io.check_output(out_dir, folder=True, inputs=[ifc_path])  # before the long read
    with frozen_heap():  # no full garbage collections through every library object on the way
        started = time.perf_counter()
        # Element.properties and the assemblies are not needed to convert: only what the weights need is read.
        model = load_model_meanwhile(ifc_path, _import_writer, include=include, exclude=exclude, progress=progress,
                                     properties=False, unknown_weight=options.unknown_weight, assemblies=False)
        load_seconds = time.perf_counter() - started
        from bimrobot.export.gazebo.package import build_package

        return build_package(model, out_dir, options, progress, load_seconds)


def _import_writer() -> None:
    """Import the package writer, trimesh and SciPy (:mod:`bimrobot.export.inertia`: the bodies' hulls and
    mass integrals), Pillow's PNG encoder and the worker pool, about 1.2 s of CPU in all, which
    :func:`convert` does while another process reads the model (a user waits less wherever a core is free
    of the reading for a while: at first, while IfcOpenShell loads and parses the file, one is)."""
    import multiprocessing.pool  # noqa: F401  (the writer's workers: bimrobot.core.pool)

    from PIL import Image

    from bimrobot.export import inertia  # noqa: F401
    from bimrobot.export.gazebo import package  # noqa: F401

    Image.preinit()  # preview.png's encoder: Pillow loads its five common formats' plugins on the first save
