"""What the reader takes from the IFC entities besides geometry: each element's properties, quantities
and weight (kg), its storey, the model's storeys (elevations in metres), units, connection relations and
the aggregates lifted as one unit; and why a product without a solid body was skipped.
"""

from __future__ import annotations

import logging

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.placement
import ifcopenshell.util.unit

from bimrobot.bim.ifc_file import product_key
from bimrobot.bim.model import Assembly, Connection, Element, SkippedProduct, Storey
from bimrobot.bim.quantities import WEIGHT_PROPERTY_NAMES, resolve_weight

log = logging.getLogger(__name__)

_CURVE_ONLY_TYPES = {
    "Curve", "Curve2D", "Curve3D", "GeometricCurveSet", "GeometricSet", "Point", "PointCloud", "Annotation2D",
}  # fmt: skip
_WEIGHT_NAMES = frozenset(WEIGHT_PROPERTY_NAMES)


def read_element(product, placement, vertices, faces, volume, mass_scale, caches, every_property: bool = True) -> Element:
    storey_cache, type_cache, materials = caches
    material = materials.of(product)
    properties, quantities, weight_properties = _property_values(product, mass_scale, type_cache, every_property)
    weight = resolve_weight(quantities, weight_properties, material, volume)
    return Element(
        global_id=product.GlobalId,
        ifc_class=product.is_a(),
        name=product.Name or "",
        storey_id=_storey_of(product, storey_cache),
        placement=placement,
        vertices=vertices,
        faces=faces,
        material=", ".join(material.names) or None,
        weight_kg=weight.kg,
        weight_source=weight.source,
        properties=properties,
        density_kg_m3=material.body_density_kg_m3,
        weight_basis=weight.basis,
    )


def _property_values(
    product, mass_scale: float, type_cache: dict, every_property: bool = True
) -> tuple[dict, dict[str, float], dict[str, float]]:
    """One pass over the element's (and its type's) property and quantity sets.

    Returns ``({"Pset/Name": value}`` in file units, occurrence values overriding type values``},
    {IfcQuantityWeight name: kg}, {"Pset/Name" of an IfcMassMeasure property: kg})``. Attributes are
    read by position (faster than by name in IfcOpenShell): this runs once per element. With
    ``every_property`` False the first dict stays empty and only the weights are read (the same two
    weight dicts, in the same order).
    """
    flat: dict = {}
    quantities: dict[str, float] = {}
    masses: dict[str, float] = {}
    read = _read_definition if every_property else _read_weights
    for relation in getattr(product, "IsDefinedBy", ()) or ():
        if relation.is_a("IfcRelDefinesByProperties"):
            read(relation.RelatingPropertyDefinition, mass_scale, flat, quantities, masses)
    product_type = ifcopenshell.util.element.get_type(product)
    if product_type is not None:
        key = product_type.id()
        if key not in type_cache:
            type_values: tuple[dict, dict, dict] = ({}, {}, {})
            for definition in product_type.HasPropertySets or ():
                read(definition, mass_scale, *type_values)
            type_cache[key] = type_values
        for mine, inherited in zip((flat, quantities, masses), type_cache[key]):
            for name, value in inherited.items():
                mine.setdefault(name, value)
    return flat, quantities, masses


def _read_weights(definition, mass_scale: float, flat: dict, quantities: dict, masses: dict) -> None:
    """What :func:`_read_definition` reads into ``quantities`` and ``masses``, without reading any other
    value: weight quantities, and single values whose name is a weight property name. ``flat`` is unused."""
    if definition is None or isinstance(definition, tuple):
        return
    if definition.is_a("IfcElementQuantity"):
        for quantity in definition.Quantities or ():
            if quantity.is_a("IfcQuantityWeight"):
                name, value = quantity[0], quantity[3]
                if value is not None:
                    scale = _unit_scale_to_kg(quantity[2]) if quantity[2] is not None else mass_scale
                    quantities.setdefault(name, float(value) * scale)
    elif definition.is_a("IfcPropertySet"):
        set_name = definition.Name
        for prop in definition.HasProperties or ():
            # as pick_weight_property compares: the part of "Pset/Name" after the last "/" (the name
            # first: most properties are not weights, and reading it is cheaper than the class)
            if str(prop[0]).rsplit("/", 1)[-1].lower() not in _WEIGHT_NAMES or prop.is_a() != "IfcPropertySingleValue":
                continue
            nominal = prop[2]
            if nominal is not None and nominal.is_a("IfcMassMeasure"):
                masses.setdefault(f"{set_name}/{prop[0]}", float(nominal.wrappedValue) * mass_scale)


