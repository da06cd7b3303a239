"""IFC reading: the only part of bimrobot that imports ifcopenshell.

``load_model(path) -> BuildingModel`` (see :mod:`bimrobot.bim.model` for the data it returns).
``bimrobot.bim.examples`` writes the thesis' example buildings; ``bimrobot.bim.split`` writes one IFC
file per element; ``bimrobot.bim.connections.infer_connections`` finds joints from touching geometry.
"""

from bimrobot.bim.model import BuildingModel, Connection, Element, SkippedProduct, Storey, WeightSource


def load_model(path, include=None, exclude=None, progress=False, threads=None) -> BuildingModel:
    """Read an IFC file into a BuildingModel (see :func:`bimrobot.bim.reader.load_model`)."""
    from bimrobot.bim.reader import load_model as _load_model

    return _load_model(path, include=include, exclude=exclude, progress=progress, threads=threads)


__all__ = ["BuildingModel", "Connection", "Element", "SkippedProduct", "Storey", "WeightSource", "load_model"]
