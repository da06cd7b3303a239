"""Smart construction objects (thesis chapter 4): components and connection nodes that know their
state, publish their requirements and follow the thesis' state chart."""

from __future__ import annotations

from bimrobot import lazy_names

_LAZY = {
    "SmartModel": "bimrobot.sco.build",
    "build_smart_model": "bimrobot.sco.build",
    "Component": "bimrobot.sco.component",
    "ConnectionNode": "bimrobot.sco.component",
    "ConstructionObject": "bimrobot.sco.component",
    "Joint": "bimrobot.sco.component",
    "Event": "bimrobot.sco.states",
    "InvalidTransitionError": "bimrobot.sco.states",
    "Requirement": "bimrobot.sco.states",
    "State": "bimrobot.sco.states",
}
"""Public name -> the module that defines it, imported when the name is first used."""

__all__ = sorted(_LAZY)


# names load on first use (PEP 562), so that importing this package (as ``bimrobot.sco.timing`` does) loads
# none of its heavy submodules
__getattr__, __dir__ = lazy_names(__name__, _LAZY)
