"""States, requirements and events of smart construction objects (thesis chapter 4, fig. 4.2).

A component (and each of its connection nodes) passes through the three construction tasks of the
thesis, each with a waiting, a working and a done state:

=========== ===================================== ==================
task        states                                requirement
=========== ===================================== ==================
transport   OnYard -> InTransit -> Arrived        NeedToTransfer (Arrived: NeedToPosition)
positioning InLocation -> WorkingInPositioning    NeedToPosition
            -> PositionFixed                      (PositionFixed: NeedToAssemble)
assembly    WaitForAssembly -> WorkingInAssembly  NeedToAssemble
            -> Assembled                          (none)
=========== ===================================== ==================

The done state of one task hands over to the waiting state of the next when the component publishes
its next requirement (``Arrived -> InLocation``, ``PositionFixed -> WaitForAssembly``). A component is
Assembled only when all its connection nodes are; a node's state follows the same chart from
InLocation on. ``abort`` (a robot broke down mid-task) puts a working state back to its waiting state so
the task can be auctioned again.
"""

from __future__ import annotations

import enum

from bimrobot.core.errors import BimrobotError
from bimrobot.core.tasks import Requirement, State  # the names, said in core: every part names them


class Event(str, enum.Enum):
    """Events that move a component or node from one state to the next."""

    START_TRANSPORT = "start_transport"
    FINISH_TRANSPORT = "finish_transport"
    PUBLISH_POSITIONING = "publish_positioning"
    START_POSITIONING = "start_positioning"
    FINISH_POSITIONING = "finish_positioning"
    PUBLISH_ASSEMBLY = "publish_assembly"
    START_ASSEMBLY = "start_assembly"
    FINISH_ASSEMBLY = "finish_assembly"
    ABORT = "abort"

    def __str__(self) -> str:
        return self.value


#: State order: a later state means more construction progress.
STATE_ORDER: dict[State, int] = {state: index for index, state in enumerate(State)}

REQUIREMENT_OF: dict[State, Requirement] = {
    State.ON_YARD: Requirement.NEED_TO_TRANSFER,
    State.IN_TRANSIT: Requirement.NEED_TO_TRANSFER,
    State.ARRIVED: Requirement.NEED_TO_POSITION,
    State.IN_LOCATION: Requirement.NEED_TO_POSITION,
    State.WORKING_IN_POSITIONING: Requirement.NEED_TO_POSITION,
    State.POSITION_FIXED: Requirement.NEED_TO_ASSEMBLE,
    State.WAIT_FOR_ASSEMBLY: Requirement.NEED_TO_ASSEMBLE,
    State.WORKING_IN_ASSEMBLY: Requirement.NEED_TO_ASSEMBLE,
    State.ASSEMBLED: Requirement.NONE,
}

#: Component transitions. The assembly phase of a component follows its nodes (see
#: :meth:`bimrobot.sco.component.Component.on_node_assembled`).
COMPONENT_TRANSITIONS: dict[tuple[State, Event], State] = {
    (State.ON_YARD, Event.START_TRANSPORT): State.IN_TRANSIT,
    (State.IN_TRANSIT, Event.FINISH_TRANSPORT): State.ARRIVED,
    (State.IN_TRANSIT, Event.ABORT): State.ON_YARD,
    (State.ARRIVED, Event.PUBLISH_POSITIONING): State.IN_LOCATION,
    (State.IN_LOCATION, Event.START_POSITIONING): State.WORKING_IN_POSITIONING,
    (State.WORKING_IN_POSITIONING, Event.FINISH_POSITIONING): State.POSITION_FIXED,
    (State.WORKING_IN_POSITIONING, Event.ABORT): State.IN_LOCATION,
    (State.POSITION_FIXED, Event.PUBLISH_ASSEMBLY): State.WAIT_FOR_ASSEMBLY,
    (State.WAIT_FOR_ASSEMBLY, Event.PUBLISH_ASSEMBLY): State.WAIT_FOR_ASSEMBLY,
    (State.WORKING_IN_ASSEMBLY, Event.PUBLISH_ASSEMBLY): State.WORKING_IN_ASSEMBLY,
    (State.WAIT_FOR_ASSEMBLY, Event.START_ASSEMBLY): State.WORKING_IN_ASSEMBLY,
    (State.WORKING_IN_ASSEMBLY, Event.START_ASSEMBLY): State.WORKING_IN_ASSEMBLY,
    # FINISH_ASSEMBLY / ABORT in assembly: the target state depends on the other nodes (guarded).
    (State.WORKING_IN_ASSEMBLY, Event.FINISH_ASSEMBLY): State.WORKING_IN_ASSEMBLY,
    (State.WORKING_IN_ASSEMBLY, Event.ABORT): State.WORKING_IN_ASSEMBLY,
}

#: Connection-node transitions (a node is opened in InLocation when its component arrives).
NODE_TRANSITIONS: dict[tuple[State, Event], State] = {
    (State.IN_LOCATION, Event.START_POSITIONING): State.WORKING_IN_POSITIONING,
    (State.WORKING_IN_POSITIONING, Event.FINISH_POSITIONING): State.POSITION_FIXED,
    (State.WORKING_IN_POSITIONING, Event.ABORT): State.IN_LOCATION,
    (State.POSITION_FIXED, Event.PUBLISH_ASSEMBLY): State.WAIT_FOR_ASSEMBLY,
    (State.WAIT_FOR_ASSEMBLY, Event.START_ASSEMBLY): State.WORKING_IN_ASSEMBLY,
    (State.WORKING_IN_ASSEMBLY, Event.FINISH_ASSEMBLY): State.ASSEMBLED,
    (State.WORKING_IN_ASSEMBLY, Event.ABORT): State.WAIT_FOR_ASSEMBLY,
}


class InvalidTransitionError(BimrobotError):
    """An event that the state machine does not allow in the object's current state.

    Its arguments are the facts (kind, object id, state, event) and the message is made from them, so
    the error is rebuilt whole wherever it is re-created from ``args``: by :mod:`pickle` (a process
    pool) and by SimPy, which re-raises a failed process's error as ``type(error)(*error.args)``.
    """

    def __init__(self, kind: str, object_id: str, state: State, event: Event):
        super().__init__(kind, object_id, state, event)
        self.kind = kind
        self.object_id = object_id
        self.state = state
        self.event = event

    def __str__(self) -> str:
        allowed = sorted(str(e) for (s, e) in _table(self.kind) if s == self.state)
        return (
            f"{self.kind} {self.object_id} in state {self.state} cannot take event {self.event} "
            f"(allowed: {', '.join(allowed) or 'none'})"
        )


def _table(kind: str) -> dict[tuple[State, Event], State]:
    return NODE_TRANSITIONS if kind == "connection node" else COMPONENT_TRANSITIONS


def next_state(kind: str, object_id: str, state: State, event: Event) -> State:
    """The state after ``event``; raises :class:`InvalidTransitionError` naming object, state and event."""
    try:
        return _table(kind)[(state, event)]
    except KeyError:
        raise InvalidTransitionError(kind, object_id, state, event) from None


def at_least(state: State, reference: State) -> bool:
    """True when ``state`` is ``reference`` or a later construction state."""
    return STATE_ORDER[state] >= STATE_ORDER[reference]
