"""IFC reading: the only part of bimrobot that imports ifcopenshell.

``load_model(path) -> BuildingModel`` (see :mod:`bimrobot.bim.model` for the data it returns).
"""

from bimrobot.bim.model import BuildingModel, Connection, Element, SkippedProduct, Storey, WeightSource

__all__ = ["BuildingModel", "Connection", "Element", "SkippedProduct", "Storey", "WeightSource"]
