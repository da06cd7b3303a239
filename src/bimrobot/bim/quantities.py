"""Weights: where an element's mass in kg comes from, best source first.

1. An ``IfcQuantityWeight`` in one of the element's quantity sets (``NetWeight`` preferred, then
   ``GrossWeight``, then any other weight quantity), scaled by the file's mass unit.
2. A weight property in a property set, by name (see :data:`WEIGHT_PROPERTY_NAMES`), e.g. Revit's
   ``Structural/Exact Weight`` (an ``IfcMassMeasure``). Per-length values such as Revit's
   ``Nominal Weight`` (kg/m) are deliberately not on the list.
3. Mesh volume (m3) x a density (kg/m3) looked up from the material name in :data:`DENSITY_TABLE`.
4. Otherwise unknown (``None``).

Densities are typical engineering values (EN 1991-1-1 Annex A, rounded): the first table row whose
keyword occurs in the lower-cased material name wins, so specific keywords come before general ones.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from bimrobot.bim.model import WeightSource

#: (keyword in the lower-cased material name, density in kg/m3), first match wins.
DENSITY_TABLE: tuple[tuple[str, float], ...] = (
    ("stainless", 7900.0),
    ("aluminium", 2700.0),
    ("aluminum", 2700.0),
    ("copper", 8900.0),
    ("cast iron", 7200.0),
    ("reinforced concrete", 2500.0),
    ("lightweight concrete", 1800.0),
    ("concrete", 2400.0),
    ("beton", 2400.0),
    ("混凝土", 2400.0),  # concrete
    ("steel", 7850.0),
    ("stahl", 7850.0),
    ("metal", 7850.0),
    ("钢", 7850.0),  # steel
    ("s235", 7850.0),
    ("s275", 7850.0),
    ("s355", 7850.0),
    ("q235", 7850.0),
    ("q345", 7850.0),
    ("a992", 7850.0),
    ("glulam", 470.0),
    ("timber", 500.0),
    ("wood", 500.0),
    ("holz", 500.0),
    ("plywood", 600.0),
    ("glass", 2500.0),
    ("brick", 1800.0),
    ("masonry", 1900.0),
    ("ziegel", 1800.0),
    ("stone", 2600.0),
    ("gypsum", 1000.0),
    ("plaster", 1200.0),
    ("mineral wool", 100.0),
    ("insulation", 100.0),
)

#: Property names (case-insensitive) that hold an element's total mass, best first.
WEIGHT_PROPERTY_NAMES: tuple[str, ...] = ("exact weight", "netweight", "net weight", "weight", "mass", "grossweight", "gross weight")

#: Quantity names, best first, among an element's IfcQuantityWeight entries.
WEIGHT_QUANTITY_NAMES: tuple[str, ...] = ("netweight", "grossweight")


def density_of(material: str | None) -> float | None:
    """Density in kg/m3 for a material name, or None when the table has no keyword for it."""
    if not material:
        return None
    name = material.lower()
    for keyword, density in DENSITY_TABLE:
        if keyword in name:
            return density
    return None


def mesh_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Enclosed volume (m3) of a closed triangle mesh by the divergence theorem (absolute value)."""
    if len(faces) == 0:
        return 0.0
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    return float(abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0)


def pick_weight_quantity(quantities: dict[str, float]) -> float | None:
    """The best of an element's weight quantities (name -> kg), or None when there is none."""
    if not quantities:
        return None
    by_lower = {name.lower(): value for name, value in quantities.items()}
    for name in WEIGHT_QUANTITY_NAMES:
        if name in by_lower:
            return by_lower[name]
    return next(iter(quantities.values()))


def pick_weight_property(properties: dict[str, float]) -> tuple[str, float] | None:
    """The best weight property (``"Pset/Name"`` -> kg) by :data:`WEIGHT_PROPERTY_NAMES`, or None."""
    for wanted in WEIGHT_PROPERTY_NAMES:
        for key, value in properties.items():
            if key.rsplit("/", 1)[-1].lower() == wanted and value > 0:
                return key, value
    return None


def resolve_weight(
    weight_quantities: dict[str, float],
    weight_properties: dict[str, float],
    material: str | None,
    volume_m3: float | Callable[[], float],
) -> tuple[float | None, WeightSource]:
    """Choose an element's mass (kg) and its source, following the order in the module docstring.

    ``volume_m3`` may be a function, called only when the volume is needed (step 3).
    """
    quantity = pick_weight_quantity({k: v for k, v in weight_quantities.items() if v > 0})
    if quantity is not None:
        return quantity, WeightSource.QUANTITY
    prop = pick_weight_property(weight_properties)
    if prop is not None:
        return prop[1], WeightSource.PROPERTY
    density = density_of(material)
    if density is not None:
        volume = volume_m3() if callable(volume_m3) else volume_m3
        if volume > 0:
            return volume * density, WeightSource.DENSITY
    return None, WeightSource.UNKNOWN
