"""Reading configuration files (fleets, sites, capability tables, scenarios).

The one reader of fleet (:mod:`bimrobot.site.fleet`), site (:mod:`bimrobot.site.site`), capability
(:mod:`bimrobot.rcan.generation`) and scenario (:mod:`bimrobot.assembly.scenario`) files:

- :func:`read_yaml_file` / :func:`parse_yaml` read YAML keeping line numbers (every mapping is a
  :class:`LineDict`, which knows the line of each key) and refuse, before any loader sees them, numbers
  that no physical quantity can take: NaN, infinities and magnitudes above :data:`MAX_MAGNITUDE`;
- :func:`check_keys` refuses a key a mapping may not have, at every level of a file.

What each key may hold (its type, physical range and unit) is declared once, in :mod:`bimrobot.core.schema`.

Every message is one sentence naming the file, the line, the key and what was expected.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import yaml

from bimrobot.core.errors import InputError

#: No number in a configuration file may exceed this in magnitude (metres, seconds, kg, counts):
#: 1e9 s is 31 years, 1e9 m is beyond the Moon, 1e9 kg is a hundred Eiffel towers.
MAX_MAGNITUDE = 1e9
#: Longest time (s) any input may give: a schedule's span, a breakdown, a repair, a solver's limit.
MAX_SECONDS = MAX_MAGNITUDE


class LineDict(dict):
    """A mapping read from YAML that remembers the 1-based line of each key (``lines``) and its own."""

    lines: dict
    line: int | None = None


def _line_loader(base: type) -> type:
    """A safe loader on ``base`` whose mappings are LineDicts and whose floats follow YAML 1.2."""
    loader = type(f"_Line{base.__name__}", (base,), {})
    # PyYAML follows YAML 1.1, where "1e-3" and "1e308" are strings (a float needs a dot and a signed
    # exponent); YAML 1.2 and every user read them as numbers.
    loader.yaml_implicit_resolvers = {
        first: [(tag, regexp) for tag, regexp in resolvers if tag != "tag:yaml.org,2002:float"]
        for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
    }
    loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_1_2, list("-+0123456789."))
    loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
    return loader


_FLOAT_1_2 = re.compile(
    r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
    |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""",
    re.X,
)


def _construct_mapping(loader: yaml.SafeLoader, node: yaml.MappingNode) -> LineDict:
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


#: ``LOADER`` is the one :func:`parse_yaml` uses: libyaml's parser (``CSafeLoader``, which keeps every
#: node's line for the messages) when PyYAML was built with it, else PyYAML's pure-Python one
#: (``PURE_PYTHON_LOADER``), about 4 times slower on a large capability table (bench/config.py).
PURE_PYTHON_LOADER = _line_loader(yaml.SafeLoader)
LOADER = _line_loader(yaml.CSafeLoader) if getattr(yaml, "__with_libyaml__", False) else PURE_PYTHON_LOADER


