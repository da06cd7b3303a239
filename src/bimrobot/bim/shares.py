"""How the geometry pass is shared between forked processes: each product's cost guessed from the file's
entities before any geometry is computed, and shares of about equal guessed cost.

The geometry kernel spends its time on Boolean operations: an opening cut from its host
(``IfcRelVoidsElement``) and a body that is itself a Boolean result (``IfcBooleanResult``,
``IfcBooleanClippingResult``: Tekla's cut beams). A product without either is an extrusion or a
faceted shell, a few tenths of a millisecond. Measured with one thread on the shared models: MULTICOM-
Prefab's 20 clipped beams take 2.2 of its 3.5 s (0.15-0.29 s each, the 280 other products 0.3-7 ms);
AC20's two walls cut by a large opening 1.5 s each of 4.1 s; ifcUnit's columns with 12 openings 0.25 s.
The guess is the number of entities under each such operand (faces and points of the cut, mostly):
a product's cost is 1 + the entities of its openings' representations + the entities under every
Boolean result its body holds (through mapped items). The sizes rank the costly products first, not
their exact seconds: greedy longest-first assignment (:func:`bimrobot.core.pool.balanced_chunks`)
then gives each process about the same work. Every other product, as before, put all of Prefab's
clipped beams into one process (they sit at every other position in the file): 2.30 against 1.18 s.
"""

from __future__ import annotations

from collections import Counter

import ifcopenshell

from bimrobot.core.pool import balanced_chunks

_UP_TO_PRODUCT = ("IfcShapeRepresentation", "IfcProductDefinitionShape", "IfcRepresentationMap", "IfcMappedItem")
"""The entities between a body's item and the products that use it (mapped items shared by types)."""


def geometry_costs(ifc: ifcopenshell.file, products: list) -> list[float]:
    """A guessed geometry cost of each of ``products`` (no unit: only their ratios matter; see the
    module docstring). Reads only the file's openings and Boolean results, a few milliseconds."""
    wanted = {product.id() for product in products}
    extra: Counter = Counter()
    for relation in ifc.by_type("IfcRelVoidsElement"):
        host, opening = relation.RelatingBuildingElement, relation.RelatedOpeningElement
        if host is not None and host.id() in wanted and opening is not None and opening.Representation is not None:
            extra[host.id()] += len(ifc.traverse(opening.Representation))
    for boolean in ifc.by_type("IfcBooleanResult"):  # IfcBooleanClippingResult too
        representations = [e for e in ifc.get_inverse(boolean) if e.is_a("IfcShapeRepresentation")]
        if representations:  # a body's own item, not an operand of another Boolean result
            size = len(ifc.traverse(boolean))
            for product_id in _products_using(ifc, representations) & wanted:
                extra[product_id] += size
    return [1.0 + extra[product.id()] for product in products]


def _products_using(ifc: ifcopenshell.file, representations: list) -> set[int]:
    """Step ids of the products whose representation holds one of ``representations``, directly or
    through a mapped item."""
    found: set[int] = set()
    seen: set[int] = set()
    stack = list(representations)
    while stack:
        entity = stack.pop()
        if entity.id() in seen:
            continue
        seen.add(entity.id())
        if entity.is_a("IfcProduct"):
            found.add(entity.id())
            continue
        stack.extend(e for e in ifc.get_inverse(entity) if e.is_a("IfcProduct") or e.is_a() in _UP_TO_PRODUCT)
    return found


def balanced_shares(products: list, count: int, costs: list[float]) -> list[list]:
    """``products`` in ``count`` shares of about equal total ``costs`` (costliest first, each to the
    share with the least so far), each share in the products' own order (the file's)."""
    chunks = balanced_chunks([[index] for index in range(len(products))], costs, count)
    return [[products[index] for index in sorted(chunk)] for chunk in chunks]
