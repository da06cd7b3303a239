"""The ``sim`` backend's class: the six features of :mod:`.drive`, :mod:`.arm` and :mod:`.gripper` on one
:class:`~.site.KinematicSite`."""

from __future__ import annotations

from pathlib import Path

from bimrobot.site.fleet import Fleet
from bimrobot.rcan.backends.interfaces import ExecutorBackend
from bimrobot.rcan.backends.sim import INFO
from bimrobot.rcan.backends.sim.arm import PositionForInstalling, PositionForPickingUp
from bimrobot.rcan.backends.sim.drive import MoveToComponent, Transport
from bimrobot.rcan.backends.sim.gripper import Install, PickUp
from bimrobot.rcan.backends.sim.site import KinematicSite


class SimBackend(MoveToComponent, PositionForPickingUp, PickUp, Transport, PositionForInstalling, Install,
                 ExecutorBackend):
    """Executor backend on the built-in :class:`KinematicSite` (see the package docstring)."""

    name = "sim"
    info = INFO

    def __init__(self, capabilities: Fleet, db_path: str | Path = ":memory:", time_scale: float = 0.0,
                 failure_probability: float = 0.0, seed: int = 0):
        self.site = KinematicSite(capabilities, db_path, time_scale, failure_probability, seed)

    def close(self) -> None:
        self.site.close()
