"""IFC reading: the only part of bimrobot that imports ifcopenshell.

``load_model(path) -> BuildingModel`` (see :mod:`bimrobot.bim.model` for the data it returns) reads
``.ifc`` and ``.ifczip`` files; ``include`` / ``exclude`` are IfcOpenShell selectors
(:mod:`bimrobot.bim.selection`). Elements are keyed by GlobalId; a GlobalId that the file gives to
several products (which IFC forbids) is reported and the later products are keyed
``<GlobalId>#<step id>``, so no element is lost. ``bimrobot.bim.examples`` writes the thesis' example
buildings; ``bimrobot.bim.split`` writes one IFC file per assembly or element;
``bimrobot.bim.connections.infer_connections`` finds joints from touching geometry;
``bimrobot.bim.components`` says what robots build (an element, or an ``IfcElementAssembly`` lifted as one
unit) and its weight, position and section.
"""

from __future__ import annotations

from bimrobot import lazy_names

_LAZY = {name: "bimrobot.bim.model" for name in
         ("BuildingModel", "Connection", "Element", "SkippedProduct", "Storey", "WeightSource")}
"""Public name -> the module that defines it, imported when the name is first used (numpy comes with it)."""


def load_model(path, include=None, exclude=None, progress=False, threads=None, properties=True,
               processes=None, prebuilt=None, unknown_weight=None, ifc=None) -> "BuildingModel":
    """Read an IFC file into a BuildingModel (see :func:`bimrobot.bim.reader.load_model`)."""
    from bimrobot.bim.reader import load_model as _load_model

    return _load_model(path, include=include, exclude=exclude, progress=progress, threads=threads,
                       properties=properties, processes=processes, prebuilt=prebuilt, unknown_weight=unknown_weight, ifc=ifc)


__all__ = ["BuildingModel", "Connection", "Element", "SkippedProduct", "Storey", "WeightSource", "load_model"]


# names load on first use (PEP 562), so that importing a light submodule (``bimrobot.bim.selection``) does
# not load numpy
__getattr__, __dir__ = lazy_names(__name__, _LAZY)
