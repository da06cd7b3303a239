"""Market-based multi-robot construction (thesis chapter 4): fleets and sites from YAML, task requests,
bids and evaluators (Open-RMF vocabulary), a SimPy discrete-event simulation of the build, its reports
and schedule CSV, baselines and an optimal CP-SAT schedule for comparison.

    from bimrobot.coordination import load_fleet, load_site, simulate
    result = simulate(smart_model, load_fleet("fleet2"), load_site(None))
"""

from __future__ import annotations

import importlib

_LAZY = {
    "Fleet": "bimrobot.coordination.fleet",
    "RobotSpec": "bimrobot.coordination.fleet",
    "Site": "bimrobot.coordination.fleet",
    "load_fleet": "bimrobot.coordination.fleet",
    "load_site": "bimrobot.coordination.fleet",
    "EVALUATORS": "bimrobot.coordination.market",
    "BidNotice": "bimrobot.coordination.market",
    "BidProposal": "bimrobot.coordination.market",
    "TaskRequest": "bimrobot.coordination.market",
    "SimulationResult": "bimrobot.coordination.simulation",
    "simulate": "bimrobot.coordination.simulation",
}
"""Public name -> the module that defines it, imported when the name is first used."""

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    """Import the submodule that defines ``name`` on first use (PEP 562), so that importing this package
    (as ``bimrobot.coordination.fleet`` does) loads none of its heavy submodules."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])
