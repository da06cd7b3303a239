"""Joints and connection nodes of the smart model (thesis fig. 4.6-4.7), from relations or from contact.

From ``IfcRelConnectsWithRealizingElements``: one joint per connector group, a node per (component,
connector) relation, its points the realizing elements (:func:`joints_from_relations`). From touching
bodies: one joint per connected pair, a node on each side, its points the model's fasteners there or
an assumed count (:func:`direct_joints`). Positions in the model frame, metres.
"""

from __future__ import annotations

import numpy as np

from bimrobot.bim.components import mass_proxy
from bimrobot.bim.model import BuildingModel, Connection, Element
from bimrobot.sco.component import Component, ConnectionNode, Joint

#: Classes whose elements are the fastening points of a joint when they reach into both its components.
FASTENER_CLASSES = ("IfcMechanicalFastener", "IfcFastener")
#: Property names (after the last "/", lower case) that give how many fasteners one element stands for
#: (a bolt group exported as one element).
FASTENER_COUNT_PROPERTIES = ("bolt count", "number of bolts", "numberofbolts", "boltcount", "number of fasteners")


def connector_roles(model: BuildingModel, connections: list[Connection]) -> tuple[set[str], str]:
    """Which elements are connectors, and the rule that decided it.

    The thesis' convention (fig. 4.6): the RelatedElement is the connector. It is used when it is
    consistent, i.e. every connector so found is related to at least one component. Models that chain
    their relations instead (footing -> plate -> column -> clip -> beam) fail that test; then in each
    relation the lighter element (weight, else bounding-box size) is the connector.
    """
    partners: dict[str, set[str]] = {}
    for c in connections:
        partners.setdefault(c.relating_id, set()).add(c.related_id)
        partners.setdefault(c.related_id, set()).add(c.relating_id)
    related = {c.related_id for c in connections}
    if all(any(p not in related for p in partners[k]) for k in related):
        return related, "RelatingElement = component, RelatedElement = connector (thesis fig. 4.6)"
    connectors = set()
    for c in connections:
        a, b = model.elements.get(c.relating_id), model.elements.get(c.related_id)
        if a is None or b is None:
            connectors.add(c.related_id)
            continue
        connectors.add(c.relating_id if mass_proxy(a) < mass_proxy(b) else c.related_id)
    return connectors, "the lighter element of each relation is the connector (relations are chained)"


def duplicates_of_connected(model, components, nodes) -> list[str]:
    """Unconnected components that sit where a connected component of the same class is (within 5 cm).

    Some exports (ifcUnit) contain each member twice: the connected, cut member and an uncut copy.
    """
    connected = {n.component_id for n in nodes.values()}
    boxes = {gid: model.elements[gid].world_bounds for gid in connected}
    duplicates = []
    for gid, component in components.items():
        if gid in connected:
            continue
        box = model.elements[gid].world_bounds
        for other in connected:
            if components[other].ifc_class == component.ifc_class and np.all(np.abs(boxes[other] - box) < 0.05):
                duplicates.append(gid)
                break
    return sorted(duplicates)


def _connector_groups(connectors: set[str], connections) -> dict[str, str]:
    """Connector -> its group: connectors related to each other (connector to connector) form one
    group, named by its smallest GlobalId (networkx's union-find)."""
    from networkx.utils import UnionFind

    groups = UnionFind(connectors)
    for c in connections:
        if c.relating_id in connectors and c.related_id in connectors:
            groups.union(c.relating_id, c.related_id)
    return {k: min(members) for members in groups.to_sets() for k in members}


