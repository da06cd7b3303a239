"""From a BuildingModel to smart construction objects (thesis section 4.4.2, fig. 4.6-4.7).

Roles come from the relations, not from IFC classes: in an ``IfcRelConnectsWithRealizingElements`` the
RelatingElement is a component (column, beam, footing), the RelatedElement a connector (plate, cleat,
clip angle) and the RealizingElements the fasteners (bolts, welds) (thesis fig. 4.6). ifcUnit's cleats
are exported as IfcColumn but are connectors because they are related elements. Models that chain their
relations (footing -> plate -> column -> clip -> beam) break that convention; there the lighter element of
each relation is the connector (see :func:`connector_roles`). Connectors joined to each other by a
relation (ifcUnit bolts cleat #1 to cleat #2) form one connector group; the components related to one
group form a joint. Each (component, connector) relation becomes a ConnectionNode with id
``"<relating GlobalId>:<related GlobalId>"``, ``assembly_point_number`` = number of realizing elements and
the assembly method from the ConnectionType or the realizing elements' class/name (bolt, weld).

When a model has no such relations (most real exports) the connections inferred from touching bodies
(``Connection.inferred``) are used instead: each touching pair is a joint with a node on each side, and
:attr:`SmartModel.inferred` says so. An inferred joint's fastening points come from the model where it
has them: the IfcMechanicalFastener / IfcFastener elements whose bodies reach into both components (one
point each, or the count a bolt group's property gives). Otherwise the joint is given
``assembly_points_per_joint`` points (default :data:`ASSUMED_POINTS_PER_JOINT`), split over its two
nodes and marked *assumed*; :attr:`SmartModel.assembly_points_by_source` counts both.

Precast and steel exports (Tekla) group parts into ``IfcElementAssembly`` units, the unit that is
lifted and placed, and into other aggregates (a wide-slab floor plate: an ``IfcSlab`` of proxies); see
:attr:`BuildingModel.assemblies`. By default each outermost one is ONE component (:func:`assembly_units`):
its parts travel and are placed together, its mass is the sum of its parts', its body the union of
theirs, its id the whole's GlobalId, its ``object_type`` the whole's class, and its class the whole's
(an IfcElementAssembly takes that of its heaviest part). Connections between parts of one unit are made
in the factory, not on site. ``by_element=True`` builds element by element instead.

Prebuilt components (foundations, or what ``--prebuilt`` names, e.g. cast-in-place slabs and walls) are
work of others. One is on site from the start only when everything it rests on is prebuilt too; one
that rests on a robot-built component (a cast slab on a robot-placed downstand beam) is made by others,
in no robot time, the moment everything it rests on has its position fixed (:attr:`SmartModel.prebuilt_later`).
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import gc
import logging
from dataclasses import dataclass, field
from typing import Iterable

import numpy as np

from bimrobot.bim.model import BuildingModel, Connection, Element
from bimrobot.core.errors import InputError
from bimrobot.sco.component import Component, ConnectionNode, Joint
from bimrobot.sco.joints import (
    connector_roles,
    direct_joints,
    duplicates_of_connected,
    fasteners_at_joints,
    joints_from_relations,
    points_by_source,
    split_points,
)
from bimrobot.sco.prebuilt import ASSEMBLY_CLASS, PREBUILT_CLASSES, PrebuiltRule, prebuilt_rule, prebuilt_selector
from bimrobot.sco.states import State
from bimrobot.sco.units import assembly_units, main_part, map_connections, orient_inferred

# Their callers import these from here, where they were before the split (issue 37).
__all__ = ["SmartModel", "build_smart_model", "gc_paused", "ASSUMED_POINTS_PER_JOINT", "MAX_TOLERANCE_M",
           "PREBUILT_CLASSES", "main_part", "prebuilt_rule", "prebuilt_selector", "split_points"]

log = logging.getLogger(__name__)

#: Fastening points an inferred joint is given when the model has no fastener there: four bolts, the
#: smallest usual bolted shear connection (a beam's fin plate or cleat), two on each side's node. An
#: assumption, reported as such; set ``assembly_points_per_joint`` (the fleet/site file's key of that name).
ASSUMED_POINTS_PER_JOINT = 4
#: Classes that are never components themselves (fasteners, non-physical or non-structural items).
#: Reinforcement is cast into its concrete, never lifted by itself. (Proxies are components: Tekla exports
#: precast floor plates as IfcBuildingElementProxy; leave them out with ``--exclude IfcBuildingElementProxy``.)
NON_COMPONENT_CLASSES = (
    "IfcFastener", "IfcMechanicalFastener", "IfcDiscreteAccessory", "IfcOpeningElement",
    "IfcSpace", "IfcAnnotation", "IfcGrid", "IfcVirtualElement",
    "IfcReinforcingBar", "IfcReinforcingMesh", "IfcTendon", "IfcTendonAnchor",
)
#: A partner counts as carrying a component when its bottom is this much lower (metres).
SUPPORT_MARGIN_M = 0.05
#: Largest gap (metres) that may count as touching when connections are inferred.
MAX_TOLERANCE_M = 0.5


@dataclass
class SmartModel:
    """The smart construction objects of one building, ready for the coordination simulation.

    ``floors``: storey GlobalIds bottom to top (index = floor number). ``supporters``: component id ->
    ids of the connected components that carry it (their bottom is lower), which must have their
    position fixed before it is brought in ("columns before the beams they carry").
    """

    source: str
    components: dict[str, Component]
    nodes: dict[str, ConnectionNode]
    joints: dict[str, Joint]
    floors: list[str]
    floor_names: list[str]
    supporters: dict[str, tuple[str, ...]]
    connection_source: str
    role_rule: str = ""
    connectors: list[str] = field(default_factory=list)
    duplicates: list[str] = field(default_factory=list)
    unconnected: list[str] = field(default_factory=list)
    unknown_weight: list[str] = field(default_factory=list)
    partial_weight: list[str] = field(default_factory=list)
    prebuilt_later: list[str] = field(default_factory=list)
    assemblies: int = 0
    internal_connections: int = 0
    #: {"model": {"joints": n, "points": n}, "assumed": {"joints": n, "points": n, "per_joint": n}}
    assembly_points_by_source: dict = field(default_factory=dict)
    #: elements whose goal was taken from their body, not from a placement that lies elsewhere
    #: (:attr:`bimrobot.bim.model.BuildingModel.relocated`): [{"GlobalId", "class", "name", "moved_m"}]
    goals_from_body: list[dict] = field(default_factory=list)

    def copy_for_run(self) -> SmartModel:
        """A copy whose components and nodes change state and position independently of this model's.

        A simulation moves and advances the objects it is given; it works on such a copy, so the same
        SmartModel can be simulated again (another fleet, evaluator or seed) and stays as built. Joints
        and everything else that a run only reads are shared.
        """
        nodes = {}
        for node_id, node in self.nodes.items():
            twin = copy.copy(node)
            twin.position = node.position.copy()
            nodes[node_id] = twin
        components = {}
        for gid, component in self.components.items():
            twin = copy.copy(component)
            twin.position = component.position.copy()
            twin.connection_nodes = [nodes.get(n.id, n) for n in component.connection_nodes]
            components[gid] = twin
        return dataclasses.replace(self, components=components, nodes=nodes)

    @property
    def inferred(self) -> list[Joint]:
        """Joints that were inferred from geometry rather than read from IFC relations."""
        return [joint for joint in self.joints.values() if joint.inferred]

    def joints_of(self, component_id: str) -> list[Joint]:
        return [self.joints[self.nodes[n.id].joint_id] for n in self.components[component_id].connection_nodes]

    def robot_supporters(self, component_id: str) -> tuple[str, ...]:
        """The robot-built components that must have their position fixed before ``component_id`` can be.

        Its supporters, where a prebuilt supporter made later (:attr:`prebuilt_later`) is replaced by what
        it rests on in turn; prebuilt supporters on site from the start drop out.
        """
        found: dict[str, None] = {}
        stack = list(self.supporters[component_id])
        later = set(self.prebuilt_later)
        while stack:
            gid = stack.pop()
            if not self.components[gid].prebuilt:
                found[gid] = None
            elif gid in later:
                stack.extend(self.supporters[gid])
        return tuple(sorted(found))

    def summary(self) -> dict:
        """Counts and provenance, for reports (JSON-serialisable)."""
        nodes = self.nodes.values()
        return {
            "source": self.source,
            "connection_source": self.connection_source,
            "role_rule": self.role_rule,
            "components": len(self.components),
            "assembly_units": self.assemblies,
            "internal_connections_not_built": self.internal_connections,
            "prebuilt": sorted(c.id for c in self.components.values() if c.prebuilt),
            "prebuilt_after_supports": self.prebuilt_later,
            "connection_nodes": len(self.nodes),
            "joints": len(self.joints),
            "assembly_points": sum(n.assembly_point_number for n in nodes),
            "assembly_points_by_source": self.assembly_points_by_source,
            "assembly_methods": sorted({n.assembly_method for n in nodes}),
            "goals_from_body": {"count": len(self.goals_from_body), "elements": self.goals_from_body},
            "connectors": self.connectors,
            "inferred_joints": [list(j.component_ids) for j in self.inferred],
            "unconnected_components": self.unconnected,
            "duplicates_not_built": self.duplicates,
            "components_without_weight": self.unknown_weight,
            "assemblies_with_parts_without_weight": self.partial_weight,
            "floors": self.floor_names,
        }


@contextlib.contextmanager
def gc_paused():
    """Pause Python's cyclic garbage collector while many long-lived objects are created.

    Its full collections walk every live object, so with tens of thousands of components they made the
    run time grow faster than linearly (measured: a quarter of the CPU time at 10,000 components).
    Usable as ``with gc_paused():`` or as the decorator ``@gc_paused()``.
    """
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


@dataclass
class _Connected:
    """What :func:`build_smart_model` builds on: the model of its work units and their connections."""

    work: BuildingModel  # the model itself, or its assembly units in place of their parts
    connections: list[Connection]
    source: str  # where the connections came from (SmartModel.connection_source)
    related: set[str]  # the connectors
    role_rule: str
    parts: dict[str, tuple[str, ...]] = field(default_factory=dict)  # unit -> its parts
    partial: list[str] = field(default_factory=list)  # units with a part of unknown weight
    internal: int = 0  # relations between parts of one unit (made in the factory)


def _check_arguments(inferred_tolerance_m: float, assembly_points_per_joint: int) -> None:
    if not (0 < inferred_tolerance_m <= MAX_TOLERANCE_M):
        raise InputError(
            f"the contact tolerance must be > 0 and <= {MAX_TOLERANCE_M:g} m (bodies this close count as touching), "
            f"got {inferred_tolerance_m!r}"
        )
    if isinstance(assembly_points_per_joint, bool) or not isinstance(assembly_points_per_joint, int) or assembly_points_per_joint < 1:
        raise InputError(
            f"assembly_points_per_joint must be a whole number of fastening points >= 1, got {assembly_points_per_joint!r}"
        )


def _unit_connections(model: BuildingModel, explicit: list[Connection], tolerance_m: float) -> _Connected:
    """Assembly units joined directly to each other: the file's relations between units, else contact."""
    work, unit_of, parts, partial = assembly_units(model)
    mapped = map_connections(explicit, unit_of)
    if mapped:
        connections, source = mapped, "IfcRelConnectsWithRealizingElements between assemblies"
    else:
        inferred = [c for c in model.connections if c.inferred] or _infer(model, tolerance_m)
        connections = orient_inferred(map_connections(inferred, unit_of), work)
        source = "inferred from geometry" if connections else "none"
    role_rule = "assemblies are joined directly to each other (connections between parts of one assembly are internal)"
    return _Connected(work, connections, source, set(), role_rule, parts, partial, len(explicit) - len(mapped))


