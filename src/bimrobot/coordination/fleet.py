"""Robot fleets (thesis Table 4.1) and the construction site (fig. 4.11), read from YAML and validated.

Units: speed m/s, carry_load and payload kg, platform_size and reach m, times s, positions m (site
frame, z up). A robot's kind says which construction tasks it can bid for:

================== =========================================================================
kind               tasks and the keys it needs
================== =========================================================================
transport          transport: speed, carry_load, platform_size [length, width]
positioning        position: speed, payload, reach, time_per_node
assembly           assemble: speed, reach, time_per_point (methods: [bolt, weld] by default)
mobile_manipulator all three: every key above
================== =========================================================================

Optional keys: ``load_time`` and ``unload_time`` (s, transport), ``methods`` (assembly), ``home`` [x, y].

Every number must be finite and physically plausible (:data:`RANGES`); a value outside its range is
refused before anything is simulated, naming the file, the robot, the key and its line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from bimrobot.config import line_of, number, parse_yaml
from bimrobot.errors import InputError

ACTIVITIES = ("transport", "position", "assemble")
KIND_ACTIVITIES = {
    "transport": ("transport",),
    "positioning": ("position",),
    "assembly": ("assemble",),
    "mobile_manipulator": ACTIVITIES,
}
ACTIVITY_KEYS = {
    "transport": ("speed", "carry_load", "platform_size"),
    "position": ("speed", "payload", "reach", "time_per_node"),
    "assemble": ("speed", "reach", "time_per_point"),
}
OPTIONAL_KEYS = ("load_time", "unload_time", "methods", "home")
BUILTIN_FLEETS = ("fleet1", "fleet2", "site-crane")
METHODS = ("bolt", "weld")

#: Physical range of each robot key: (low, high, unit); low is exclusive except for handling times,
#: which may be 0. Speeds: the fastest site vehicle is far below 50 m/s (180 km/h); loads: the largest
#: mobile cranes lift about 1,200 t, so 1e6 kg; a reach or platform beyond 300 m / 100 m is a typo;
#: one handling step longer than a day (86,400 s) is not a step.
RANGES = {
    "speed": (0.0, 50.0, "m/s"),
    "carry_load": (0.0, 1e6, "kg"),
    "payload": (0.0, 1e6, "kg"),
    "reach": (0.0, 300.0, "m"),
    "time_per_node": (0.0, 86_400.0, "s"),
    "time_per_point": (0.0, 86_400.0, "s"),
    "load_time": (0.0, 86_400.0, "s"),
    "unload_time": (0.0, 86_400.0, "s"),
}
#: Platform length and width (m).
PLATFORM_RANGE_M = (0.0, 100.0)
#: Site positions (yard, homes, construction area) within this many metres of the site origin; the
#: model offset may be as large as projected map coordinates (UTM northings reach 1e7 m).
SITE_COORDINATE_LIMIT_M = 1e6
OFFSET_LIMIT_M = 2e7


@dataclass(frozen=True)
class RobotSpec:
    """One robot: what it can do and how fast (units in the module docstring)."""

    name: str
    kind: str
    speed: float
    carry_load: float = 0.0
    platform_size: tuple[float, float] = (0.0, 0.0)
    payload: float = 0.0
    reach: float = 0.0
    time_per_node: float = 0.0
    time_per_point: float = 0.0
    load_time: float = 0.0
    unload_time: float = 0.0
    methods: tuple[str, ...] = METHODS
    home: tuple[float, float] | None = None

    @property
    def activities(self) -> tuple[str, ...]:
        return KIND_ACTIVITIES[self.kind]

    def can(self, activity: str) -> bool:
        return activity in KIND_ACTIVITIES[self.kind]


@dataclass(frozen=True)
class Fleet:
    name: str
    robots: tuple[RobotSpec, ...]
    source: str

    def by_activity(self, activity: str) -> list[RobotSpec]:
        return [r for r in self.robots if r.can(activity)]


def _number_in(value, label: str, low: float, high: float, unit: str, low_inclusive: bool = False) -> float:
    """``value`` as a finite float in (low, high] (or [low, high]); ``label`` names file, key and line."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{label} must be a number in {unit}, got {value!r}")
    if not math.isfinite(value):
        raise InputError(f"{label} must be a finite number in {unit}, got {value!r}")
    if (value < low if low_inclusive else value <= low) or value > high:
        raise InputError(f"{label} must be {'>=' if low_inclusive else '>'} {low:g} and <= {high:g} {unit}, got {value:g}")
    return float(value)


