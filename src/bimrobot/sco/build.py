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
import re
import copy
import gc
import logging
import dataclasses
from dataclasses import dataclass, field
from typing import Callable, Iterable

import numpy as np

from bimrobot.bim.model import BuildingModel, Connection, Element, WeightSource
from bimrobot.bim.selection import DEFAULT_PREBUILT
from bimrobot.core.errors import InputError
from bimrobot.sco.component import Component, ConnectionNode, Joint
from bimrobot.sco.states import State

log = logging.getLogger(__name__)

#: Classes that are foundations already built on site when the simulation starts (thesis 4.5.2): the
#: default ``--prebuilt`` selector (:data:`bimrobot.bim.selection.DEFAULT_PREBUILT`) as a tuple.
PREBUILT_CLASSES = tuple(name.strip() for name in DEFAULT_PREBUILT.split(","))
#: Fastening points an inferred joint is given when the model has no fastener there: four bolts, the
#: smallest usual bolted shear connection (a beam's fin plate or cleat), two on each side's node. An
#: assumption, reported as such; set ``assembly_points_per_joint`` (the fleet/site file's key of that name).
ASSUMED_POINTS_PER_JOINT = 4
#: Classes whose elements are the fastening points of a joint when they reach into both its components.
FASTENER_CLASSES = ("IfcMechanicalFastener", "IfcFastener")
#: Property names (after the last "/", lower case) that give how many fasteners one element stands for
#: (a bolt group exported as one element).
FASTENER_COUNT_PROPERTIES = ("bolt count", "number of bolts", "numberofbolts", "boltcount", "number of fasteners")
#: Classes that are never components themselves (fasteners, non-physical or non-structural items).
#: Reinforcement is cast into its concrete, never lifted by itself. (Proxies are components: Tekla exports
#: precast floor plates as IfcBuildingElementProxy; leave them out with ``--exclude IfcBuildingElementProxy``.)
NON_COMPONENT_CLASSES = (
    "IfcFastener", "IfcMechanicalFastener", "IfcDiscreteAccessory", "IfcOpeningElement",
    "IfcSpace", "IfcAnnotation", "IfcGrid", "IfcVirtualElement",
    "IfcReinforcingBar", "IfcReinforcingMesh", "IfcTendon", "IfcTendonAnchor",
)
#: The class name that, given to ``prebuilt_classes``, marks every assembly unit prebuilt.
ASSEMBLY_CLASS = "IfcElementAssembly"
#: A partner counts as carrying a component when its bottom is this much lower (metres).
SUPPORT_MARGIN_M = 0.05
#: Largest gap (metres) that may count as touching when connections are inferred.
MAX_TOLERANCE_M = 0.5
#: Schemas whose class names ``prebuilt_classes`` may use (a name valid in any of them is accepted).
KNOWN_SCHEMAS = ("IFC2X3", "IFC4", "IFC4X3_ADD2")


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
    if not (0 < inferred_tolerance_m <= MAX_TOLERANCE_M):
        raise InputError(
            f"the contact tolerance must be > 0 and <= {MAX_TOLERANCE_M:g} m (bodies this close count as touching), "
            f"got {inferred_tolerance_m!r}"
        )
    if isinstance(assembly_points_per_joint, bool) or not isinstance(assembly_points_per_joint, int) or assembly_points_per_joint < 1:
        raise InputError(
            f"assembly_points_per_joint must be a whole number of fastening points >= 1, got {assembly_points_per_joint!r}"
        )
    is_prebuilt = prebuilt_rule(model, prebuilt_classes)
    explicit = [c for c in model.connections if not c.inferred]
    realizing = {r for c in explicit for r in c.realizing_ids}
    parts: dict[str, tuple[str, ...]] = {}
    partial: list[str] = []
    internal = 0
    if model.assemblies and not by_element:
        work, unit_of, parts, partial = assembly_units(model)
        mapped = _map_connections(explicit, unit_of)
        internal = len(explicit) - len(mapped)
        if mapped:
            connections, connection_source = mapped, "IfcRelConnectsWithRealizingElements between assemblies"
        else:
            inferred = [c for c in model.connections if c.inferred] or _infer(model, inferred_tolerance_m)
            connections = _orient(_map_connections(inferred, unit_of), work)
            connection_source = "inferred from geometry" if connections else "none"
        related = set()
        role_rule = "assemblies are joined directly to each other (connections between parts of one assembly are internal)"
    else:
        work = model
        if explicit:
            connection_source = "IfcRelConnectsWithRealizingElements"
            connections = explicit
        else:
            connections = [c for c in model.connections if c.inferred]
            if not connections:
                connections = _infer(model, inferred_tolerance_m)
            connection_source = "inferred from geometry" if connections else "none"
        if connection_source == "IfcRelConnectsWithRealizingElements":
            related, role_rule = connector_roles(model, connections)
        else:
            related, role_rule = set(), "no connectors: touching components are joined directly"
    component_ids = [
        gid
        for gid, element in work.elements.items()
        if gid not in related and gid not in realizing and element.ifc_class not in NON_COMPONENT_CLASSES
    ]
    wholes = {gid: a.ifc_class for gid, a in model.assemblies.items()} if parts else {}
    if not component_ids:
        raise InputError(f"{model.source or 'the model'} has no buildable element (columns, beams, footings, ...)")

    floors, floor_names = _floor_order(work)
    components = {
        gid: _component(work.elements[gid], work, floors, is_prebuilt, parts.get(gid, ()), wholes.get(gid))
        for gid in component_ids
    }

    duplicates: list[str] = []
    if connection_source == "IfcRelConnectsWithRealizingElements":
        joints, nodes = _joints_from_relations(work, connections, components, related)
        duplicates = _duplicates_of_connected(work, components, nodes)
        for gid in duplicates:
            del components[gid]
    else:
        fasteners = _fasteners_at_joints(model, work, connections, components, inferred_tolerance_m,
                                         {p for ids in parts.values() for p in ids})
        joints, nodes = _direct_joints(
            work, model, connections, components, assembly_points_per_joint, inferred_assembly_method, fasteners
        )
    for node in nodes.values():
        components[node.component_id].connection_nodes.append(node)
    for joint in joints.values():
        for gid in joint.component_ids:
            partners = [other for other in joint.component_ids if other != gid]
            components[gid].relative_object_ids.extend(p for p in partners if p not in components[gid].relative_object_ids)
        for node_id in joint.node_ids:
            nodes[node_id].relative_object_ids = [n for n in joint.node_ids if n != node_id]

    supporters = {
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

    smart = SmartModel(
        source=str(model.source or model.project_name),
        components=components,
        nodes=nodes,
        joints=joints,
        floors=floors,
        floor_names=floor_names,
        supporters=supporters,
        connection_source=connection_source,
        role_rule=role_rule,
        connectors=sorted(related),
        duplicates=duplicates,
        unconnected=sorted(gid for gid, c in components.items() if not c.connection_nodes),
        unknown_weight=sorted(gid for gid, c in components.items() if c.weight_kg is None),
        partial_weight=sorted(gid for gid in partial if gid in components),
        prebuilt_later=sorted(later),
        assemblies=sum(1 for c in components.values() if c.part_ids),
        internal_connections=internal,
        assembly_points_by_source=_points_by_source(joints, nodes, assembly_points_per_joint),
        goals_from_body=[
            {"GlobalId": r.global_id, "class": r.ifc_class, "name": r.name, "moved_m": r.distance_m}
            for r in getattr(model, "relocated", ())
        ],
    )
    if smart.unknown_weight:
        log.warning(
            "%d components have no weight, not even an assumed one (e.g. %s): payload checks cannot verify them",
            len(smart.unknown_weight), smart.unknown_weight[0],
        )
    log.info(
        "%s: %d components, %d connection nodes, %d joints (%s)",
        smart.source, len(components), len(nodes), len(joints), connection_source,
    )
    return smart


def _schema(name: str):
    import ifcopenshell

    try:
        return ifcopenshell.ifcopenshell_wrapper.schema_by_name(name)
    except Exception:  # an unknown schema (e.g. a generated model): fall back to IFC4 where used
        return None


def _declaration(schema, name: str):
    if schema is None:
        return None
    try:
        return schema.declaration_by_name(name)
    except Exception:
        return None


_CLASS_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")  # a bare name: the old class list


class PrebuiltRule:
    """Which components are prebuilt (work of others), from a ``--prebuilt`` selector.

    Called with an IFC class name it says whether that class is prebuilt (subclasses count), as the
    plain class rule always did; :meth:`of` decides for a component: an element or unit the selector
    picked, one of a prebuilt class, or a unit whose whole is of a prebuilt class (or, with
    ``IfcElementAssembly`` among the classes, any unit), or whose parts the selector all picked.
    """

    def __init__(self, classes: set[str], own_schema, ids: frozenset[str] = frozenset()):
        self.classes, self.ids, self._own, self._cache = classes, ids, own_schema, {}
        self.assemblies = ASSEMBLY_CLASS in classes

    def __call__(self, ifc_class: str) -> bool:
        if ifc_class not in self._cache:
            declaration = _declaration(self._own, ifc_class)
            names = {ifc_class}
            while declaration is not None:
                names.add(declaration.name())
                declaration = declaration.supertype()
            self._cache[ifc_class] = bool(names & self.classes)
        return self._cache[ifc_class]

    def of(self, component_id: str, ifc_class: str, whole_class: str | None = None, part_ids=()) -> bool:
        """Whether the component (an element, or a unit of ``part_ids`` whose whole is ``whole_class``) is prebuilt."""
        if component_id in self.ids or self(ifc_class):
            return True
        if part_ids:
            if self.assemblies or (whole_class and self(whole_class)):
                return True
            return bool(self.ids) and all(p in self.ids for p in part_ids)
        return False


def prebuilt_selector(text: str | None) -> str | None:
    """The ``--prebuilt`` text when it is a selector that is evaluated on the IFC file (give it to
    ``load_model(prebuilt=...)``, which evaluates it on the one parse of the file), or None when it is a
    comma list of IFC class names, which :func:`prebuilt_rule` reads without the file."""
    names = [name.strip() for name in (text or "").split(",") if name.strip()]
    return None if all(_CLASS_NAME.match(name) for name in names) else text


def prebuilt_rule(model: BuildingModel, classes: Iterable[str] | str) -> PrebuiltRule:
    """The :class:`PrebuiltRule` of a ``--prebuilt`` selector (or of IFC class names).

    A comma list of class names (``"IfcFooting, IfcPile"``, the old ``--prebuilt`` syntax) is read
    without the IFC file: a class takes its subclasses in the model's schema (``IfcWall`` takes
    ``IfcWallStandardCase``), and a name valid in another IFC schema only matches nothing. Any other
    selector (``"IfcSlab, /Pset_SlabCommon/.IsExternal=False"``, ``"IfcWall + IfcSlab"``) is evaluated
    with IfcOpenShell: from ``model.prebuilt_ids`` when the model was loaded with that selector
    (``load_model(prebuilt=...)``), else on the model's file. Raises InputError for a name that is no
    IFC class at all (listing the classes the model has) or an invalid selector.
    """
    text = classes if isinstance(classes, str) else ", ".join(str(c) for c in classes)
    names = [name.strip() for name in text.split(",") if name.strip()]
    own = _schema(model.schema) or _schema("IFC4")
    if all(_CLASS_NAME.match(name) for name in names):
        known = [s for s in (_schema(n) for n in KNOWN_SCHEMAS) if s is not None]
        wanted: set[str] = set()
        for name in names:
            declarations = [d for d in (_declaration(s, name) for s in known) if d is not None]
            if not declarations:
                present = sorted(set(model.class_counts()) | ({ASSEMBLY_CLASS} if model.assemblies else set()))
                raise InputError(
                    f"--prebuilt names '{name}', which is not an IFC class "
                    f"(this model's classes: {', '.join(present) or 'none'})"
                )
            wanted.add(declarations[0].name())
        return PrebuiltRule(wanted, own)
    if getattr(model, "prebuilt_selector", None) == text:
        return PrebuiltRule(set(), own, model.prebuilt_ids)
    if model.source is None or not str(model.source).lower().endswith((".ifc", ".ifczip")):
        raise InputError(f"--prebuilt '{text}' is a selector, which needs the model's IFC file; give IFC class names instead")
    from bimrobot.bim.reader import open_ifc, product_key, product_keys
    from bimrobot.bim.selection import select_ids

    log.info("evaluating --prebuilt '%s' on %s", text, model.source)
    ifc = open_ifc(model.source)
    keys = product_keys(ifc)
    ids = frozenset(product_key(ifc.by_id(i), keys) for i in select_ids(ifc, text, model.source, "--prebuilt"))
    return PrebuiltRule(set(), own, ids)


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


def _map_connections(connections: list[Connection], unit_of: dict[str, str]) -> list[Connection]:
    """Connections between units (relations between parts of one unit are dropped: they are internal)."""
    mapped = []
    for c in connections:
        a, b = unit_of.get(c.relating_id, c.relating_id), unit_of.get(c.related_id, c.related_id)
        if a != b:
            mapped.append(Connection(a, b, c.realizing_ids, c.connection_type, c.global_id, c.inferred))
    return mapped


def _orient(connections: list[Connection], model: BuildingModel) -> list[Connection]:
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
                import trimesh

                _, oriented = trimesh.bounds.oriented_bounds(vertices)
                if float(np.prod(oriented)) < box:
                    extents = np.asarray(oriented)
            except Exception:  # a degenerate hull (flat or needle-thin body): keep the local box
                pass
    return tuple(float(v) for v in extents)


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


def main_part(parts: list[Element]) -> Element:
    """The part whose placement an assembly unit takes (the heaviest; the first of equals): the unit's
    origin, where the schedule, the graph and RCAN install it (issue 34: one position per component)."""
    return max(parts, key=_mass_proxy)


def _mass_proxy(element: Element) -> float:
    """Weight in kg, or (weight unknown) bounding-box volume x steel density, to compare sizes."""
    if element.weight_kg is not None:
        return float(element.weight_kg)
    extent = element.world_bounds[1] - element.world_bounds[0]
    return float(np.prod(extent)) * 7850.0


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
        connectors.add(c.relating_id if _mass_proxy(a) < _mass_proxy(b) else c.related_id)
    return connectors, "the lighter element of each relation is the connector (relations are chained)"


def _duplicates_of_connected(model, components, nodes) -> list[str]:
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


def _joints_from_relations(model, connections, components, connectors: set[str]):
    """Joints from IfcRelConnectsWithRealizingElements: one per connector group."""
    group_of = _connector_groups(connectors, connections)

    group_realizing: dict[str, set[str]] = {}
    for c in connections:
        if c.relating_id in connectors and c.related_id in connectors:
            group_realizing.setdefault(group_of[c.related_id], set()).update(c.realizing_ids)

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


def _contact_point(a: Component, b: Component, model: BuildingModel) -> np.ndarray:
    box_a, box_b = model.elements[a.id].world_bounds, model.elements[b.id].world_bounds
    low = np.maximum(box_a[0], box_b[0])
    high = np.minimum(box_a[1], box_b[1])
    return (low + high) / 2.0  # centre of the overlap (or of the gap, when within tolerance)


def _fasteners_at_joints(model: BuildingModel, work: BuildingModel, connections, components, tolerance_m: float,
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


def _points_by_source(joints: dict, nodes: dict, per_joint: int) -> dict:
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


def _direct_joints(model, source_model, connections, components, points: int, method: str, fasteners=None):
    """One joint per connected pair of components, with a node on each side.

    An inferred pair takes its points from the model's fasteners there (``fasteners``: see
    :func:`_fasteners_at_joints`, method by :func:`fastener_method`), else ``points`` per joint made by
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
        realizing = tuple(c.realizing_ids)
        if c.inferred:
            found = fasteners.get(frozenset((a_id, b_id)), [])
            if found:
                count, how, source = sum(fastener_count(f) for f in found), fastener_method(found), "model"
                realizing = tuple(f.global_id for f in found)
            else:
                count, how, source = points, method, "assumed"
            counts = split_points(count)
        else:
            count, how = max(1, len(c.realizing_ids)), assembly_method(c, source_model)
            source = "model" if c.realizing_ids else "assumed"
            counts = (count, count)
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
