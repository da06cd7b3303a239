"""The triples of one model (and schedule) for the construction graph, in the order of fig. 5.5:
topology, elements and assemblies, connections and joints, activities (:class:`GraphWriter`, used by
:func:`bimrobot.lbd.graph.build_graph`). Positions in metres (world frame, z up), times in seconds.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Iterable, Iterator

from rdflib import RDF, RDFS, Literal, URIRef

from bimrobot.bim import components
from bimrobot.core.errors import InputError
from bimrobot.core.tasks import Task
from bimrobot.lbd.terms import (
    BOT,
    BRC,
    DICE,
    DICP,
    FROM_GEOMETRY,
    FROM_IFC_RELATION,
    Triple,
    literal,
    property_iri,
)
from bimrobot.core.tasks import Activity
from bimrobot.schedule.schedule import Schedule

if TYPE_CHECKING:  # pragma: no cover
    from bimrobot.bim.model import BuildingModel
    from bimrobot.sco.build import SmartModel


def _provenance(joint) -> str:
    return FROM_GEOMETRY if joint.inferred else FROM_IFC_RELATION


class GraphWriter:
    """Yields the triples of one model (and schedule), in the order of fig. 5.5."""

    def __init__(self, graph, model: BuildingModel, properties: bool = True, assemblies: bool = True,
                 smart: SmartModel | None = None, pick_up: dict[str, tuple[float, float, float]] | None = None,
                 site=None, fleet=None):
        self.graph, self.model, self.properties, self.smart = graph, model, properties, smart
        self.run_site, self.fleet = site, fleet
        self.pick_up = pick_up or {}
        self.assemblies = dict(getattr(model, "assemblies", {})) if assemblies else {}
        self.site = graph.iri("site", "site")
        self.storeys = {s.global_id for s in model.storeys}
        self.building = graph.iri("building", "building")
        self.start_states = self._start_states()
        self.interfaces = {f"{c.relating_id}:{c.related_id}" for c in model.connections}
        if smart is not None:
            self.interfaces.update(smart.nodes)
        self.bar = None  # a progress bar, advanced by one per element, assembly, connection, joint, activity

    def items(self, schedule: Schedule | None) -> int:
        """How many items (elements, assemblies, connections, joints, activities) the graph describes."""
        count = len(self.model.elements) + len(self.assemblies) + len(self.model.connections)
        if self.smart is not None:
            count += len(self.smart.joints)
        if schedule is not None:
            count += len(schedule.activities) + len(schedule.phases)
        return count

    def _tick(self) -> None:
        if self.bar is not None:
            self.bar.update(1)

    def _start_states(self) -> dict[str, str]:
        """GlobalId -> the state a prebuilt component (and each part of a prebuilt assembly) starts in."""
        states: dict[str, str] = {}
        if self.smart is None:
            return states
        for component in self.smart.components.values():
            if component.prebuilt:
                for gid in (component.id, *component.part_ids):
                    states[gid] = str(component.state)
        return states

    def topology(self) -> Iterator[Triple]:
        g, model = self.graph, self.model
        yield self.site, RDF.type, BOT.Site
        yield self.site, RDFS.label, Literal(model.site_name or "site")
        yield self.site, BOT.hasBuilding, self.building
        if self.run_site is not None and self.run_site.model_offset is not None:
            from bimrobot.site.site import site_to_dict

            yield self.site, BRC.modelOffsetX, literal(float(self.run_site.model_offset[0]))
            yield self.site, BRC.modelOffsetY, literal(float(self.run_site.model_offset[1]))
            yield self.site, BRC.siteDescription, Literal(json.dumps(site_to_dict(self.run_site)))
        if self.fleet is not None:
            yield from self.fleet_triples()
        yield self.building, RDF.type, BOT.Building
        yield self.building, RDFS.label, Literal(model.project_name or "building")
        for storey in model.storeys:
            iri = g.iri("storey", storey.global_id)
            yield self.building, BOT.hasStorey, iri
            yield iri, RDF.type, BOT.Storey
            yield iri, BRC.globalId, Literal(storey.global_id)
            yield iri, RDFS.label, Literal(storey.name)
            yield iri, BRC.elevation, literal(float(storey.elevation))
        storeys = {s.global_id for s in model.storeys}
        for element in model.elements.values():
            yield from self.element(element, storeys)
            self._tick()
        for assembly in self.assemblies.values():
            yield from self.assembly(assembly, storeys)
            self._tick()
        for connection in model.connections:
            yield from self.interface(connection)
            self._tick()
        if self.smart is not None:
            for joint in self.smart.joints.values():
                yield from self.joint(joint)
                self._tick()

    def element(self, element, storeys: set[str]) -> Iterator[Triple]:
        iri = self.graph.element_iri(element.global_id)
        zone = self.graph.iri("storey", element.storey_id) if element.storey_id in storeys else self.building
        yield zone, BOT.containsElement, iri
        yield iri, RDF.type, BOT.Element
        yield iri, BRC.globalId, Literal(element.global_id)
        yield iri, BRC.ifcClass, Literal(element.ifc_class)
        if element.name:
            yield iri, RDFS.label, Literal(element.name)
        if element.weight_kg is not None:
            yield iri, BRC.weightKg, literal(float(element.weight_kg))
            yield iri, BRC.weightSource, Literal(getattr(element.weight_source, "value", str(element.weight_source)))
        if element.material:
            yield iri, BRC.material, Literal(element.material)
        yield from _position(URIRef(f"{iri}/position"), iri, DICE.hasQuality, element.position)
        if len(element.vertices):
            lengths = element.local_bounds[1] - element.local_bounds[0]
            size = URIRef(f"{iri}/size")
            yield iri, DICE.hasQuality, size
            yield size, RDF.type, DICE.CartesianVolume
            for prop, length in zip((DICE.hasXLength, DICE.hasYLength, DICE.hasZLength), lengths):
                yield size, prop, literal(float(length))
        if self.properties:
            yield from _property_values(iri, element.properties)
        yield from self.state(iri, element.global_id)

    def assembly(self, assembly, storeys: set[str]) -> Iterator[Triple]:
        """An assembly as a bot:Element with its parts as bot:hasSubElement (see the module docstring)."""
        g, model, gid = self.graph, self.model, assembly.global_id
        iri = g.element_iri(gid)
        storey = components.storey_id(model, gid)
        yield (g.iri("storey", storey) if storey in storeys else self.building), BOT.containsElement, iri
        yield iri, RDF.type, BOT.Element
        yield iri, BRC.globalId, Literal(gid)
        yield iri, BRC.ifcClass, Literal("IfcElementAssembly")
        if assembly.name:
            yield iri, RDFS.label, Literal(assembly.name)
        for part in assembly.part_ids:
            if part in model.elements:
                yield iri, BOT.hasSubElement, g.element_iri(part)
        weight = components.weight_kg(model, gid)
        if weight is not None:
            yield iri, BRC.weightKg, literal(weight)
            yield iri, BRC.weightSource, Literal("sum of its parts")
        yield from _position(URIRef(f"{iri}/position"), iri, DICE.hasQuality, components.position(model, gid))
        size = components.extents(model, gid)
        if size is not None:
            volume = URIRef(f"{iri}/size")
            yield iri, DICE.hasQuality, volume
            yield volume, RDF.type, DICE.CartesianVolume
            for prop, length in zip((DICE.hasXLength, DICE.hasYLength, DICE.hasZLength), size):
                yield volume, prop, literal(float(length))
        yield from self.state(iri, gid)

    def state(self, iri: URIRef, gid: str) -> Iterator[Triple]:
        """The component's starting state and, when it waits on the yard, its pick-up position."""
        state = self.start_states.get(gid, "OnYard")
        yield iri, DICE.hasEntityState, BRC[state]
        if state == "OnYard" and gid in self.pick_up:
            yield from _position(URIRef(f"{iri}/pick-up"), iri, BRC.pickUpPosition, self.pick_up[gid])

    def interface(self, connection) -> Iterator[Triple]:
        g = self.graph
        node_id = f"{connection.relating_id}:{connection.related_id}"
        iri = g.interface_iri(node_id)
        relating, related = g.element_iri(connection.relating_id), g.element_iri(connection.related_id)
        yield iri, RDF.type, BOT.Interface
        yield iri, BRC.nodeId, Literal(node_id)
        yield iri, BOT.interfaceOf, relating
        yield iri, BOT.interfaceOf, related
        yield iri, BRC.relatingElement, relating
        yield iri, BRC.relatedElement, related
        if connection.global_id:
            yield iri, BRC.globalId, Literal(connection.global_id)
        if connection.connection_type:
            yield iri, BRC.connectionType, Literal(connection.connection_type)
        yield iri, BRC.inferred, Literal(bool(connection.inferred))
        for realizing in connection.realizing_ids:
            yield iri, BRC.realizingElement, g.element_iri(realizing)

    def joint(self, joint) -> Iterator[Triple]:
        """A joint of the simulation (:class:`bimrobot.sco.component.Joint`) and its connection nodes.

        The joint is a ``bot:Interface`` (and ``brc:Joint``) of its components and connectors, with its
        provenance, realizing elements, total assembly points and where the robot works (m, world).
        Each node is a ``bot:Interface`` (and ``brc:ConnectionNode``) of its component and its
        connector, with its own points and method; a prebuilt component's nodes carry their state.
        """
        g, smart = self.graph, self.smart
        iri = g.iri("joint", joint.id)
        provenance = Literal(_provenance(joint))
        nodes = [smart.nodes[n] for n in joint.node_ids]
        yield iri, RDF.type, BOT.Interface
        yield iri, RDF.type, BRC.Joint
        yield iri, BRC.jointId, Literal(joint.id)
        yield iri, BRC.provenance, provenance
        for gid in (*joint.component_ids, *joint.connector_ids):
            yield iri, BOT.interfaceOf, g.element_iri(gid)
        for realizing in joint.realizing_ids:
            yield iri, BRC.realizingElement, g.element_iri(realizing)
        yield iri, BRC.assemblyPoints, Literal(sum(n.assembly_point_number for n in nodes))
        yield iri, BRC.assemblyMethod, Literal(",".join(sorted({n.assembly_method for n in nodes})))
        yield from _position(URIRef(f"{iri}/position"), iri, BRC.assemblyPosition, joint.position)
        for node in nodes:
            node_iri = g.interface_iri(node.id)
            yield iri, BRC.hasNode, node_iri
            yield node_iri, RDF.type, BOT.Interface
            yield node_iri, RDF.type, BRC.ConnectionNode
            yield node_iri, BRC.nodeId, Literal(node.id)
            yield node_iri, BRC.partOfJoint, iri
            yield node_iri, BRC.provenance, provenance
            yield node_iri, BOT.interfaceOf, g.element_iri(node.component_id)
            for connector in node.connector_ids:
                yield node_iri, BOT.interfaceOf, g.element_iri(connector)
            yield node_iri, BRC.assemblyPoints, Literal(int(node.assembly_point_number))
            yield node_iri, BRC.assemblyMethod, Literal(node.assembly_method)
            if smart.components[node.component_id].prebuilt:
                yield node_iri, DICE.hasEntityState, BRC[str(node.state)]

    def processes(self, schedule: Schedule) -> Iterator[Triple]:
        interfaces = self.interfaces
        robots: set[str] = set()
        for phase in schedule.phases:
            yield from self.activity(phase, interfaces)
            self._tick()
        for activity in schedule.activities:
            yield from self.activity(activity, interfaces)
            self._tick()
            if activity.robot and activity.robot not in robots:
                robots.add(activity.robot)
                robot = self.graph.iri("robot", activity.robot)
                yield robot, RDF.type, DICE.Device
                yield robot, RDF.type, DICP.Resource
                yield robot, RDFS.label, Literal(activity.robot)

    def fleet_triples(self) -> Iterator[Triple]:
        """The fleet's robots, what each does, and the fleet file itself (``brc:fleetDescription``)."""
        from bimrobot.site.fleet import fleet_to_dict

        yield self.site, BRC.fleetDescription, Literal(json.dumps(fleet_to_dict(self.fleet)))
        for spec in self.fleet.robots:
            robot = self.graph.iri("robot", spec.name)
            yield robot, RDF.type, DICE.Device
            yield robot, RDFS.label, Literal(spec.name)
            yield robot, BRC.robotKind, Literal(spec.kind)
            for task in spec.activities:
                yield robot, BRC.performs, Literal(str(task))

    def activity(self, activity: Activity, interfaces: set[str]) -> Iterator[Triple]:
        g = self.graph
        iri = g.activity_iri(activity.id)
        yield iri, RDF.type, DICP.Activity
        yield iri, BRC.identification, Literal(activity.id)
        yield iri, RDFS.label, Literal(activity.name)
        if activity.activity:
            yield iri, BRC.activityType, Literal(activity.activity)
        if activity.predefined_type:
            yield iri, BRC.taskType, Literal(activity.predefined_type)
        if activity.parent:
            yield g.activity_iri(activity.parent), DICP.hasSubActivity, iri
        for predecessor in activity.predecessors:
            yield iri, DICE.precededBy, g.activity_iri(predecessor)
        yield from self.interval(iri, activity)
        yield from self.objects(iri, activity, interfaces)
        if activity.robot:
            role = URIRef(f"{iri}/resource")
            robot = g.iri("robot", activity.robot)
            yield iri, DICP.hasAssignedResource, role
            yield role, RDF.type, DICP.ResourceRole
            yield role, DICE.isRoleOf, robot
            yield robot, DICE.hasRole, role
        if activity.target is not None:
            yield from _position(URIRef(f"{iri}/target"), iri, BRC.targetPosition, activity.target)
        if activity.work_from is not None:
            yield from _position(URIRef(f"{iri}/work"), iri, BRC.workPosition, activity.work_from)
        if activity.work_to is not None and activity.work_to != activity.work_from:
            yield from _position(URIRef(f"{iri}/work-end"), iri, BRC.workEndPosition, activity.work_to)
        if activity.nodes is not None:
            yield iri, BRC.nodeCount, Literal(int(activity.nodes))
        if activity.points is not None:
            yield iri, BRC.pointCount, Literal(int(activity.points))
        if activity.storey:
            if activity.storey not in self.storeys:
                raise InputError(f"schedule activity {activity.id}: Storey {activity.storey!r} is not a storey of {self.model.source or 'the model'}")
            yield iri, BRC.onStorey, g.iri("storey", activity.storey)
        yield iri, DICE.hasEntityState, BRC.NotStarted

    def interval(self, iri: URIRef, activity: Activity) -> Iterator[Triple]:
        interval, start, end = URIRef(f"{iri}/interval"), URIRef(f"{iri}/start"), URIRef(f"{iri}/end")
        yield iri, DICP.occupiesTimeInterval, interval
        yield interval, RDF.type, DICE.TimeInterval
        yield interval, DICE.hasStart, start
        yield interval, DICE.hasEnd, end
        yield start, RDF.type, DICE.TimeInstant
        yield start, BRC.atSecond, literal(float(activity.start))
        yield end, RDF.type, DICE.TimeInstant
        yield end, BRC.atSecond, literal(float(activity.finish))

    def objects(self, iri: URIRef, activity: Activity, interfaces: set[str]) -> Iterator[Triple]:
        gid = activity.global_id
        if not gid:
            return
        if gid in self.model.elements or gid in self.assemblies:
            element = self.graph.element_iri(gid)
        elif any(s.global_id == gid for s in self.model.storeys):
            element = self.graph.iri("storey", gid)  # an IFC summary task that outputs a storey
        else:
            where = f" of {activity.id}" if activity.id else ""
            raise InputError(f"schedule activity{where}: GlobalId {gid!r} is not an element of {self.model.source or 'the model'}")
        yield iri, DICP.hasObject, element
        if activity.activity == Task.ASSEMBLE:
            yield iri, DICP.hasOutputObject, element
        if activity.node_id and activity.node_id in interfaces:
            yield iri, DICP.hasObject, self.graph.interface_iri(activity.node_id)


def _property_values(iri: URIRef, properties: dict) -> Iterator[Triple]:
    for key, value in properties.items():
        if isinstance(value, (bool, int, float, str)) and value != "":
            yield iri, property_iri(str(key)), literal(value)


def _position(iri: URIRef, owner: URIRef, link: URIRef, xyz: Iterable[float]) -> Iterator[Triple]:
    x, y, z = (float(v) for v in xyz)
    yield owner, link, iri
    yield iri, RDF.type, DICE.CartesianPosition
    yield iri, DICE.hasX, literal(x)
    yield iri, DICE.hasY, literal(y)
    yield iri, DICE.hasZ, literal(z)
