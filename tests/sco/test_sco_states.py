"""The thesis' state chart (fig. 4.2) for components and connection nodes."""

import pickle

import numpy as np
import pytest
import simpy

from bimrobot.sco import Component, ConnectionNode, Event, InvalidTransitionError, Requirement, State


def _column_with_nodes(n: int = 3) -> Component:
    column = Component(id="COL", name="W250x73", object_type="IfcColumn", ifc_class="IfcColumn", weight_kg=289.81)
    for k in range(n):
        column.connection_nodes.append(
            ConnectionNode(id=f"COL:K{k}", name="", object_type="ConnectionNode", component_id="COL", joint_id=f"K{k}")
        )
    return column


def test_component_walks_the_thesis_states_with_their_requirements():
    column = _column_with_nodes(1)
    seen = [(column.state, column.requirement)]
    column.update_state(Event.START_TRANSPORT)
    seen.append((column.state, column.requirement))
    column.update_state(Event.FINISH_TRANSPORT)
    seen.append((column.state, column.requirement))
    column.publish_positioning()
    seen.append((column.state, column.requirement))
    column.start_positioning()
    seen.append((column.state, column.requirement))
    column.finish_positioning()
    seen.append((column.state, column.requirement))
    node = column.connection_nodes[0]
    column.node_event(node, Event.PUBLISH_ASSEMBLY)
    seen.append((column.state, column.requirement))
    column.node_event(node, Event.START_ASSEMBLY)
    seen.append((column.state, column.requirement))
    column.node_event(node, Event.FINISH_ASSEMBLY)
    seen.append((column.state, column.requirement))
    assert [(str(s), str(r)) for s, r in seen] == [
        ("OnYard", "NeedToTransfer"),
        ("InTransit", "NeedToTransfer"),
        ("Arrived", "NeedToPosition"),
        ("InLocation", "NeedToPosition"),
        ("WorkingInPositioning", "NeedToPosition"),
        ("PositionFixed", "NeedToAssemble"),
        ("WaitForAssembly", "NeedToAssemble"),
        ("WorkingInAssembly", "NeedToAssemble"),
        ("Assembled", "None"),
    ]


def test_column_is_assembled_only_when_all_its_nodes_are():
    """Thesis 4.3: foot assembled, top nodes still waiting for beams -> column is WaitForAssembly."""
    column = _column_with_nodes(3)
    column.state = State.POSITION_FIXED
    for node in column.connection_nodes:
        node.state = State.POSITION_FIXED
    foot, top_a, top_b = column.connection_nodes
    column.node_event(foot, Event.PUBLISH_ASSEMBLY)
    column.node_event(foot, Event.START_ASSEMBLY)
    column.node_event(foot, Event.FINISH_ASSEMBLY)
    assert foot.state == State.ASSEMBLED and foot.requirement == Requirement.NONE
    assert top_a.state == State.POSITION_FIXED
    assert column.state == State.WAIT_FOR_ASSEMBLY and column.requirement == Requirement.NEED_TO_ASSEMBLE
    for node in (top_a, top_b):
        column.node_event(node, Event.PUBLISH_ASSEMBLY)
        column.node_event(node, Event.START_ASSEMBLY)
    column.node_event(top_a, Event.FINISH_ASSEMBLY)
    assert column.state == State.WORKING_IN_ASSEMBLY  # top_b still being bolted
    column.node_event(top_b, Event.FINISH_ASSEMBLY)
    assert column.state == State.ASSEMBLED


def test_invalid_transition_names_component_state_and_event():
    column = _column_with_nodes(1)
    with pytest.raises(InvalidTransitionError) as error:
        column.update_state(Event.FINISH_TRANSPORT)
    message = str(error.value)
    assert "component COL" in message and "OnYard" in message and "finish_transport" in message
    assert "start_transport" in message  # what is allowed instead


def _refused_transition() -> InvalidTransitionError:
    try:
        _column_with_nodes(1).update_state(Event.FINISH_TRANSPORT)
    except InvalidTransitionError as exc:
        return exc
    raise AssertionError("finish_transport on the yard was allowed")


def _facts(error: InvalidTransitionError) -> tuple:
    return (str(error), error.kind, error.object_id, error.state, error.event)


def test_invalid_transition_survives_pickling():
    # A process pool sends a worker's error back pickled: the user must still read what went wrong.
    original = _refused_transition()
    copy = pickle.loads(pickle.dumps(original))
    assert type(copy) is InvalidTransitionError
    assert _facts(copy) == _facts(original) == (
        str(original), "component", "COL", State.ON_YARD, Event.FINISH_TRANSPORT)
    assert str(copy).startswith("component COL in state OnYard cannot take event finish_transport")


def test_invalid_transition_survives_simpys_reraise():
    # SimPy re-raises a failed process's error as type(error)(*error.args) from env.run().
    column = _column_with_nodes(1)
    env = simpy.Environment()

    def arrive():
        yield env.timeout(5.0)
        column.update_state(Event.FINISH_TRANSPORT)  # never left the yard

    env.process(arrive())
    with pytest.raises(InvalidTransitionError) as error:
        env.run()
    original = error.value.__cause__
    assert isinstance(original, InvalidTransitionError) and error.value is not original
    assert _facts(error.value) == _facts(original)
    assert (error.value.object_id, error.value.state, error.value.event) == ("COL", State.ON_YARD, Event.FINISH_TRANSPORT)
    assert "allowed: start_transport" in str(error.value)


def test_node_event_is_refused_while_the_component_is_on_the_yard():
    column = _column_with_nodes(1)
    with pytest.raises(InvalidTransitionError, match="component COL in state OnYard cannot take event start_assembly"):
        column.node_event(column.connection_nodes[0], Event.START_ASSEMBLY)
    assert column.connection_nodes[0].state == State.IN_LOCATION  # nothing changed


def test_node_transition_error_names_the_node():
    node = ConnectionNode(id="A:B", name="", object_type="ConnectionNode")
    with pytest.raises(InvalidTransitionError, match="connection node A:B in state InLocation cannot take event finish_assembly"):
        node.update_state(Event.FINISH_ASSEMBLY)


def test_abort_returns_working_states_to_waiting_states():
    column = _column_with_nodes(2)
    column.update_state(Event.START_TRANSPORT)
    column.update_state(Event.ABORT)
    assert column.state == State.ON_YARD
    column.state = State.IN_LOCATION
    column.start_positioning()
    column.abort_positioning()
    assert column.state == State.IN_LOCATION
    assert all(n.state == State.IN_LOCATION for n in column.connection_nodes)


def test_component_without_nodes_is_assembled_once_positioned():
    slab = Component(id="SLAB", name="", object_type="IfcSlab", state=State.IN_LOCATION)
    slab.start_positioning()
    slab.finish_positioning()
    assert slab.state == State.ASSEMBLED
    assert np.allclose(slab.identify_current_position(), 0.0)
