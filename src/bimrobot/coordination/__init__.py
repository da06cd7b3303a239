"""Market-based multi-robot construction (thesis chapter 4): fleets and sites from YAML, task requests,
bids and evaluators (Open-RMF vocabulary), a SimPy discrete-event simulation of the build, its reports
and schedule CSV, baselines and an optimal CP-SAT schedule for comparison.

    from bimrobot.coordination import load_fleet, load_site, simulate
    result = simulate(smart_model, load_fleet("fleet2"), load_site(None))
"""

from __future__ import annotations

from bimrobot import lazy_names

_LAZY = {
    "Fleet": "bimrobot.site.fleet",
    "RobotSpec": "bimrobot.site.fleet",
    "Site": "bimrobot.site.fleet",
    "load_fleet": "bimrobot.site.fleet",
    "load_site": "bimrobot.site.fleet",
    "EVALUATORS": "bimrobot.coordination.market",
    "BidNotice": "bimrobot.coordination.market",
    "BidProposal": "bimrobot.coordination.market",
    "TaskRequest": "bimrobot.coordination.market",
    "SimulationResult": "bimrobot.coordination.simulation",
    "simulate": "bimrobot.coordination.simulation",
}
"""Public name -> the module that defines it, imported when the name is first used."""

__all__ = sorted(_LAZY)


# names load on first use (PEP 562), so that importing this package (as ``bimrobot.site.fleet``
# does) loads none of its heavy submodules
__getattr__, __dir__ = lazy_names(__name__, _LAZY)
