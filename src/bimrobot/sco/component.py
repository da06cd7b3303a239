"""Smart construction objects (thesis fig. 4.1): ConstructionObject, Component, ConnectionNode.

Positions are in metres in the world frame (z up); weights in kg. Identifiers are IFC GlobalIds for
components and ``"<relating GlobalId>:<related GlobalId>"`` for connection nodes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bimrobot.sco.states import STATE_ORDER, Event, Requirement, REQUIREMENT_OF, State, at_least, next_state


@dataclass(eq=False)
class ConstructionObject:
    """What components and connection nodes share: identity, state, requirement and position.

    ``relative_object_ids``: ids of the objects this one is connected to (components for a component,
    nodes for a node). ``position``: where the object is now (x, y, z in metres, world frame).
    """

    id: str
    name: str
    object_type: str
    relative_object_ids: list[str] = field(default_factory=list)
    state: State = State.ON_YARD
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))

    kind = "construction object"

    @property
    def requirement(self) -> Requirement:
        """The construction requirement under the current state (e.g. NeedToTransfer when OnYard).

        It is derived from the state, so the UML's UpdateRequirement happens with every UpdateState.
        """
        return REQUIREMENT_OF[self.state]

    def update_state(self, event: Event) -> State:
        """Apply ``event``; an event the state chart does not allow raises InvalidTransitionError."""
        self.state = next_state(self.kind, self.id, self.state, event)
        return self.state

    def publish_requirement(self) -> Requirement:
        """The requirement this object publishes to the robots now."""
        return self.requirement

    def identify_current_position(self) -> np.ndarray:
        """Current position (metres, world frame)."""
        return self.position.copy()


@dataclass(eq=False)
class ConnectionNode(ConstructionObject):
    """One side of a joint: the component ``component_id`` fastened to a connector (or to another component).

    ``assembly_point_number``: how many fastening points (bolts, welds) must be made; ``assembly_method``:
    "bolt" or "weld". ``assembly_point_source``: "model" when the count comes from the IFC (realizing
    elements, fasteners at the joint), "assumed" when from the per-joint default
    (:data:`bimrobot.sco.build.ASSUMED_POINTS_PER_JOINT`). ``level``: index of the floor the node is built
    on (see Listing 4.1).
    """

    component_id: str = ""
    joint_id: str = ""
    connector_ids: tuple[str, ...] = ()
    assembly_point_number: int = 1
    assembly_method: str = "bolt"
    assembly_point_source: str = "model"
    level: int = 0
    state: State = State.IN_LOCATION

    kind = "connection node"

    @property
    def node_state(self) -> State:
        return self.state

    @property
    def node_requirement(self) -> Requirement:
        return self.requirement


@dataclass(eq=False)
class Component(ConstructionObject):
    """A building component that robots transport, position and assemble.

    ``weight_kg`` may be None when the model gives no weight. ``target_position``: installed position
    of the component's reference point (centre of its world bounding box, metres); ``origin``: its
    placement origin in the world frame (metres). ``size``: extents of
    the bounding box in the element's own frame, sorted longest first (metres). ``bottom_z``: lowest point (metres).
    ``prebuilt``: work of others, not of the robots: foundations, or the classes given as prebuilt (on
    site from the start, state PositionFixed, unless they rest on a robot-built component: see
    :mod:`bimrobot.sco.build`). ``part_ids``: for an assembly unit (a precast unit lifted as one), the
    GlobalIds of its parts; empty for a single element. ``object_type`` is then the class of the whole
    (IfcElementAssembly, or e.g. IfcSlab for a wide-slab floor plate of proxies).
    """

    ifc_class: str = ""
    weight_kg: float | None = None
    storey_id: str | None = None
    floor: int = 0
    target_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    origin: np.ndarray | None = None
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    bottom_z: float = 0.0
    prebuilt: bool = False
    part_ids: tuple[str, ...] = ()
    connection_nodes: list[ConnectionNode] = field(default_factory=list)

    kind = "component"

    @property
    def what(self) -> str:
        """What the component is, for messages: its class, or for a unit e.g. ``"IfcElementAssembly unit
        (main part IfcBeam)"``, so a refusal names the assembly that is lifted, not one of its parts."""
        if not self.part_ids:
            return self.ifc_class
        main = f" (main part {self.ifc_class})" if self.ifc_class != self.object_type else ""
        return f"{self.object_type} unit{main}"

    @property
    def node_number(self) -> int:
        """How many connection nodes the component has."""
        return len(self.connection_nodes)

    @property
    def component_state(self) -> State:
        return self.state

    @property
    def component_requirement(self) -> Requirement:
        return self.requirement

    def publish_positioning(self) -> None:
        """Arrived -> InLocation: the component opens its nodes (all InLocation) for positioning."""
        self.update_state(Event.PUBLISH_POSITIONING)
        for node in self.connection_nodes:
            node.state = State.IN_LOCATION

    def start_positioning(self) -> None:
        """A positioning robot starts on the component: it and its open nodes are WorkingInPositioning."""
        self.update_state(Event.START_POSITIONING)
        for node in self.connection_nodes:
            node.update_state(Event.START_POSITIONING)

    def finish_positioning(self) -> None:
        """Positioning done: the component and all its nodes are PositionFixed."""
        self.update_state(Event.FINISH_POSITIONING)
        for node in self.connection_nodes:
            node.update_state(Event.FINISH_POSITIONING)
        if not self.connection_nodes:
            # Nothing to fasten: the component is complete once it stands in place.
            self.state = State.ASSEMBLED

    def abort_positioning(self) -> None:
        """The positioning robot broke down: back to InLocation, waiting for another robot."""
        self.update_state(Event.ABORT)
        for node in self.connection_nodes:
            node.update_state(Event.ABORT)

    def sync_assembly_state(self) -> None:
        """Set the component's assembly-phase state from its nodes' states.

        Assembled only when every node is Assembled; WorkingInAssembly while any node is; otherwise
        WaitForAssembly once any node waits for assembly (nodes still only PositionFixed wait for their
        partner component and keep the component in its current state).
        """
        if not at_least(self.state, State.POSITION_FIXED):
            raise ValueError(f"component {self.id} in state {self.state} is not in its assembly phase")
        states = [node.state for node in self.connection_nodes]
        if all(s == State.ASSEMBLED for s in states):
            self.state = State.ASSEMBLED
        elif any(s == State.WORKING_IN_ASSEMBLY for s in states):
            self.state = State.WORKING_IN_ASSEMBLY
        elif any(s in (State.WAIT_FOR_ASSEMBLY, State.ASSEMBLED) for s in states):
            self.state = State.WAIT_FOR_ASSEMBLY

    def sync_from_nodes(self) -> None:
        """Per-node work (thesis l.4214-4218): once arrived, the component is as far as its least advanced node.

        Used when its nodes are positioned and assembled as independent tasks: a column whose foot is
        bolted while its top nodes wait for the beams is InLocation until they are positioned, and it is
        Assembled only when every node is. Before arrival (OnYard, InTransit) nothing changes.
        """
        if self.prebuilt or not self.connection_nodes or not at_least(self.state, State.ARRIVED):
            return
        self.state = min((n.state for n in self.connection_nodes), key=STATE_ORDER.__getitem__)

    def node_event(self, node: ConnectionNode, event: Event) -> None:
        """Apply an assembly-phase event to one of this component's nodes and update the component.

        The component must allow the event in its current state (e.g. a component still OnYard cannot
        start assembling a node): otherwise InvalidTransitionError names the component, state and event.
        """
        next_state(self.kind, self.id, self.state, event)  # validate against the component's state chart
        node.update_state(event)
        self.sync_assembly_state()


@dataclass(eq=False)
class Joint:
    """A connection between components: the nodes that are fastened together in one assembly task.

    From IFC: the components whose relations share a connector (or a group of connectors joined to each
    other, e.g. ifcUnit's two cleats). Inferred: two components whose bodies touch. ``position``: where the
    robot works (centre of the connectors, or of the contact region), metres. ``floor``: the highest floor
    of its components (a column's top joint belongs to the floor of the beams it carries).
    """

    id: str
    component_ids: tuple[str, ...]
    node_ids: tuple[str, ...]
    connector_ids: tuple[str, ...]
    realizing_ids: tuple[str, ...]
    position: np.ndarray
    floor: int
    inferred: bool = False
