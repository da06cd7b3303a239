"""One declarative schema for the configuration files: fleets, sites, RCAN capability tables, scenarios.

A file's keys are declared once, as the fields of a frozen dataclass whose ``metadata`` holds the key's
:class:`Rule` (``field(metadata=rule(Quantity(0.01, 50.0, "m/s")))``): the kind of value, its physical
range and unit, its shape. The same declaration gives the allowed keys (:func:`keys_of`), the physical
ranges (:func:`quantities_of`) and the reading (:func:`read_keys`), so a range is written in one place and
a message cannot disagree with it.

Every rule reads one value at an :class:`At` (the file, the line, the entry and the key) and returns it
typed, or raises one :class:`~bimrobot.core.errors.InputError` of one sentence naming them. Two phrasings
exist, as the files had them: the *key* style of fleets, sites and capability tables
(``f.yaml line 4: robots[0] (T1): key 'speed' must be >= 0.01 and <= 50 m/s, got 90``) and the *path*
style of scenarios (``f.yaml line 9: reward.r0: must be a finite number >= -1e+06 and < 0, got 2``).

Mappings come from :func:`bimrobot.core.config.parse_yaml`, which knows each key's line and has already
refused NaN, infinities and magnitudes beyond any physical value.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields, replace
from typing import Any, Iterable

from bimrobot.core.config import MAX_MAGNITUDE, check_finite, check_keys, line_of
from bimrobot.core.errors import InputError

RULE = "bimrobot.core.schema"
"""The metadata key under which a dataclass field keeps its rule."""


def rule(r: "Rule") -> dict:
    """Field metadata declaring that the field is read from a file key by rule ``r``."""
    return {RULE: r}


@functools.lru_cache(maxsize=None)
def rules_of(schema: type) -> dict[str, "Rule"]:
    """The file keys of a schema dataclass and their rules, in declaration order (do not change it)."""
    return {f.name: f.metadata[RULE] for f in fields(schema) if RULE in f.metadata}


def keys_of(schema: type) -> tuple[str, ...]:
    """The keys a file (or one entry of it) may have: the schema's declared fields."""
    return tuple(rules_of(schema))


def quantities_of(schema: type) -> dict[str, tuple[float, float, str]]:
    """Each physical quantity of a schema: key -> (low, high, unit), both bounds as declared."""
    return {key: (r.low, r.high, r.unit) for key, r in rules_of(schema).items() if isinstance(r, Quantity)}


# ---------------------------------------------------------------- where a value is
@dataclass(slots=True)  # not frozen: built once per key read, and frozen dataclasses are slow to build
class At:
    """Where a value is, for messages: ``source`` (the file), ``line`` (`` line N`` or ""), ``where`` (the
    entry, e.g. ``robots[0] (T1)``) and ``key`` (e.g. ``speed`` or ``yard[1]``); ``path``: the scenario
    style (``reward.r0:``, ``where`` the path of the entry) instead of the key style (``key 'speed'``)."""

    source: str
    line: str = ""
    where: str = ""
    key: str = ""
    path: bool = False
    #: what a rule may need to know of the file read so far (a scenario's grid), else None
    context: Any = None

    def __str__(self) -> str:
        if self.path:  # scenario style: the key's path from the top of the file, e.g. targets.col2.cells
            return f"{self.source}{self.line}: {self.where + '.' if self.where and self.key else self.where}{self.key}:"
        return f"{self.source}{self.line}: {self.where + ': ' if self.where else ''}key '{self.key}'"

    def of(self, mapping: Any, key: Any) -> "At":
        """The place of ``mapping[key]``: its own line when known, else this one's."""
        return At(self.source, line_of(mapping, key) or self.line, self.where, str(key), self.path, self.context)

    def entry(self) -> "At":
        """This place as the entry whose own keys are read next (path style: ``reward`` -> ``reward.r0``)."""
        name = f"{self.where}.{self.key}" if self.where and self.key else self.where or self.key
        return replace(self, where=name, key="")

    def item(self, index: int) -> "At":
        """The place of item ``index`` of this list (key style: ``key[i]``; scenario messages name the list)."""
        return self if self.path else replace(self, key=f"{self.key}[{index}]")

    def fail(self, what: str) -> InputError:
        """One sentence: this place, then ``what`` (e.g. ``must be a number in kg, got 'heavy'``)."""
        return InputError(f"{self} {what}")

    def expected(self, key_style: str, path_style: str, value: Any) -> InputError:
        """A value of the wrong type: ``must be <key_style>`` or ``expected <path_style>``, then the value."""
        return self.fail(f"expected {path_style}, got {value!r}" if self.path else f"must be {key_style}, got {value!r}")