def _read_definition(definition, mass_scale: float, flat: dict, quantities: dict, masses: dict) -> None:
    if definition is None or isinstance(definition, tuple):  # IFC4 property set definition sets: rare
        return
    set_name = definition.Name
    if definition.is_a("IfcElementQuantity"):
        for quantity in definition.Quantities or ():
            if not quantity.is_a("IfcPhysicalSimpleQuantity"):
                continue
            name, value = quantity[0], quantity[3]
            flat.setdefault(f"{set_name}/{name}", value)
            if value is not None and quantity.is_a("IfcQuantityWeight"):
                scale = _unit_scale_to_kg(quantity[2]) if quantity[2] is not None else mass_scale
                quantities.setdefault(name, float(value) * scale)
    elif definition.is_a("IfcPropertySet"):
        for prop in definition.HasProperties or ():
            kind = prop.is_a()
            key = f"{set_name}/{prop[0]}"
            if kind == "IfcPropertySingleValue":
                nominal = prop[2]
                flat.setdefault(key, nominal.wrappedValue if nominal is not None else None)
                if nominal is not None and nominal.is_a("IfcMassMeasure"):
                    masses.setdefault(key, float(nominal.wrappedValue) * mass_scale)
            elif kind in ("IfcPropertyEnumeratedValue", "IfcPropertyListValue"):
                flat.setdefault(key, tuple(v.wrappedValue for v in prop[2] or ()))
            elif kind == "IfcPropertyBoundedValue":
                bounds = (prop[3], prop[2])  # (lower, upper)
                flat.setdefault(key, tuple(b.wrappedValue if b is not None else None for b in bounds))
    else:  # pre-defined property sets (e.g. IfcDoorLiningProperties): their own attributes are the values
        for index in range(4, len(definition)):
            value = definition[index]
            if value is not None and not isinstance(value, (ifcopenshell.entity_instance, tuple)):
                flat.setdefault(f"{set_name}/{definition.attribute_name(index)}", value)


def _storey_of(product, cache: dict[int, str | None]) -> str | None:
    """GlobalId of the storey that contains the product (directly, or through its container/aggregate)."""
    key = product.id()
    if key in cache:
        return cache[key]
    result = None
    node = product
    for _ in range(32):  # spatial trees are shallow; the bound guards against cyclic files
        if node.is_a("IfcBuildingStorey"):
            result = node.GlobalId
            break
        parent = ifcopenshell.util.element.get_container(node) if node.is_a("IfcElement") else None
        parent = parent or ifcopenshell.util.element.get_aggregate(node)
        if parent is None:
            break
        node = parent
    cache[key] = result
    return result


def skipped_product(product, empty_body: bool) -> SkippedProduct:
    if empty_body:
        reason = "its body triangulates to no faces"
    elif product.Representation is None:
        parts = [p for rel in getattr(product, "IsDecomposedBy", ()) or () for p in rel.RelatedObjects]
        reason = f"an assembly without its own body ({len(parts)} parts)" if parts else "no representation"
    else:
        types = sorted({r.RepresentationType or "unknown" for r in product.Representation.Representations})
        if set(types) <= _CURVE_ONLY_TYPES:
            reason = f"curve-only geometry ({', '.join(types)}), no solid body"
        else:
            reason = f"no solid body could be built from its representation ({', '.join(types)})"
    return SkippedProduct(product.GlobalId, product.is_a(), product.Name or "", reason)


def read_connections(ifc: ifcopenshell.file, elements: dict[str, Element], keys: dict[int, str]) -> list[Connection]:
    """Every IfcRelConnectsWithRealizingElements whose relating and related elements were loaded.

    Realizing ids are kept even when those products are not elements (e.g. curve-only welds).
    Elements are named by their key (:func:`product_key`: the GlobalId, made distinct for duplicates).
    """
    connections = []
    for relation in ifc.by_type("IfcRelConnectsWithRealizingElements"):
        relating, related = relation.RelatingElement, relation.RelatedElement
        if relating is None or related is None:
            continue
        relating_id, related_id = product_key(relating, keys), product_key(related, keys)
        if relating_id not in elements or related_id not in elements:
            log.debug("connection %s involves an element that was not loaded", relation.GlobalId)
            continue
        connections.append(
            Connection(
                relating_id=relating_id,
                related_id=related_id,
                realizing_ids=tuple(product_key(r, keys) for r in relation.RealizingElements or ()),
                connection_type=relation.ConnectionType or "",
                global_id=relation.GlobalId,
            )
        )
    return connections


def read_assemblies(
    ifc: ifcopenshell.file, elements: dict[str, Element], storey_cache: dict, keys: dict[int, str]
) -> dict[str, Assembly]:
    """Outermost aggregates lifted as one unit (:func:`is_unit_whole`) with at least one loaded part
    (parts of nested aggregates included, and the whole itself when it has a body of its own)."""
    order = {gid: index for index, gid in enumerate(elements)}
    assemblies = {}
    wholes = {rel.RelatingObject for rel in ifc.by_type("IfcRelAggregates") if is_unit_whole(rel.RelatingObject)}
    for whole in sorted(wholes, key=lambda w: w.id()):
        if outermost_unit(whole).id() != whole.id():
            continue  # a sub-assembly: its parts belong to the outer unit
        below = [whole, *ifcopenshell.util.element.get_decomposition(whole, is_recursive=True)]
        parts = sorted({key for p in below if (key := product_key(p, keys)) in order}, key=order.__getitem__)
        if parts:
            storey = _storey_of(whole, storey_cache)
            key = product_key(whole, keys)
            assemblies[key] = Assembly(key, whole.Name or "", storey, tuple(parts), whole.is_a())
    return assemblies


