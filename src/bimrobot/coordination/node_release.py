"""Per-node release rules of a simulated build (``--per-node``, thesis l.4214-4218, the default).

A node asks to be positioned once its component and its joint partners have arrived (ACC), to be
assembled once its position is fixed; a component carries others once one of its nodes is fixed. A
node of a prebuilt component (a footing's anchor bolts) is assembled with the robot-built node of its
joint. :class:`NodeRelease` is a part of :class:`~bimrobot.coordination.simulation.ConstructionSimulation`
(it reads the simulation's ``smart`` model and ``build`` state); times in seconds since the build started.
"""

from __future__ import annotations

from bimrobot.coordination.run_state import SiteRobot
from bimrobot.coordination.market import TaskRequest
from bimrobot.core.tasks import Task
from bimrobot.sco.component import Component
from bimrobot.sco.states import Event, State, at_least


class NodeRelease:
    """The per-node steps of :class:`~bimrobot.coordination.simulation.ConstructionSimulation`."""

    def _node_step(self, node, event: Event) -> None:
        """Apply ``event`` to one node and update its component (per node: the component follows its nodes)."""
        owner = self.smart.components[node.component_id]
        if self.per_node and not owner.prebuilt:
            node.update_state(event)
            owner.sync_from_nodes()
        else:  # a prebuilt component's node (per node: assembled with its joint's robot-built node)
            owner.node_event(node, event)
        self._note_state(owner)

    def _prebuilt_nodes_done(self, component: Component) -> None:
        """Per node: a prebuilt component on site has nothing of its own to do (as the footings in Table 4.2);
        its nodes joined to robot-built ones (anchor bolts) are assembled with those nodes."""
        for node in component.connection_nodes:
            if node.id not in self.build.attached_to:
                node.state = State.ASSEMBLED
        if all(node.state == State.ASSEMBLED for node in component.connection_nodes):
            component.state = State.ASSEMBLED
            self.build.history[component.id].append((0.0, str(State.ASSEMBLED)))

    def _maybe_publish_node_positioning(self, node) -> None:
        """Per node: position ``node`` once its component and every partner of its joint have arrived (ACC)."""
        component = self.smart.components[node.component_id]
        if node.id in self.build.node_position_published or component.prebuilt or not at_least(component.state, State.ARRIVED):
            return
        partners = [self.smart.components[p] for p in self.smart.joints[node.joint_id].component_ids if p != component.id]
        if not self._has_anchor(component):
            # every node of it waits for something that rests on it: waiting would deadlock, so its nodes
            # wait only for the partners that can come before it is fixed
            partners = [p for p in partners if not self.rests_on(p.id, component.id)]
        if not all(p.prebuilt or at_least(p.state, State.ARRIVED) for p in partners):
            return
        if self._in_hands(component, node):
            return  # one robot handles a component at a time: its other nodes follow its first positioning
        self.build.node_position_published.add(node.id)
        names = ", ".join(p.id for p in partners)
        self._say(f"Node: {node.id} asks to be positioned: its connection components have arrived (ACC){': ' + names if names else ''}")
        predecessors = [self.build.transport_activity.get(c.id) for c in (component, *partners)]
        predecessors += self.build.position_activity.get(component.id, ())[:1]  # the row that put it in place
        self._publish(Task.POSITION, component, predecessors=predecessors, node=node)

    def _in_hands(self, component: Component, node) -> bool:
        """Whether another node of ``component`` is being positioned and none is fixed yet: the robot doing
        it holds the component, so ``node`` waits until the component stands in place (RCAN's robots hold
        a component one at a time; the schedule says so, and RCAN executes it in the same time)."""
        return component.id not in self.build.position_activity and any(
            other.id != node.id and other.id in self.build.node_position_published for other in component.connection_nodes)

    def rests_on(self, upper: str, lower: str) -> bool:
        """Does ``upper`` rest on ``lower``, directly or through what it rests on (so it cannot arrive first)?"""
        key = (upper, lower)
        if key not in self._rests_memo:
            supporters = self.smart.supporters.get(upper, ())
            self._rests_memo[key] = lower in supporters or any(self.rests_on(s, lower) for s in supporters)
        return self._rests_memo[key]

    def _has_anchor(self, component: Component) -> bool:
        """Per node: has ``component`` a node whose joint partners do not rest on it (a column's foot)? Once
        that node is fixed the component carries what rests on it, so its other nodes can wait for those."""
        if component.id not in self._anchor_memo:
            self._anchor_memo[component.id] = any(
                not any(self.rests_on(p, component.id) for p in self.smart.joints[n.joint_id].component_ids if p != component.id)
                for n in component.connection_nodes
            )
        return self._anchor_memo[component.id]

    def _finish_node_positioning(self, robot: SiteRobot, request: TaskRequest, started: float) -> None:
        """Per node: the node's position is fixed; it asks to be assembled; the first fixed node lets the
        component carry what rests on it."""
        component, name = self.smart.components[request.component_id], robot.spec.name
        node = self.smart.nodes[request.node_ids[0]]
        self._node_step(node, Event.FINISH_POSITIONING)
        self._say(f"Node: {node.id} position is fixed, {name} is free for next work")
        activity = self._record(Task.POSITION, component, f"{Task.POSITION.title} {node.id}", name, started,
                                request.predecessors, work=self._work(request, node.position[2], nodes=1))
        self.build.node_position_activity[node.id] = activity.id
        first = component.id not in self.build.position_activity
        self.build.position_activity[component.id] = self.build.position_activity.get(component.id, ()) + (activity.id,)
        if first:
            self._position_fixed(component, joints=False)
            for other in component.connection_nodes:  # they waited for the component to stand in place
                if other.id != node.id:
                    self._maybe_publish_node_positioning(other)
        self._maybe_publish_node_assembly(node)

    def _maybe_publish_node_assembly(self, node) -> None:
        """Per node: assemble ``node`` once its position is fixed and the prebuilt nodes assembled with it
        (a footing's anchors) are in place; the task carries their points too."""
        if node.id in self.build.node_assembly_published or node.id not in self.build.node_position_activity:
            return
        attached = [self.smart.nodes[n] for n in self.build.attached_nodes.get(node.id, ())]
        if not all(at_least(n.state, State.POSITION_FIXED) for n in attached):
            return  # a prebuilt component made later is not in place yet
        self.build.node_assembly_published.add(node.id)
        component = self.smart.components[node.component_id]
        predecessors = [self.build.node_position_activity[node.id]]
        for other in attached:
            self._node_step(other, Event.PUBLISH_ASSEMBLY)
            predecessors += self.build.position_activity.get(other.component_id, ())
        self._node_step(node, Event.PUBLISH_ASSEMBLY)
        self._publish(Task.ASSEMBLE, component, self.smart.joints[node.joint_id], predecessors=list(dict.fromkeys(predecessors)), node=node)
