"""Reading configuration files (fleets, sites, capability tables, scenarios).

:func:`parse_yaml` is the one YAML reader. It keeps line numbers (every mapping it returns is a
:class:`LineDict`, which knows the line of each key) and refuses, before any loader sees them, numbers
that no physical quantity can take: NaN, infinities and magnitudes above :data:`MAX_MAGNITUDE`. Loaders
then check each key's own physical range with :func:`number`, whose message names the file, the key
and its line.
"""

from __future__ import annotations

import math
import re
from typing import Any

import yaml

from bimrobot.errors import InputError

#: No number in a configuration file may exceed this in magnitude (metres, seconds, kg, counts):
#: 1e9 s is 31 years, 1e9 m is beyond the Moon, 1e9 kg is a hundred Eiffel towers.
MAX_MAGNITUDE = 1e9


class LineDict(dict):
    """A mapping read from YAML that remembers the 1-based line of each key (``lines``) and its own."""

    lines: dict
    line: int | None = None


class _LineLoader(yaml.SafeLoader):
    """SafeLoader whose mappings are LineDicts and whose floats follow YAML 1.2 (``1e-3`` is a number)."""


# PyYAML follows YAML 1.1, where "1e-3" and "1e308" are strings (a float needs a dot and a signed
# exponent); YAML 1.2 and every user read them as numbers.
_LineLoader.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag != "tag:yaml.org,2002:float"]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_LineLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
        |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
        |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)


def _construct_mapping(loader: _LineLoader, node: yaml.MappingNode) -> LineDict:
    mapping = LineDict(loader.construct_mapping(node, deep=True))
    mapping.lines = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=True)
        try:
            if key in mapping.lines:  # YAML would silently keep the last value: refuse instead
                raise yaml.constructor.ConstructorError(
                    None, None, f"key '{key}' appears twice (first on line {mapping.lines[key]})", key_node.start_mark
                )
            mapping.lines[key] = key_node.start_mark.line + 1
        except TypeError:  # an unhashable key: yaml itself refuses it elsewhere
            pass
    mapping.line = node.start_mark.line + 1
    return mapping


_LineLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def line_of(mapping: Any, key: Any) -> str:
    """`` line N`` for ``key`` of a mapping read by :func:`parse_yaml`, or ``""`` when unknown."""
    line = getattr(mapping, "lines", {}).get(key) if isinstance(mapping, LineDict) else None
    return f" line {line}" if line else ""


def parse_yaml(text: str, source: str) -> Any:
    """Parse YAML ``text`` into plain data with :class:`LineDict` mappings.

    A syntax error, a NaN, an infinity or a number beyond :data:`MAX_MAGNITUDE` becomes an InputError
    naming ``source``, the key and the line.
    """
    try:
        data = yaml.load(text, Loader=_LineLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark else ""
        raise InputError(f"{source}{where}: not valid YAML ({getattr(exc, 'problem', None) or exc})") from None
    _check_numbers(data, source, key_path="", line="")
    return data


def _check_numbers(data: Any, source: str, key_path: str, line: str) -> None:
    """Refuse non-finite or absurdly large numbers anywhere in ``data``."""
    if isinstance(data, dict):
        for key, value in data.items():
            _check_numbers(value, source, f"{key_path}.{key}" if key_path else str(key), line_of(data, key) or line)
    elif isinstance(data, list):
        for index, value in enumerate(data):
            _check_numbers(value, source, f"{key_path}[{index}]", line)
    elif isinstance(data, (int, float)) and not isinstance(data, bool):
        _check_finite(data, f"{source}{line}: key '{key_path or '(top level)'}'")


def _check_finite(value: int | float, where: str) -> None:
    if isinstance(value, float) and math.isnan(value):
        raise InputError(f"{where} is NaN; expected a finite number")
    if isinstance(value, float) and math.isinf(value):
        raise InputError(f"{where} is infinite; expected a finite number")
    if abs(value) > MAX_MAGNITUDE:
        shown = f"{value:.3g}" if isinstance(value, float) else (str(value) if value < 10**20 else f"a {len(str(abs(value)))}-digit number")
        raise InputError(f"{where} is {shown}, beyond any physical value (at most {MAX_MAGNITUDE:g} in magnitude)")


def number(
    mapping: Any,
    key: Any,
    source: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_inclusive: bool = True,
    unit: str = "",
    default: float | None = None,
    where: str = "",
) -> float:
    """``mapping[key]`` as a finite float in ``[low, high]`` (or ``(low, high]``), else an InputError.

    The message names ``source``, ``where`` (e.g. ``robot 'Crane1'``), the key, its line, the range and
    the unit. A missing key gives ``default`` when one is given.
    """
    label = f"{source}{line_of(mapping, key)}: {where + ': ' if where else ''}key '{key}'"
    if key not in mapping:
        if default is not None:
            return float(default)
        raise InputError(f"{label} is missing")
    value = mapping[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{label} must be a number{' in ' + unit if unit else ''}, got {value!r}")
    _check_finite(value, label)
    too_low = low is not None and (value < low if low_inclusive else value <= low)
    if too_low or (high is not None and value > high):
        lower = "" if low is None else f"{'>=' if low_inclusive else '>'} {low:g}"
        upper = "" if high is None else f"<= {high:g}"
        bounds = " and ".join(b for b in (lower, upper) if b)
        raise InputError(f"{label} must be {bounds}{' ' + unit if unit else ''}, got {value:g}")
    return float(value)