#: Aggregates whose parts are installed one by one on site (a roof of rafters and slabs, a curtain wall
#: of mullions and panels, a stair or ramp of flights and landings): never one lifted unit.
BUILT_IN_PLACE_WHOLES = ("IfcRoof", "IfcCurtainWall", "IfcStair", "IfcRamp")


def is_unit_whole(entity) -> bool:
    """Whether ``entity`` is an aggregate lifted and placed as one unit: an IfcElement (not spatial, not
    a feature) that aggregates parts and is not one of :data:`BUILT_IN_PLACE_WHOLES`. IfcElementAssembly
    always is; so are Tekla's precast floor plates (an IfcSlab of proxies) and a window of members."""
    if entity is None or not entity.is_a("IfcElement") or entity.is_a("IfcFeatureElement"):
        return False
    if entity.is_a("IfcElementAssembly"):
        return True
    return not any(entity.is_a(name) for name in BUILT_IN_PLACE_WHOLES)


def outermost_unit(product):
    """The outermost aggregate lifted as one unit (:func:`is_unit_whole`) that holds ``product`` (itself
    when it is one), or None: the climb stops at a whole built in place (a roof) or a spatial element."""
    found = product if is_unit_whole(product) and getattr(product, "IsDecomposedBy", None) else None
    node = product
    for _ in range(32):  # aggregation trees are shallow; the bound guards against cyclic files
        parent = ifcopenshell.util.element.get_aggregate(node)
        if parent is None or not is_unit_whole(parent):
            break
        found = node = parent
    return found


def outermost_assembly(product):
    """The outermost IfcElementAssembly that holds ``product`` (itself when it is one), or None."""
    found = product if product.is_a("IfcElementAssembly") else None
    node = product
    for _ in range(32):  # aggregation trees are shallow; the bound guards against cyclic files
        parent = ifcopenshell.util.element.get_aggregate(node)
        if parent is None or not parent.is_a("IfcElementAssembly"):
            break
        found = node = parent
    return found


def read_storeys(ifc: ifcopenshell.file, length_scale: float) -> list[Storey]:
    """Storeys sorted by elevation; the elevation is the world z of the storey's placement (metres)."""
    storeys = []
    for storey in ifc.by_type("IfcBuildingStorey"):
        if storey.ObjectPlacement is not None:
            matrix = ifcopenshell.util.placement.get_local_placement(storey.ObjectPlacement)
            elevation = float(matrix[2, 3]) * length_scale
        else:
            elevation = float(storey.Elevation or 0.0) * length_scale
        storeys.append(Storey(storey.GlobalId, storey.Name or "", round(elevation, 9)))
    return sorted(storeys, key=lambda s: s.elevation)


def length_unit_name(ifc: ifcopenshell.file) -> str:
    """The project's length unit as IFC names it (``MILLIMETRE``, ``INCH``); METRE when undeclared."""
    unit = ifcopenshell.util.unit.get_project_unit(ifc, "LENGTHUNIT")
    return ifcopenshell.util.unit.get_full_unit_name(unit) if unit is not None else "METRE"


def _unit_scale_to_kg(unit) -> float:
    """Kilograms in one ``unit`` of mass: an IfcSIUnit (GRAM with its prefix) or an
    IfcConversionBasedUnit (a pound, a tonne: its chain of factors), scaled by ifcopenshell.util.unit,
    whose SI mass unit is the gram; a unit of neither kind (context dependent) is taken as kilograms."""
    if not (unit.is_a("IfcSIUnit") or unit.is_a("IfcConversionBasedUnit")):
        return 1.0
    grams = ifcopenshell.util.unit.get_named_unit_scale(unit)
    return ifcopenshell.util.unit.convert(grams, None, "GRAM", "KILO", "GRAM")


def mass_unit(ifc: ifcopenshell.file) -> tuple[float, str]:
    """(kilograms per unit, unit name) of the project's mass unit; kilograms when the file declares none."""
    unit = ifcopenshell.util.unit.get_project_unit(ifc, "MASSUNIT")
    if unit is None:
        return 1.0, "KILOGRAM (not declared)"
    return _unit_scale_to_kg(unit), ifcopenshell.util.unit.get_full_unit_name(unit)


def name_of_first(ifc: ifcopenshell.file, ifc_class: str) -> str:
    found = ifc.by_type(ifc_class)
    return (found[0].Name or "") if found else ""
