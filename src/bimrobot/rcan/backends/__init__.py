"""Executor backends behind one interface (:class:`~bimrobot.rcan.backends.interfaces.ExecutorBackend`).

The registry :data:`BACKENDS` names each backend's folder, whose ``__init__`` declares the backend
(``INFO``, a :class:`~bimrobot.rcan.backends.info.BackendInfo`: its class, what it needs from a run, its
command-line options) without importing it; or, for a backend with no command-line options, its class
as ``module:Class`` (its ``info`` is read when it runs). A backend's class is imported only when it is
chosen (``ros2`` needs ROS 2, ``mujoco`` needs MuJoCo). Adding a backend is one folder and one line here
(docs/rcan.md, "Adding a backend").
"""

from __future__ import annotations

import importlib

from bimrobot.core.errors import InputError
from bimrobot.rcan.backends.info import BackendInfo, BackendOption

#: backend name -> its folder (a module declaring ``INFO``), or "module:Class" of its ExecutorBackend subclass
BACKENDS: dict[str, str] = {
    "sim": "bimrobot.rcan.backends.sim",  # built-in kinematic robots (the default)
    "ros2": "bimrobot.rcan.backends.ros2",  # an rclpy action client on ConstructionActivity
    "mujoco": "bimrobot.rcan.backends.mujoco",  # physical robots in MuJoCo (bimrobot.physics)
}

#: the backend a run uses unless told otherwise
DEFAULT_BACKEND = "sim"


def declaration(name: str) -> BackendInfo:
    """Backend ``name``'s declaration, without importing its class (a ``module:Class`` entry: the class
    alone, with no options); an unknown name is an InputError naming the choices."""
    if name not in BACKENDS:
        raise InputError(f"unknown RCAN backend {name!r} (expected one of: {', '.join(BACKENDS)})")
    entry = BACKENDS[name]
    return BackendInfo(entry) if ":" in entry else importlib.import_module(entry).INFO


def backend_class(name: str):
    """The backend class registered as ``name``; an unknown name is an InputError naming the choices."""
    module, _, cls = declaration(name).backend.partition(":")
    return getattr(importlib.import_module(module), cls)


def create_backend(name: str, capabilities, **options):
    """Instantiate backend ``name`` (a key of :data:`BACKENDS`) with its options."""
    return backend_class(name)(capabilities, **options)


def backend_options() -> tuple[BackendOption, ...]:
    """Every registered backend's command-line options, in registry order; an option two backends share
    (the same first flag, e.g. ``--time-scale``) once, as the first declares it."""
    options: dict[str, BackendOption] = {}
    for name in BACKENDS:
        for option in declaration(name).options:
            options.setdefault(option.flags[0], option)
    return tuple(options.values())


def backend_commands() -> list:
    """The functions that add the registered backends' own ``bimrobot rcan`` sub-commands (each called
    with the sub-parsers), in registry order."""
    functions = []
    for name in BACKENDS:
        for entry in declaration(name).commands:
            module, _, function = entry.partition(":")
            functions.append(getattr(importlib.import_module(module), function))
    return functions