# ---------------------------------------------------------------- rules
class Rule:
    """How one key's value is read (subclasses are frozen dataclasses)."""

    def read(self, value: Any, at: At) -> Any:  # pragma: no cover - every rule overrides it
        raise NotImplementedError

    def describe(self) -> str:
        """What the key holds, in a few words for ``bimrobot fleet keys`` (e.g. ``0.01 to 50 m/s``)."""
        return ""


def _bound(value: float | None, inclusive: bool, below: bool) -> str:
    if value is None:
        return ""
    return f"{'>' if below else '<'}{'=' if inclusive else ''} {value:g}"


@dataclass(frozen=True)
class Quantity(Rule):
    """A physical number in ``unit`` within [low, high] (``low_open``/``high_open``: that bound excluded;
    None: unbounded); read as a float."""

    low: float | None
    high: float | None
    unit: str = ""
    low_open: bool = False
    high_open: bool = False

    def read(self, value: Any, at: At) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise at.expected(f"a number{' in ' + self.unit if self.unit else ''}", "a number", value)
        if not at.path and not (math.isfinite(value) and abs(value) <= MAX_MAGNITUDE):
            check_finite(value, str(at))
        too_low = self.low is not None and (value <= self.low if self.low_open else value < self.low)
        too_high = self.high is not None and (value >= self.high if self.high_open else value > self.high)
        if too_low or too_high or not math.isfinite(value):
            bounds = " and ".join(b for b in (_bound(self.low, not self.low_open, True),
                                              _bound(self.high, not self.high_open, False)) if b)
            if at.path:
                shown = f"{value:g}" if isinstance(value, float) or abs(value) < 10**15 else "a huge number"
                raise at.fail(f"must be a finite number {bounds}, got {shown}")
            raise at.fail(f"must be {bounds}{' ' + self.unit if self.unit else ''}, got {value:g}")
        return float(value)

    def describe(self) -> str:
        return f"{self.low:g} to {self.high:g} {self.unit}".strip()


@dataclass(frozen=True)
class Integer(Rule):
    """A whole number (a YAML integer, not a boolean) within [low, high] (None: unbounded); ``noun`` names
    it in messages."""

    low: int | None = None
    high: int | None = None
    noun: str = "an integer"

    def read(self, value: Any, at: At) -> int:
        span = f" from {self.low} to {self.high}" if self.low is not None and self.high is not None else ""
        if isinstance(value, bool) or not isinstance(value, int):
            raise at.expected(f"{self.noun}{span}", self.noun, value)
        if (self.low is not None and value < self.low) or (self.high is not None and value > self.high):
            raise at.fail(f"must be {self.noun}{span}, got {value!r}")
        return value


@dataclass(frozen=True)
class Choice(Rule):
    """One of ``values`` (strings); ``shown`` says them in messages (default ``one of a, b, c``)."""

    values: tuple[str, ...]
    shown: str = ""

    def read(self, value: Any, at: At) -> str:
        if not isinstance(value, str) or value not in self.values:
            shown = self.shown or f"one of {', '.join(self.values)}"
            raise at.expected(shown, shown, value)
        return value

    def describe(self) -> str:
        return " | ".join(self.values)


@dataclass(frozen=True)
class Flag(Rule):
    """true or false."""

    def read(self, value: Any, at: At) -> bool:
        if not isinstance(value, bool):
            raise at.expected("true or false", "true or false", value)
        return value


@dataclass(frozen=True)
class Text(Rule):
    """Any value, read as its text (a scenario's name and description)."""

    def read(self, value: Any, at: At) -> str:
        return str(value)


@dataclass(frozen=True)
class Name(Rule):
    """A non-empty string of printable characters (it goes into schedules, graphs and logs)."""

    def read(self, value: Any, at: At) -> str:
        if not isinstance(value, str) or not value.strip() or not value.isprintable():
            raise InputError(f"{at} must be a non-empty string of printable characters, got {value!r}"[:400])
        return value

    def describe(self) -> str:
        return "text"


@dataclass(frozen=True)
class Subset(Rule):
    """A non-empty list drawn from ``values``; read as a tuple in file order."""

    values: tuple[str, ...]

    def read(self, value: Any, at: At) -> tuple[str, ...]:
        if not isinstance(value, list) or not value or any(v not in self.values for v in value):
            raise at.fail(f"must be a list drawn from {list(self.values)}, got {value!r}")
        return tuple(value)

    def describe(self) -> str:
        return f"list of {', '.join(self.values)}"


