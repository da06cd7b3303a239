"""Market-based multi-robot construction (thesis chapter 4): fleets and sites from YAML, task requests,
bids and evaluators (Open-RMF vocabulary), a SimPy discrete-event simulation of the build, its reports
and schedule CSV, baselines and an optimal CP-SAT schedule for comparison.

    from bimrobot.coordination import load_fleet, load_site, simulate
    result = simulate(smart_model, load_fleet("fleet2"), load_site(None))
"""

from bimrobot.coordination.fleet import Fleet, RobotSpec, Site, load_fleet, load_site
from bimrobot.coordination.market import EVALUATORS, BidNotice, BidProposal, TaskRequest
from bimrobot.coordination.simulation import SimulationResult, simulate

__all__ = [
    "EVALUATORS", "BidNotice", "BidProposal", "Fleet", "RobotSpec", "SimulationResult", "Site", "TaskRequest",
    "load_fleet", "load_site", "simulate",
]