def _element_connections(model: BuildingModel, explicit: list[Connection], tolerance_m: float) -> _Connected:
    """Element by element: the file's relations with their connectors, else touching components joined directly."""
    if explicit:
        related, role_rule = connector_roles(model, explicit)
        return _Connected(model, explicit, "IfcRelConnectsWithRealizingElements", related, role_rule)
    connections = [c for c in model.connections if c.inferred]
    if not connections:
        connections = _infer(model, tolerance_m)
    source = "inferred from geometry" if connections else "none"
    return _Connected(model, connections, source, set(), "no connectors: touching components are joined directly")


def _components(model: BuildingModel, connected: _Connected, realizing: set[str], floors: list[str],
                is_prebuilt) -> dict[str, Component]:
    """The components: every work unit that is no connector, no realizing element and of no
    :data:`NON_COMPONENT_CLASSES`. Raises InputError when there is none."""
    work = connected.work
    component_ids = [
        gid
        for gid, element in work.elements.items()
        if gid not in connected.related and gid not in realizing and element.ifc_class not in NON_COMPONENT_CLASSES
    ]
    wholes = {gid: a.ifc_class for gid, a in model.assemblies.items()} if connected.parts else {}
    if not component_ids:
        raise InputError(f"{model.source or 'the model'} has no buildable element (columns, beams, footings, ...)")
    return {
        gid: _component(work.elements[gid], work, floors, is_prebuilt, connected.parts.get(gid, ()), wholes.get(gid))
        for gid in component_ids
    }


