"""Executor backends behind one interface (:class:`~bimrobot.rcan.backends.interfaces.ExecutorBackend`).

``sim`` (built-in kinematic robots, the default) and ``ros2`` (an rclpy action client per activity on
the project's ``ConstructionActivity`` action). Only ``ros2`` imports ROS, and only when it is chosen.
"""

from __future__ import annotations

from bimrobot.errors import InputError

BACKENDS = ("sim", "ros2")


def create_backend(name: str, capabilities, **options):
    """Instantiate backend ``name`` (``sim`` or ``ros2``) with its options."""
    if name == "sim":
        from bimrobot.rcan.backends.sim import SimBackend

        return SimBackend(capabilities, **options)
    if name == "ros2":
        from bimrobot.rcan.backends.ros2 import Ros2Backend

        return Ros2Backend(capabilities, **options)
    raise InputError(f"unknown RCAN backend {name!r} (expected one of: {', '.join(BACKENDS)})")