def read_yaml_file(path: str | Path, what: str) -> Any:
    """The YAML file at ``path`` parsed by :func:`parse_yaml`; ``what`` (e.g. ``"site file"``) names
    it when it is missing, unreadable or not UTF-8 text."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{what} {str(path)!r} does not exist")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the {what} {path}: {getattr(exc, 'strerror', None) or exc}") from None
    return parse_yaml(text, str(path))


def check_keys(mapping: Any, allowed, source: str, where: str = "", detail: str = "") -> None:
    """Refuse a key of ``mapping`` that is not in ``allowed``: one sentence naming ``source``, the key's
    line, ``where`` (e.g. ``robots[0] (Crane1)``), the key, ``detail`` (e.g. `` for a transport robot``)
    and the allowed keys."""
    for key in mapping:
        if key not in allowed:
            raise InputError(
                f"{source}{line_of(mapping, key)}: {where + ': ' if where else ''}unknown key '{key}'{detail} "
                f"(allowed: {', '.join(sorted(str(k) for k in allowed))})"
            )


def line_of(mapping: Any, key: Any) -> str:
    """`` line N`` for ``key`` of a mapping read by :func:`parse_yaml`, or ``""`` when unknown."""
    line = getattr(mapping, "lines", {}).get(key) if isinstance(mapping, LineDict) else None
    return f" line {line}" if line else ""


def parse_yaml(text: str, source: str, *, loader: type | None = None) -> Any:
    """Parse YAML ``text`` into plain data with :class:`LineDict` mappings.

    A syntax error, a NaN, an infinity or a number beyond :data:`MAX_MAGNITUDE` becomes an InputError
    naming ``source``, the key and the line. ``loader``: :data:`LOADER` (default) or
    :data:`PURE_PYTHON_LOADER` (for comparison, bench/config.py).
    """
    reader = (loader or LOADER)(text)
    try:
        node = reader.get_single_node()
        return None if node is None else _Builder(reader, source).build(node, "", "")
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark else ""
        problem = " ".join(str(getattr(exc, "problem", None) or exc).split())  # one line (a ReaderError has several)
        raise InputError(f"{source}{where}: not valid YAML ({problem})") from None
    finally:
        reader.dispose()


_STR, _SEQ, _MAP, _MERGE = (f"tag:yaml.org,2002:{name}" for name in ("str", "seq", "map", "merge"))


class _Builder:
    """Plain data from a composed YAML node tree: what ``yaml.load`` with a line loader returns, but
    built in one pass that also checks every number (``yaml.load`` spends most of its time in
    PyYAML's generic constructor, even on libyaml's parser)."""

    def __init__(self, loader: yaml.SafeLoader, source: str):
        self.loader = loader
        self.source = source
        self.scalars = loader.yaml_constructors
        self.built: dict[int, Any] = {}  # node id -> object: an alias gives the same object again

    def build(self, node: yaml.Node, key_path: str, line: str) -> Any:
        """The object of ``node``; ``key_path`` and ``line`` (`` line N``) name it in messages."""
        if isinstance(node, yaml.ScalarNode):
            if node.tag == _STR:
                return node.value
            value = (self.scalars.get(node.tag) or self.scalars[None])(self.loader, node)
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                check_finite(value, f"{self.source}{line}: key '{key_path or '(top level)'}'")
            return value
        if id(node) in self.built:
            return self.built[id(node)]
        if isinstance(node, yaml.SequenceNode) and node.tag == _SEQ:
            items = self.built[id(node)] = []
            items.extend(self.build(item, f"{key_path}[{index}]", line) for index, item in enumerate(node.value))
            return items
        if isinstance(node, yaml.MappingNode) and node.tag == _MAP:
            return self._mapping(node, key_path, line)
        return self.loader.construct_object(node, deep=True)  # !!set, !!omap, ...: PyYAML's own

    def _mapping(self, node: yaml.MappingNode, key_path: str, line: str) -> LineDict:
        if any(key.tag == _MERGE for key, _ in node.value):
            self.loader.flatten_mapping(node)  # "<<: *base" merges base's keys in first
        mapping = self.built[id(node)] = LineDict()
        mapping.lines = {}
        mapping.line = node.start_mark.line + 1
        for key_node, value_node in node.value:
            key = self.build(key_node, key_path, line)
            key_line = key_node.start_mark.line + 1
            try:
                first = mapping.lines.get(key)
            except TypeError:
                raise yaml.constructor.ConstructorError(
                    "while constructing a mapping", node.start_mark, "found unhashable key", key_node.start_mark
                ) from None
            if first is not None:  # YAML would silently keep the last value: refuse instead
                raise yaml.constructor.ConstructorError(
                    None, None, f"key '{key}' appears twice (first on line {first})", key_node.start_mark
                )
            mapping.lines[key] = key_line
            path = f"{key_path}.{key}" if key_path else str(key)
            mapping[key] = self.build(value_node, path, f" line {key_line}")
        return mapping


def check_finite(value: int | float, where: str) -> None:
    """Refuse NaN, infinities and magnitudes beyond :data:`MAX_MAGNITUDE`; ``where`` names the value."""
    if isinstance(value, float) and math.isnan(value):
        raise InputError(f"{where} is NaN; expected a finite number")
    if isinstance(value, float) and math.isinf(value):
        raise InputError(f"{where} is infinite; expected a finite number")
    if abs(value) > MAX_MAGNITUDE:
        shown = f"{value:.3g}" if isinstance(value, float) else (str(value) if value < 10**20 else f"a {len(str(abs(value)))}-digit number")
        raise InputError(f"{where} is {shown}, beyond any physical value (at most {MAX_MAGNITUDE:g} in magnitude)")