def _goals_from_body(model: BuildingModel) -> list[dict]:
    """The elements whose goal was moved onto their body by the reader (``model.relocated``), in metres."""
    return [
        {"GlobalId": r.global_id, "class": r.ifc_class, "name": r.name, "moved_m": r.distance_m}
        for r in getattr(model, "relocated", ())
    ]


def _joints_and_nodes(model: BuildingModel, c: _Connected, components: dict[str, Component], tolerance_m: float,
                      points_per_joint: int, method: str) -> tuple[dict, dict, list[str]]:
    """The joints and nodes, and the duplicates dropped from ``components`` (uncut copies of connected members)."""
    if c.source == "IfcRelConnectsWithRealizingElements":
        joints, nodes = joints_from_relations(c.work, c.connections, components, c.related)
        duplicates = duplicates_of_connected(c.work, components, nodes)
        for gid in duplicates:
            del components[gid]
        return joints, nodes, duplicates
    fasteners = fasteners_at_joints(model, c.work, c.connections, components, tolerance_m,
                                    {p for ids in c.parts.values() for p in ids})
    joints, nodes = direct_joints(c.work, model, c.connections, components, points_per_joint, method, fasteners)
    return joints, nodes, []


def _link(components: dict[str, Component], joints: dict[str, Joint], nodes: dict[str, ConnectionNode]) -> None:
    """Give each component its nodes and joint partners, each node the other nodes of its joint."""
    for node in nodes.values():
        components[node.component_id].connection_nodes.append(node)
    for joint in joints.values():
        for gid in joint.component_ids:
            partners = [other for other in joint.component_ids if other != gid]
            components[gid].relative_object_ids.extend(p for p in partners if p not in components[gid].relative_object_ids)
        for node_id in joint.node_ids:
            nodes[node_id].relative_object_ids = [n for n in joint.node_ids if n != node_id]


