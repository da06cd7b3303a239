"""Errors a user can act on.

Every error raised for bad input is a :class:`BimrobotError` whose message is one sentence naming what
is wrong and where (file, line, key, element). The CLI prints it and exits with status 2.
"""


class BimrobotError(Exception):
    """Bad input or an unsatisfiable request; the message is meant for the user as is."""


class InputError(BimrobotError):
    """A file or option the user gave is missing, malformed or unsupported."""


class MissingExtraError(BimrobotError):
    """An optional dependency is not installed; the message names the extra to install."""


def require_extra(module: str, extra: str):
    """Import ``module`` or raise :class:`MissingExtraError` naming ``pip install 'bimrobot[extra]'``."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise MissingExtraError(
            f"this command needs the optional dependency '{module}': pip install 'bimrobot[{extra}]'"
        ) from exc
