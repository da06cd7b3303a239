"""RCAN: Robot Construction Action Nodes, the middle layer between smart components and robots
(thesis chapter 5). See docs/rcan.md.

- :mod:`~bimrobot.rcan.activities`: the six robot construction activities, poses, :class:`RcanActivity`
- :mod:`~bimrobot.rcan.fleet`: the fleet placed in the model frame, Table 5.2
- :mod:`~bimrobot.rcan.generation`: task allocator, node generator
- :mod:`~bimrobot.rcan.node`: the RCAN node
- :mod:`~bimrobot.rcan.broker`: receiver, sender, router; in-process and Redis streams
- :mod:`~bimrobot.rcan.executor`: the robot executor service
- :mod:`~bimrobot.rcan.backends`: executor backends (``sim``, ``ros2``) behind one interface
- :mod:`~bimrobot.rcan.state_manager`: state machine updates, retries, escalation, SQLite journal
- :mod:`~bimrobot.rcan.system`: everything wired together, :func:`run_plan`
- :mod:`~bimrobot.rcan.plans`: plans from a schedule CSV and the thesis' three experiments
- :mod:`~bimrobot.rcan.observers`: keep the construction graph live
"""

import importlib

_EXPORTS = {
    "ActivityKind": "activities", "Pose": "activities", "RcanActivity": "activities",
    "NodeGenerator": "generation", "TaskAllocator": "generation",
    "load_capabilities": "generation", "RcanNode": "node", "experiment": "plans",
    "plan_from_schedule": "plans", "RcanSystem": "system", "RunReport": "system", "run_plan": "system",
}
__all__ = list(_EXPORTS)


def __getattr__(name: str):
    """Import on first use, so ``bimrobot --help`` does not load RCAN."""
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"bimrobot.rcan.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'bimrobot.rcan' has no attribute {name!r}")