def _supporters(components: dict[str, Component]) -> dict[str, tuple[str, ...]]:
    """Component -> the joint partners it rests on: lower by :data:`SUPPORT_MARGIN_M` and on its floor or below."""
    return {
        gid: tuple(
            sorted(
                other
                for other in component.relative_object_ids
                if components[other].bottom_z < component.bottom_z - SUPPORT_MARGIN_M
                and components[other].floor <= component.floor
            )
        )
        for gid, component in components.items()
    }


def _prebuilt_states(components: dict[str, Component], joints: dict[str, Joint], nodes: dict[str, ConnectionNode],
                     supporters: dict[str, tuple[str, ...]]) -> set[str]:
    """Set the start states of the prebuilt components and return those made later (SmartModel.prebuilt_later)."""
    # A prebuilt component resting on a robot-built one (or on one made later) cannot be there from the
    # start: it is made by others once what it rests on is fixed. Supporters are strictly lower, so one
    # pass bottom-up decides it.
    later: set[str] = set()
    for component in sorted(components.values(), key=lambda c: (c.bottom_z, c.id)):
        if component.prebuilt and any(
            not components[s].prebuilt or s in later for s in supporters[component.id]
        ):
            later.add(component.id)
    for component in components.values():
        if component.prebuilt:
            on_site = component.id not in later
            component.state = State.POSITION_FIXED if on_site else State.IN_LOCATION
            for node in component.connection_nodes:
                node.state = component.state
    # Joints among prebuilt components only (a wall standing on a cast slab) are made with them.
    for joint in joints.values():
        if all(components[gid].prebuilt for gid in joint.component_ids):
            for node_id in joint.node_ids:
                nodes[node_id].state = State.ASSEMBLED
    for component in components.values():
        if (
            component.prebuilt
            and component.id not in later
            and all(n.state == State.ASSEMBLED for n in component.connection_nodes)
        ):
            component.state = State.ASSEMBLED
    return later


