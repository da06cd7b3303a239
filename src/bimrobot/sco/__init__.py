"""Smart construction objects (thesis chapter 4): components and connection nodes that know their
state, publish their requirements and follow the thesis' state chart."""

from bimrobot.sco.build import SmartModel, build_smart_model
from bimrobot.sco.component import Component, ConnectionNode, ConstructionObject, Joint
from bimrobot.sco.states import Event, InvalidTransitionError, Requirement, State

__all__ = [
    "Component", "ConnectionNode", "ConstructionObject", "Event", "InvalidTransitionError", "Joint",
    "Requirement", "SmartModel", "State", "build_smart_model",
]