def _relation_nodes(model, connections, components, connectors: set[str], group_of: dict[str, str],
                    group_realizing: dict[str, set[str]]) -> tuple[dict[str, ConnectionNode], dict[str, list[str]]]:
    """One node per (component, connector) relation (a pair related twice adds its points to one node), and
    connector group -> its node ids; ``group_realizing`` gains each relation's realizing elements."""
    nodes: dict[str, ConnectionNode] = {}
    group_nodes: dict[str, list[str]] = {}
    for c in connections:
        if c.related_id in connectors and c.relating_id in components:
            component_id, connector_id = c.relating_id, c.related_id
        elif c.relating_id in connectors and c.related_id in components:
            component_id, connector_id = c.related_id, c.relating_id
        else:
            continue
        node_id = f"{c.relating_id}:{c.related_id}"
        group = group_of[connector_id]
        if node_id in nodes:  # the same pair related twice: more fastening points on one node
            node = nodes[node_id]
            node.assembly_point_number += max(1, len(c.realizing_ids))
            continue
        component = components[component_id]
        position = _centre([connector_id], model)
        if position is None:
            position = _centre(c.realizing_ids, model)
        nodes[node_id] = ConnectionNode(
            id=node_id,
            name=f"{component.name} / {model.elements[connector_id].name if connector_id in model.elements else connector_id}",
            object_type="ConnectionNode",
            component_id=component_id,
            joint_id=group,
            connector_ids=(connector_id,),
            assembly_point_number=max(1, len(c.realizing_ids)),
            assembly_method=assembly_method(c, model),
            assembly_point_source="model" if c.realizing_ids else "assumed",
            position=position if position is not None else component.target_position.copy(),
        )
        group_nodes.setdefault(group, []).append(node_id)
        group_realizing.setdefault(group, set()).update(c.realizing_ids)
    return nodes, group_nodes


def joints_from_relations(model, connections, components, connectors: set[str]):
    """Joints from IfcRelConnectsWithRealizingElements: one per connector group."""
    group_of = _connector_groups(connectors, connections)

    group_realizing: dict[str, set[str]] = {}
    for c in connections:
        if c.relating_id in connectors and c.related_id in connectors:
            group_realizing.setdefault(group_of[c.related_id], set()).update(c.realizing_ids)
    nodes, group_nodes = _relation_nodes(model, connections, components, connectors, group_of, group_realizing)

    members_of_group: dict[str, list[str]] = {}
    for k in connectors:
        members_of_group.setdefault(group_of[k], []).append(k)
    joints: dict[str, Joint] = {}
    for group, node_ids in group_nodes.items():
        member_ids = tuple(dict.fromkeys(nodes[n].component_id for n in node_ids))
        group_connectors = tuple(sorted(members_of_group.get(group, ())))
        position = _centre(group_connectors, model)
        if position is None:
            position = np.mean([nodes[n].position for n in node_ids], axis=0)
        floor = max(components[m].floor for m in member_ids)
        joints[group] = Joint(
            id=group,
            component_ids=member_ids,
            node_ids=tuple(node_ids),
            connector_ids=group_connectors,
            realizing_ids=tuple(sorted(group_realizing.get(group, ()))),
            position=position,
            floor=floor,
        )
        for n in node_ids:
            nodes[n].level = floor
            nodes[n].joint_id = group
    return joints, nodes


def assembly_method(connection: Connection, model: BuildingModel) -> str:
    """"bolt" or "weld", from the relation's ConnectionType or else its realizing elements."""
    text = (connection.connection_type or "").upper()
    if "WELD" in text:
        return "weld"
    if any(word in text for word in ("BOLT", "SCREW", "RIVET", "PIN")):
        return "bolt"
    classes_and_names = []
    skipped = {s.global_id: s for s in model.skipped}
    for gid in connection.realizing_ids:
        item = model.elements.get(gid) or skipped.get(gid)
        if item is not None:
            classes_and_names.append((item.ifc_class, (item.name or "").lower()))
    for ifc_class, name in classes_and_names:
        if "weld" in name:
            return "weld"
        if "bolt" in name or ifc_class == "IfcMechanicalFastener":
            return "bolt"
    if any(ifc_class == "IfcFastener" for ifc_class, _ in classes_and_names):
        return "weld"  # IfcFastener without a name hint: IFC's class for welds, glue, nails
    return "bolt"