def _log_summary(smart: SmartModel) -> None:
    if smart.unknown_weight:
        log.warning(
            "%d components have no weight, not even an assumed one (e.g. %s): payload checks cannot verify them",
            len(smart.unknown_weight), smart.unknown_weight[0],
        )
    log.info(
        "%s: %d components, %d connection nodes, %d joints (%s)",
        smart.source, len(smart.components), len(smart.nodes), len(smart.joints), smart.connection_source,
    )


@gc_paused()
def build_smart_model(
    model: BuildingModel,
    *,
    prebuilt_classes: Iterable[str] | str = PREBUILT_CLASSES,
    inferred_tolerance_m: float = 0.01,
    assembly_points_per_joint: int = ASSUMED_POINTS_PER_JOINT,
    inferred_assembly_method: str = "bolt",
    by_element: bool = False,
) -> SmartModel:
    """Components, connection nodes and joints of ``model``.

    Uses the model's ``IfcRelConnectsWithRealizingElements`` when there are any; otherwise connections
    inferred from touching geometry (``bimrobot.bim.connections.infer_connections`` with
    ``inferred_tolerance_m``, metres). An inferred joint's points are the model's fasteners there, or
    else ``assembly_points_per_joint`` (assumed, made by ``inferred_assembly_method``). When the model
    has assemblies (``model.assemblies``) each is one component unless ``by_element``.
    ``prebuilt_classes``: a ``--prebuilt`` selector, or IFC class names (subclasses count; and
    ``IfcElementAssembly`` for every assembly unit), that are work of others. Raises InputError when the
    model has no buildable element, a prebuilt class is not an IFC class, the tolerance is not in
    (0, 0.5] m or the points per joint are not a whole number >= 1.
    """
    _check_arguments(inferred_tolerance_m, assembly_points_per_joint)
    is_prebuilt = prebuilt_rule(model, prebuilt_classes)
    explicit = [c for c in model.connections if not c.inferred]
    realizing = {r for c in explicit for r in c.realizing_ids}
    if model.assemblies and not by_element:
        connected = _unit_connections(model, explicit, inferred_tolerance_m)
    else:
        connected = _element_connections(model, explicit, inferred_tolerance_m)
    floors, floor_names = _floor_order(connected.work)
    components = _components(model, connected, realizing, floors, is_prebuilt)
    joints, nodes, duplicates = _joints_and_nodes(model, connected, components, inferred_tolerance_m,
                                                  assembly_points_per_joint, inferred_assembly_method)
    _link(components, joints, nodes)
    supporters = _supporters(components)
    later = _prebuilt_states(components, joints, nodes, supporters)
    smart = SmartModel(
        source=str(model.source or model.project_name),
        components=components,
        nodes=nodes,
        joints=joints,
        floors=floors,
        floor_names=floor_names,
        supporters=supporters,
        connection_source=connected.source,
        role_rule=connected.role_rule,
        connectors=sorted(connected.related),
        duplicates=duplicates,
        unconnected=sorted(gid for gid, c in components.items() if not c.connection_nodes),
        unknown_weight=sorted(gid for gid, c in components.items() if c.weight_kg is None),
        partial_weight=sorted(gid for gid in connected.partial if gid in components),
        prebuilt_later=sorted(later),
        assemblies=sum(1 for c in components.values() if c.part_ids),
        internal_connections=connected.internal,
        assembly_points_by_source=points_by_source(joints, nodes, assembly_points_per_joint),
        goals_from_body=_goals_from_body(model),
    )
    _log_summary(smart)
    return smart


def _infer(model: BuildingModel, tolerance_m: float) -> list[Connection]:
    from bimrobot.bim.connections import infer_connections

    return list(infer_connections(model, tolerance_m))