def _point(mapping, key, source: str, where: str = "", limit: float = SITE_COORDINATE_LIMIT_M, item: int | None = None) -> tuple[float, float]:
    """``mapping[key]`` (or its item ``item``) as [x, y] metres, each within +-``limit``."""
    shown = key if item is None else f"{key}[{item}]"
    label = f"{source}{line_of(mapping, key)}: {where + ': ' if where else ''}key '{shown}'"
    value = mapping[key] if item is None else mapping[key][item]
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise InputError(f"{label} must be a pair of numbers [x, y] in metres, got {value!r}")
    x, y = (_number_in(v, label, -limit, limit, "m", low_inclusive=True) for v in value)
    return (x, y)


def _robot(entry, source: str, index: int) -> RobotSpec:
    where = f"robots[{index}]"
    if not isinstance(entry, dict):
        raise InputError(f"{source}: {where} must be a mapping with name, kind, speed, ..., got {entry!r}")
    name = entry.get("name")
    if not isinstance(name, str) or not name.strip():
        raise InputError(f"{source}{line_of(entry, 'name')}: {where}: key 'name' must be a non-empty string")
    where = f"{where} ({name})"
    kind = entry.get("kind")
    if kind not in KIND_ACTIVITIES:
        raise InputError(f"{source}{line_of(entry, 'kind')}: {where}: key 'kind' must be one of {', '.join(KIND_ACTIVITIES)}, got {kind!r}")
    needed = {key for activity in KIND_ACTIVITIES[kind] for key in ACTIVITY_KEYS[activity]}
    allowed = needed | set(OPTIONAL_KEYS) | {"name", "kind"}
    for key in entry:
        if key not in allowed:
            raise InputError(f"{source}{line_of(entry, key)}: {where}: unknown key '{key}' for a {kind} robot (allowed: {', '.join(sorted(allowed))})")
    for key in sorted(needed):
        if key not in entry:
            raise InputError(f"{source}: {where}: missing key '{key}' (a {kind} robot needs {', '.join(sorted(needed))})")
    values: dict = {"name": name, "kind": kind}
    for key in sorted((needed - {"platform_size"}) | ({"load_time", "unload_time"} & set(entry))):
        low, high, unit = RANGES[key]
        values[key] = number(entry, key, source, low=low, high=high, low_inclusive=key in ("load_time", "unload_time"), unit=unit, where=where)
    if "platform_size" in needed:
        size = entry["platform_size"]
        label = f"{source}{line_of(entry, 'platform_size')}: {where}: key 'platform_size'"
        if not isinstance(size, (list, tuple)) or len(size) != 2:
            raise InputError(f"{label} must be [length, width] in metres, got {size!r}")
        length, width = (_number_in(v, label, *PLATFORM_RANGE_M, "m") for v in size)
        values["platform_size"] = (max(length, width), min(length, width))
    if "methods" in entry:
        methods = entry["methods"]
        if not isinstance(methods, list) or not methods or any(m not in METHODS for m in methods):
            raise InputError(f"{source}{line_of(entry, 'methods')}: {where}: key 'methods' must be a list drawn from {list(METHODS)}, got {methods!r}")
        values["methods"] = tuple(methods)
    if "home" in entry:
        values["home"] = _point(entry, "home", source, where)
    return RobotSpec(**values)


def fleet_from_dict(data, source: str) -> Fleet:
    """A validated Fleet from parsed YAML; errors name ``source`` and the key."""
    if not isinstance(data, dict) or "robots" not in data:
        raise InputError(f"{source}: expected a mapping with a 'robots' list")
    robots = data["robots"]
    if not isinstance(robots, list) or not robots:
        raise InputError(f"{source}: key 'robots' must be a non-empty list")
    extra = set(data) - {"name", "robots"}
    if extra:
        raise InputError(f"{source}: unknown top-level key '{sorted(extra)[0]}' (allowed: name, robots)")
    specs = tuple(_robot(entry, source, i) for i, entry in enumerate(robots))
    names = [r.name for r in specs]
    duplicate = next((n for n in names if names.count(n) > 1), None)
    if duplicate:
        raise InputError(f"{source}: robot name '{duplicate}' is used twice")
    return Fleet(name=str(data.get("name") or Path(source).stem), robots=specs, source=source)


