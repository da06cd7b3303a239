"""``convert``: an IFC file to its Gazebo package, with the package writer loaded while the geometry is computed.

This module is light on purpose (no NumPy-heavy writer, no trimesh or SciPy at import): ``bimrobot
convert`` imports it and IfcOpenShell's reader, forks the processes that compute the geometry, and only
then, while they work, imports the package writer (:mod:`bimrobot.export.gazebo.package`) and the
bodies' mass and hull libraries. Imported before the fork they would keep one core busy while the other
waits; for the writer alone that is little (the fork came at 0.68 instead of 0.70 CPU s on GEELEN, most
of its imports being loaded by the options already), for trimesh and SciPy about 1.1 CPU s. Units:
metres, kg, seconds; z up.
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
    from bimrobot.bim.reader import load_model  # imported here: only bim/ touches ifcopenshell

    options = options or ConvertOptions()
    options.validate()
    io.check_output(out_dir, folder=True, inputs=[ifc_path])  # before the long read
    with frozen_heap():  # no full garbage collections through every library object on the way
        started = time.perf_counter()
        # Element.properties and the assemblies are not needed to convert: only what the weights need is read.
        model = load_model(ifc_path, include=include, exclude=exclude, progress=progress, properties=False,
                           unknown_weight=options.unknown_weight, assemblies=False, meanwhile=_import_writer)
        load_seconds = time.perf_counter() - started
        from bimrobot.export.gazebo.package import build_package

        return build_package(model, out_dir, options, progress, load_seconds)


def _import_writer() -> None:
    """Import the package writer, trimesh and SciPy (:mod:`bimrobot.export.inertia`: the bodies' hulls and
    mass integrals), about 1.2 s of CPU in all, which :func:`convert` does while the forked processes compute
    the geometry (a user waits less wherever a core is free of the geometry for a while)."""
    from bimrobot.export import inertia  # noqa: F401
    from bimrobot.export.gazebo import package  # noqa: F401