def _floor_order(model: BuildingModel) -> tuple[list[str], list[str]]:
    storeys = sorted(model.storeys, key=lambda s: s.elevation)
    if not storeys:
        return ["(no storey)"], ["(no storey)"]
    return [s.global_id for s in storeys], [s.name for s in storeys]


def _floor_of(element: Element, model: BuildingModel, floors: list[str]) -> int:
    if element.storey_id in floors:
        return floors.index(element.storey_id)
    if not model.storeys:
        return 0
    # No storey assignment: the highest storey whose elevation is at or below the element's bottom.
    elevations = sorted(model.storeys, key=lambda s: s.elevation)
    bottom = float(element.world_bounds[0, 2])
    floor = 0
    for index, storey in enumerate(elevations):
        if storey.elevation <= bottom + 0.01:
            floor = index
    return floor


def _component(element: Element, model: BuildingModel, floors: list[str], is_prebuilt, part_ids=(),
               whole_class: str | None = None) -> Component:
    bounds = element.world_bounds
    extents = sorted(own_extents(element), reverse=True)
    centre = bounds.mean(axis=0)
    if isinstance(is_prebuilt, PrebuiltRule):
        prebuilt = is_prebuilt.of(element.global_id, element.ifc_class, whole_class, part_ids)
    else:  # a plain test of the class
        prebuilt = bool(is_prebuilt(element.ifc_class))
    return Component(
        id=element.global_id,
        name=element.name,
        object_type=(whole_class or ASSEMBLY_CLASS) if part_ids else element.ifc_class,
        ifc_class=element.ifc_class,
        weight_kg=element.weight_kg,
        storey_id=element.storey_id,
        floor=_floor_of(element, model, floors),
        target_position=centre,
        origin=element.position,
        position=centre.copy(),
        size=(extents[0], extents[1], extents[2]),
        bottom_z=float(bounds[0, 2]),
        prebuilt=prebuilt,
        part_ids=tuple(part_ids),
    )


#: A body filling less than this share of its local box is measured again in its tightest oriented box.
LOOSE_FILL = 0.5


def own_extents(element: Element) -> tuple[float, float, float]:
    """The element's extents (metres) in its own frame: a member's length along its axis.

    The local frame of the placement is used (a diagonal beam is as long as it is). Some exports place
    a body diagonally in an unrotated frame (ArchiCAD's rafters); when the body fills less than
    :data:`LOOSE_FILL` of that box, the tightest oriented box (trimesh) is used if it is smaller.
    """
    local = element.local_bounds
    extents = local[1] - local[0]
    box = float(np.prod(extents))
    vertices, faces = element.vertices, element.faces
    if box > 0 and len(faces) and len(vertices) >= 4:
        triangles = vertices[faces]
        volume = abs(float(np.einsum("ij,ij->i", triangles[:, 0], np.cross(triangles[:, 1], triangles[:, 2])).sum())) / 6.0
        if 0 < volume < LOOSE_FILL * box:
            try:
                oriented = _oriented_extents(vertices)
                if float(np.prod(oriented)) < box:
                    extents = np.asarray(oriented)
            except Exception:  # a degenerate hull (flat or needle-thin body): keep the local box
                pass
    return tuple(float(v) for v in extents)


# ---- issue 38 (planning at 10,000 components): identical members share one body (one mapped
# representation), so their tightest oriented box is measured once. Before: trimesh's hull for each of a
# generated 10,000-component frame's members, most of build_smart_model's time.
_ORIENTED: dict[bytes, np.ndarray] = {}  # digest of a body's local vertices -> its oriented extents (m)


def _oriented_extents(vertices: np.ndarray) -> np.ndarray:
    """trimesh's tightest oriented box extents (metres) of ``vertices`` (local frame), once per body."""
    import hashlib

    key = hashlib.blake2b(np.ascontiguousarray(vertices).tobytes(), digest_size=16).digest() + bytes(str(vertices.shape), "ascii")
    if key not in _ORIENTED:
        import trimesh

        if len(_ORIENTED) >= 4096:
            _ORIENTED.clear()
        _ORIENTED[key] = np.asarray(trimesh.bounds.oriented_bounds(vertices)[1])
    return _ORIENTED[key].copy()


