"""Executor backends behind one interface (:class:`~bimrobot.rcan.backends.interfaces.ExecutorBackend`).

The registry :data:`BACKENDS` names each backend's class as ``module:Class``; a backend's module is
imported only when it is chosen (``ros2`` needs ROS 2, ``mujoco`` needs MuJoCo). Adding a backend is one
module with one class and one line here.
"""

from __future__ import annotations

import importlib

from bimrobot.errors import InputError

#: backend name -> "module:Class" of its :class:`ExecutorBackend` subclass
BACKENDS: dict[str, str] = {
    "sim": "bimrobot.rcan.backends.sim:SimBackend",  # built-in kinematic robots (the default)
    "ros2": "bimrobot.rcan.backends.ros2.client:Ros2Backend",  # an rclpy action client on ConstructionActivity
    "mujoco": "bimrobot.rcan.backends.mujoco:MujocoBackend",  # physical robots in MuJoCo (bimrobot.physics)
}


def backend_class(name: str):
    """The backend class registered as ``name``; an unknown name is an InputError naming the choices."""
    if name not in BACKENDS:
        raise InputError(f"unknown RCAN backend {name!r} (expected one of: {', '.join(BACKENDS)})")
    module, _, cls = BACKENDS[name].partition(":")
    return getattr(importlib.import_module(module), cls)


def create_backend(name: str, capabilities, **options):
    """Instantiate backend ``name`` (a key of :data:`BACKENDS`) with its options."""
    return backend_class(name)(capabilities, **options)