def _centre(ids, model: BuildingModel) -> np.ndarray | None:
    boxes = [model.elements[i].world_bounds for i in ids if i in model.elements]
    if not boxes:
        return None
    return np.mean([box.mean(axis=0) for box in boxes], axis=0)


def _contact_point(a: Component, b: Component, model: BuildingModel) -> np.ndarray:
    box_a, box_b = model.elements[a.id].world_bounds, model.elements[b.id].world_bounds
    low = np.maximum(box_a[0], box_b[0])
    high = np.minimum(box_a[1], box_b[1])
    return (low + high) / 2.0  # centre of the overlap (or of the gap, when within tolerance)


def fasteners_at_joints(model: BuildingModel, work: BuildingModel, connections, components, tolerance_m: float,
                         internal: set[str]) -> dict[frozenset, list[Element]]:
    """The model's fasteners at each inferred joint: {frozenset((a, b)): [fastener elements]}.

    A fastener (:data:`FASTENER_CLASSES`; not a part of a unit, where it is made in the factory) is at
    the joint of two components when its body's world box reaches into both components' boxes (within
    ``tolerance_m`` metres, the contact tolerance): a bolt through a fin plate and a column. When it
    reaches into several joints, it is at the one whose contact centre is nearest to it.
    """
    fasteners = [e for gid, e in model.elements.items() if e.ifc_class in FASTENER_CLASSES and gid not in internal]
    pairs = list(dict.fromkeys(
        frozenset((c.relating_id, c.related_id)) for c in connections
        if c.inferred and c.relating_id in components and c.related_id in components and c.relating_id != c.related_id
    ))
    if not fasteners or not pairs:
        return {}
    ordered = [tuple(sorted(pair)) for pair in pairs]
    box_of = {gid: work.elements[gid].world_bounds for pair in ordered for gid in pair}
    low_a = np.array([box_of[a][0] for a, _ in ordered]) - tolerance_m
    high_a = np.array([box_of[a][1] for a, _ in ordered]) + tolerance_m
    low_b = np.array([box_of[b][0] for _, b in ordered]) - tolerance_m
    high_b = np.array([box_of[b][1] for _, b in ordered]) + tolerance_m
    centres = (np.maximum(low_a, low_b) + np.minimum(high_a, high_b)) / 2.0
    found: dict[frozenset, list[Element]] = {}
    for fastener in fasteners:
        low, high = fastener.world_bounds
        touches = (
            np.all(low <= high_a, axis=1) & np.all(high >= low_a, axis=1)
            & np.all(low <= high_b, axis=1) & np.all(high >= low_b, axis=1)
        )
        if not touches.any():
            continue
        candidates = np.flatnonzero(touches)
        distance = np.linalg.norm(centres[candidates] - (low + high) / 2.0, axis=1)
        found.setdefault(pairs[int(candidates[int(np.argmin(distance))])], []).append(fastener)
    return found


def fastener_count(element: Element) -> int:
    """How many fastening points one fastener element stands for: a count property of a bolt group
    (:data:`FASTENER_COUNT_PROPERTIES`, a whole number 1-1000), else 1."""
    for key, value in (element.properties or {}).items():
        if str(key).rsplit("/", 1)[-1].lower() in FASTENER_COUNT_PROPERTIES:
            try:
                count = int(float(value))
            except (TypeError, ValueError):
                continue
            if 1 <= count <= 1000 and count == float(value):
                return count
    return 1


def fastener_method(fasteners: list[Element]) -> str:
    """"bolt" or "weld" for the fasteners of one joint: a name saying weld or bolt decides, else
    IfcMechanicalFastener is a bolt and IfcFastener (IFC's class for welds, glue, nails) a weld."""
    for fastener in fasteners:
        name = (fastener.name or "").lower()
        if "weld" in name:
            return "weld"
        if "bolt" in name or fastener.ifc_class == "IfcMechanicalFastener":
            return "bolt"
    return "weld"


