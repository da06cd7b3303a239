"""Assembly units: each outermost ``IfcElementAssembly`` (or other aggregate) as ONE component.

A unit's parts travel and are placed together: its mass is the sum of its parts' (kg), its body the union
of theirs in its heaviest part's frame (metres), its id the whole's GlobalId. Connections between parts of
one unit are made in the factory and dropped; the rest are mapped onto the units.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from bimrobot.bim.components import main_part
from bimrobot.bim.model import BuildingModel, Connection, Element, WeightSource
from bimrobot.sco.prebuilt import ASSEMBLY_CLASS


def assembly_units(model: BuildingModel) -> tuple[BuildingModel, dict[str, str], dict[str, tuple[str, ...]], list[str]]:
    """The model with each outermost assembly replaced by one element: its unit.

    A unit keeps the assembly's GlobalId, name and storey (else its heaviest part's), takes the
    placement and local frame of its heaviest part and its class (the whole's class when the whole is
    not an IfcElementAssembly: an IfcSlab floor plate of proxies is an IfcSlab), and as body the union of its parts' bodies (in that
    frame, so its size is measured along the main part). Its weight is the sum of its parts' (kg), or
    None when no part has one. Returns (the unit model, element id -> unit id for every part, unit id ->
    part ids, ids of units with a part whose weight is unknown).
    """
    elements: dict[str, Element] = {}
    unit_of: dict[str, str] = {}
    parts_of: dict[str, tuple[str, ...]] = {}
    partial: list[str] = []
    for assembly in model.assemblies.values():
        parts = [model.elements[p] for p in assembly.part_ids if p in model.elements]
        if not parts:
            continue
        main = main_part(parts)
        whole_class = getattr(assembly, "ifc_class", ASSEMBLY_CLASS)
        to_main = np.linalg.inv(main.placement)
        vertices, faces, offset = [], [], 0
        for part in parts:
            homogeneous = np.c_[part.world_vertices, np.ones(len(part.vertices))]
            vertices.append((homogeneous @ to_main.T)[:, :3])
            faces.append(part.faces + offset)
            offset += len(part.vertices)
        weights = [p.weight_kg for p in parts if p.weight_kg is not None]
        if len(weights) < len(parts):
            partial.append(assembly.global_id)
        sources = {p.weight_source for p in parts}
        elements[assembly.global_id] = Element(
            global_id=assembly.global_id,
            ifc_class=main.ifc_class if whole_class == ASSEMBLY_CLASS else whole_class,
            name=assembly.name or main.name,
            storey_id=assembly.storey_id or main.storey_id,
            placement=main.placement.copy(),
            vertices=np.concatenate(vertices),
            faces=np.concatenate(faces),
            material=main.material,
            weight_kg=float(sum(weights)) if weights else None,
            weight_source=sources.pop() if len(sources) == 1 else (WeightSource.UNKNOWN if not weights else main.weight_source),
        )
        parts_of[assembly.global_id] = tuple(p.global_id for p in parts)
        for part in parts:
            unit_of[part.global_id] = assembly.global_id
    # Keep file order: a unit takes the place of its first part.
    ordered: dict[str, Element] = {}
    for gid, element in model.elements.items():
        unit = unit_of.get(gid)
        if unit is None:
            ordered[gid] = element
        elif unit not in ordered:
            ordered[unit] = elements[unit]
    # the same model with units in place of their parts; connections are mapped to units by the caller
    units = dataclasses.replace(model, elements=ordered, connections=[], assemblies={})
    return units, unit_of, parts_of, partial


def map_connections(connections: list[Connection], unit_of: dict[str, str]) -> list[Connection]:
    """Connections between units (relations between parts of one unit are dropped: they are internal)."""
    mapped = []
    for c in connections:
        a, b = unit_of.get(c.relating_id, c.relating_id), unit_of.get(c.related_id, c.related_id)
        if a != b:
            mapped.append(Connection(a, b, c.realizing_ids, c.connection_type, c.global_id, c.inferred))
    return mapped


def orient_inferred(connections: list[Connection], model: BuildingModel) -> list[Connection]:
    """One inferred connection per touching pair of units, the lower-reaching one relating."""
    seen: set[frozenset] = set()
    oriented = []
    for c in connections:
        pair = frozenset((c.relating_id, c.related_id))
        if pair in seen:
            continue
        seen.add(pair)
        a, b = model.elements[c.relating_id], model.elements[c.related_id]
        if b.world_bounds[0, 2] < a.world_bounds[0, 2]:
            a, b = b, a
        oriented.append(Connection(a.global_id, b.global_id, inferred=True))
    return oriented