def load_fleet(spec: str | Path) -> Fleet:
    """A built-in fleet ("fleet1", "fleet2", "site-crane") or a fleet YAML file, validated."""
    if str(spec) in BUILTIN_FLEETS:
        text = resources.files("bimrobot.coordination").joinpath("fleets", f"{spec}.yaml").read_text()
        source = f"built-in fleet {spec}"
    else:
        path = Path(spec)
        if not path.is_file():
            raise InputError(f"fleet {spec!r} is neither a built-in fleet ({', '.join(BUILTIN_FLEETS)}) nor a file")
        text = path.read_text()
        source = str(path)
    return fleet_from_dict(parse_yaml(text, source), source)


@dataclass(frozen=True)
class Site:
    """Where things are on the site (metres, site frame).

    ``yard``: component pick-up positions, used in turn; ``robot_home``: robot start positions, used in
    turn (a robot's own ``home`` wins); ``construction_area``: [[xmin, ymin], [xmax, ymax]], the building
    is centred in it unless ``model_offset`` [dx, dy] (model frame -> site frame) is given.
    ``idle_robots``: "stay" (a robot with nothing to do waits where it finished; default) or "yard" (it
    drives back to the nearest yard position, as in the thesis, and can be called away on the way).
    """

    yard: tuple[tuple[float, float], ...]
    robot_home: tuple[tuple[float, float], ...]
    construction_area: tuple[tuple[float, float], tuple[float, float]]
    model_offset: tuple[float, float] | None = None
    idle_robots: str = "stay"
    source: str = "default site (thesis fig. 4.11)"

    def offset_for(self, model_min_xy: np.ndarray, model_max_xy: np.ndarray) -> np.ndarray:
        """Translation (x, y) from the model frame to the site frame, metres."""
        if self.model_offset is not None:
            return np.array(self.model_offset, dtype=float)
        (x0, y0), (x1, y1) = self.construction_area
        area_centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        return area_centre - (np.asarray(model_min_xy) + np.asarray(model_max_xy)) / 2


def site_from_dict(data, source: str) -> Site:
    if not isinstance(data, dict):
        raise InputError(f"{source}: expected a mapping with yard, robot_home and construction_area")
    allowed = {"yard", "robot_home", "construction_area", "model_offset", "idle_robots"}
    extra = set(data) - allowed
    if extra:
        raise InputError(f"{source}: unknown key '{sorted(extra)[0]}' (allowed: {', '.join(sorted(allowed))})")
    default = default_site()
    values = {}
    for key in ("yard", "robot_home"):
        if key in data:
            points = data[key]
            if not isinstance(points, list) or not points:
                raise InputError(f"{source}{line_of(data, key)}: key '{key}' must be a non-empty list of [x, y] positions in metres")
            values[key] = tuple(_point(data, key, source, item=i) for i in range(len(points)))
        else:
            values[key] = getattr(default, key)
    if "construction_area" in data:
        area = data["construction_area"]
        if not isinstance(area, list) or len(area) != 2:
            raise InputError(f"{source}{line_of(data, 'construction_area')}: key 'construction_area' must be [[xmin, ymin], [xmax, ymax]] in metres")
        low, high = (_point(data, "construction_area", source, item=i) for i in range(2))
        if not (low[0] < high[0] and low[1] < high[1]):
            raise InputError(f"{source}{line_of(data, 'construction_area')}: key 'construction_area' must have xmin < xmax and ymin < ymax, got {area!r}")
        values["construction_area"] = (low, high)
    else:
        values["construction_area"] = default.construction_area
    if "model_offset" in data:
        values["model_offset"] = _point(data, "model_offset", source, limit=OFFSET_LIMIT_M)
    if "idle_robots" in data:
        if data["idle_robots"] not in ("stay", "yard"):
            raise InputError(f"{source}{line_of(data, 'idle_robots')}: key 'idle_robots' must be 'stay' or 'yard', got {data['idle_robots']!r}")
        values["idle_robots"] = data["idle_robots"]
    return Site(**values, source=source)


def default_site() -> Site:
    """The site of fig. 4.11: yard at x = 12.5 m, robot homes at x = 18.5 m, y = 4, 6, 8, 11 m."""
    return Site(
        yard=((12.5, 4.0), (12.5, 6.0), (12.5, 8.0), (12.5, 11.0)),
        robot_home=((18.5, 4.0), (18.5, 6.0), (18.5, 8.0), (18.5, 11.0)),
        construction_area=((3.0, 1.5), (10.5, 8.0)),
    )


def load_site(path: str | Path | None) -> Site:
    """The site YAML at ``path`` (missing keys take fig. 4.11's values), or the default site."""
    if path is None:
        return default_site()
    path = Path(path)
    if not path.is_file():
        raise InputError(f"site file {str(path)!r} does not exist")
    return site_from_dict(parse_yaml(path.read_text(), str(path)), str(path))
