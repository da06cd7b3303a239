"""bimrobot: from a building information model (IFC) to robot worlds, smart construction objects,
the RCAN middle layer and DRL assembly planning.

Conventions used everywhere: lengths in metres, z up, masses in kg, times in seconds; an element is
identified by its IFC GlobalId.
"""

__version__ = "0.1.0"


def lazy_names(package: str, names: dict[str, str]):
    """PEP 562 hooks for a package whose public names live in heavier submodules: ``names`` maps a public
    name to the module that defines it, imported when the name is first used (and then kept in the
    package), so that importing a light submodule of the package loads none of the heavy ones.

    Use: ``__getattr__, __dir__ = lazy_names(__name__, _LAZY)`` in the package's ``__init__``."""
    import importlib
    import sys

    def __getattr__(name: str):
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted([*vars(sys.modules[package]), *names])

    return __getattr__, __dir__