def split_points(points: int) -> tuple[int, int]:
    """A joint's points over its two nodes: (the first node's, the second's), the first taking the odd one."""
    return points - points // 2, points // 2


def points_by_source(joints: dict, nodes: dict, per_joint: int) -> dict:
    """Joints and fastening points by where their count came from: {"model": ..., "assumed": ...}."""
    result = {"model": {"joints": 0, "points": 0}, "assumed": {"joints": 0, "points": 0, "per_joint": per_joint}}
    for joint in joints.values():
        joint_nodes = [nodes[n] for n in joint.node_ids if n in nodes]
        for source in ("model", "assumed"):
            points = sum(n.assembly_point_number for n in joint_nodes if n.assembly_point_source == source)
            if any(n.assembly_point_source == source for n in joint_nodes):
                result[source]["joints"] += 1
                result[source]["points"] += points
    return result


def _pair_points(c: Connection, fasteners: dict, source_model, points: int, method: str):
    """A connected pair's fastening points: (total, per node (a, b), method, "model" | "assumed", realizing ids)."""
    a_id, b_id = c.relating_id, c.related_id
    realizing = tuple(c.realizing_ids)
    if c.inferred:
        found = fasteners.get(frozenset((a_id, b_id)), [])
        if found:
            count, how, source = sum(fastener_count(f) for f in found), fastener_method(found), "model"
            realizing = tuple(f.global_id for f in found)
        else:
            count, how, source = points, method, "assumed"
        return count, split_points(count), how, source, realizing
    count, how = max(1, len(c.realizing_ids)), assembly_method(c, source_model)
    return count, (count, count), how, "model" if c.realizing_ids else "assumed", realizing


def direct_joints(model, source_model, connections, components, points: int, method: str, fasteners=None):
    """One joint per connected pair of components, with a node on each side.

    An inferred pair takes its points from the model's fasteners there (``fasteners``: see
    :func:`fasteners_at_joints`, method by :func:`fastener_method`), else ``points`` per joint made by
    ``method``, assumed (split over the two nodes by :func:`split_points`); a relation from the file
    (between two assemblies) keeps its realizing elements' count and method. Several relations between
    the same pair add up on one joint.
    """
    fasteners = fasteners or {}
    nodes: dict[str, ConnectionNode] = {}
    joints: dict[str, Joint] = {}
    for c in connections:
        a_id, b_id = c.relating_id, c.related_id
        if a_id not in components or b_id not in components or a_id == b_id:
            continue
        count, counts, how, source, realizing = _pair_points(c, fasteners, source_model, points, method)
        joint_id = f"{a_id}:{b_id}" if f"{b_id}:{a_id}" not in joints else f"{b_id}:{a_id}"
        if joint_id in joints:
            if not c.inferred:
                for node_id in joints[joint_id].node_ids:
                    nodes[node_id].assembly_point_number += count
            continue
        a, b = components[a_id], components[b_id]
        position = _contact_point(a, b, model)
        floor = max(a.floor, b.floor)
        pair = (f"{a_id}:{b_id}", f"{b_id}:{a_id}")
        for node_id, owner, other, node_points in ((pair[0], a, b, counts[0]), (pair[1], b, a, counts[1])):
            nodes[node_id] = ConnectionNode(
                id=node_id,
                name=f"{owner.name} / {other.name}",
                object_type="ConnectionNode",
                component_id=owner.id,
                joint_id=joint_id,
                assembly_point_number=node_points,
                assembly_method=how,
                assembly_point_source=source,
                level=floor,
                position=position.copy(),
            )
        joints[joint_id] = Joint(
            id=joint_id,
            component_ids=(a_id, b_id),
            node_ids=pair,
            connector_ids=(),
            realizing_ids=realizing,
            position=position,
            floor=floor,
            inferred=c.inferred,
        )
    return joints, nodes