@dataclass(frozen=True)
class Vector(Rule):
    """A list of ``counts`` items, each read by ``item`` at the same place; ``shape`` says it in messages
    (``[length, width] in metres``). Read as a tuple."""

    item: Rule
    shape: str
    counts: tuple[int, ...] = (2,)

    def read(self, value: Any, at: At) -> tuple:
        if not isinstance(value, (list, tuple)) or len(value) not in self.counts:
            raise at.expected(self.shape, self.shape, value)
        return tuple(self.item.read(v, at) for v in value)

    def describe(self) -> str:
        return f"{self.shape}, each {self.item.describe()}"

    def within(self, limit: float, counts: tuple[int, ...] | None = None, shape: str | None = None) -> "Vector":
        """This vector with items in [-limit, limit] (and other counts or shape when given)."""
        return replace(self, item=replace(self.item, low=-limit, high=limit), counts=counts or self.counts,
                       shape=shape or self.shape)


@dataclass(frozen=True)
class Coordinates(Rule):
    """``count`` numbers in metres, each in [low, high], said of the whole list (capability tables); a
    null value reads as None (as if absent)."""

    count: int
    low: float
    high: float

    def read(self, value: Any, at: At) -> tuple[float, ...] | None:
        if value is None:
            return None
        if not (isinstance(value, list) and len(value) == self.count
                and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
            raise at.fail(f"must be a list of {self.count} numbers in metres, got {value!r}")
        if not all(self.low <= v <= self.high and math.isfinite(v) for v in value):
            raise at.fail(f"must hold numbers between {self.low:g} and {self.high:g} m, got {value!r}")
        return tuple(float(v) for v in value)


@dataclass(frozen=True)
class Points(Rule):
    """A non-empty list of ``item`` values (``key[i]`` in messages); ``noun`` says the items."""

    item: Rule
    noun: str

    def read(self, value: Any, at: At) -> tuple:
        if not isinstance(value, list) or not value:
            raise at.fail(f"must be a non-empty list of {self.noun}")
        return tuple(self.item.read(v, at.item(i)) for i, v in enumerate(value))


@dataclass(frozen=True)
class Ordered(Rule):
    """``inner``'s pair read, then required to be [min, max] with min <= max."""

    inner: Rule

    def read(self, value: Any, at: At) -> tuple:
        pair = self.inner.read(value, at)
        if pair is not None and pair[0] > pair[1]:  # None: a capability table's null (as if absent)
            raise at.fail(f"must be [min, max] with min <= max, got {list(pair)}")
        return pair

    def describe(self) -> str:
        return f"{self.inner.describe()}, min <= max"


@dataclass(frozen=True)
class Custom(Rule):
    """A value read by ``reader(value, at)``: for what a module of its own validates (a work calendar);
    ``text`` describes it."""

    reader: Any
    text: str = ""

    def read(self, value: Any, at: At) -> Any:
        return self.reader(value, at)

    def describe(self) -> str:
        return self.text


# ---------------------------------------------------------------- reading a mapping
def read_key(mapping: Any, key: str, schema: type, at: At, default: Any = None) -> Any:
    """``mapping[key]`` (``default`` when absent) read by the rule ``schema`` declares for ``key``, at the
    key's line (else ``at``'s)."""
    return rules_of(schema)[key].read(mapping.get(key, default), at.of(mapping, key))


def read_keys(mapping: Any, schema: type, at: At, *, only: Iterable[str] | None = None, names=None,
              detail: str = "", required: Iterable[str] = (), needs: str = "", rules: dict | None = None) -> dict[str, Any]:
    """The values of ``mapping``'s keys declared by ``schema`` (or of ``only``, in that order), each read by
    its rule; a key absent from ``mapping`` is absent from the result.

    Refused first: an undeclared key (``detail`` ends that message, e.g. `` for a transport robot``),
    then a missing key of ``required`` (``needs`` ends that message). ``names``: the file's name of a
    declared key (an older format's), used for the keys and in messages; ``rules``: rules that replace
    declared ones for this reading (e.g. a wider range for homes in the model frame)."""
    rules = {**rules_of(schema), **rules} if rules else rules_of(schema)
    wanted = {key: names(key) if names else key for key in (rules if only is None else only)}  # key -> file's key
    check_keys(mapping, set(wanted.values()), at.source, at.where, detail=detail)
    for key in sorted(names(key) if names else key for key in required):
        if key not in mapping:
            raise InputError(f"{at.source}: {at.where + ': ' if at.where else ''}missing key '{key}'{needs}")
    return {key: rules[key].read(mapping[name], at.of(mapping, name)) for key, name in wanted.items() if name in mapping}
