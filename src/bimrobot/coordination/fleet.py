"""Robot fleets (thesis Table 4.1), read from YAML and validated (the site is :mod:`bimrobot.site`).

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

from dataclasses import dataclass
from importlib import resources
from pathlib import Path


from bimrobot.config import check_keys, line_of, number, parse_yaml, read_yaml_file
from bimrobot.errors import InputError
from bimrobot.site import Site, default_site, load_site  # noqa: F401 (re-exported: the site once lived here)
from bimrobot.site import number_in as _number_in, point as _point
from bimrobot.tasks import KIND_TASKS, TASKS, Task

#: The tasks (:class:`bimrobot.tasks.Task`) and, per robot kind, the tasks its robots bid for.
ACTIVITIES = TASKS
KIND_ACTIVITIES = KIND_TASKS
#: The keys a robot needs for each task it does.
ACTIVITY_KEYS = {
    Task.TRANSPORT: ("speed", "carry_load", "platform_size"),
    Task.POSITION: ("speed", "payload", "reach", "time_per_node"),
    Task.ASSEMBLE: ("speed", "reach", "time_per_point"),
}
OPTIONAL_KEYS = ("load_time", "unload_time", "methods", "home")
BUILTIN_FLEETS = ("fleet1", "fleet2", "site-crane")
METHODS = ("bolt", "weld")

#: Physical range of each robot key: (low, high, unit), both bounds inclusive. Upper bounds: the fastest
#: site vehicle is far below 50 m/s (180 km/h); the largest mobile cranes lift about 1,200 t, so 1e6
#: kg; a reach or platform beyond 300 m / 100 m is a typo; one handling step longer than a day
#: (86,400 s) is not a step. Lower bounds, so that no time a simulation derives from them overflows
#: what a schedule holds (1e9 s): 0.01 m/s (36 m an hour, slower than any site robot crawls; a 1e-300
#: m/s robot made a 302-digit makespan) crosses a 10 km site in 11.6 days; 1 kg is less than any
#: building part or tool a robot carries; a reach under 0.1 m reaches nothing; a node or assembly point
#: takes at least 0.1 s; loading and unloading may take no time at all.
RANGES = {
    "speed": (0.01, 50.0, "m/s"),
    "carry_load": (1.0, 1e6, "kg"),
    "payload": (1.0, 1e6, "kg"),
    "reach": (0.1, 300.0, "m"),
    "time_per_node": (0.1, 86_400.0, "s"),
    "time_per_point": (0.1, 86_400.0, "s"),
    "load_time": (0.0, 86_400.0, "s"),
    "unload_time": (0.0, 86_400.0, "s"),
}
#: Platform length and width (m), both inclusive: 0.1 m is a tray, 100 m longer than any transport deck.
PLATFORM_RANGE_M = (0.1, 100.0)


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
    def activities(self) -> tuple[Task, ...]:
        return KIND_TASKS[self.kind]

    def can(self, activity: Task | str) -> bool:
        return activity in KIND_TASKS[self.kind]


@dataclass(frozen=True)
class Fleet:
    name: str
    robots: tuple[RobotSpec, ...]
    source: str

    def by_activity(self, activity: Task | str) -> list[RobotSpec]:
        return [r for r in self.robots if r.can(activity)]


def _robot(entry, source: str, index: int) -> RobotSpec:
    where = f"robots[{index}]"
    if not isinstance(entry, dict):
        raise InputError(f"{source}: {where} must be a mapping with name, kind, speed, ..., got {entry!r}")
    name = entry.get("name")
    if not isinstance(name, str) or not name.strip() or not name.isprintable():  # it goes into schedules and logs
        raise InputError(f"{source}{line_of(entry, 'name')}: {where}: key 'name' must be a non-empty string of printable "
                         f"characters, got {name!r}"[:400])
    where = f"{where} ({name})"
    kind = entry.get("kind")
    if not isinstance(kind, str) or kind not in KIND_ACTIVITIES:
        raise InputError(f"{source}{line_of(entry, 'kind')}: {where}: key 'kind' must be one of {', '.join(KIND_ACTIVITIES)}, got {kind!r}")
    needed = {key for activity in KIND_ACTIVITIES[kind] for key in ACTIVITY_KEYS[activity]}
    allowed = needed | set(OPTIONAL_KEYS) | {"name", "kind"}
    check_keys(entry, allowed, source, where, detail=f" for a {kind} robot")
    for key in sorted(needed):
        if key not in entry:
            raise InputError(f"{source}: {where}: missing key '{key}' (a {kind} robot needs {', '.join(sorted(needed))})")
    values: dict = {"name": name, "kind": kind}
    for key in sorted((needed - {"platform_size"}) | ({"load_time", "unload_time"} & set(entry))):
        low, high, unit = RANGES[key]
        values[key] = number(entry, key, source, low=low, high=high, low_inclusive=True, unit=unit, where=where)
    if "platform_size" in needed:
        size = entry["platform_size"]
        label = f"{source}{line_of(entry, 'platform_size')}: {where}: key 'platform_size'"
        if not isinstance(size, (list, tuple)) or len(size) != 2:
            raise InputError(f"{label} must be [length, width] in metres, got {size!r}")
        length, width = (_number_in(v, label, *PLATFORM_RANGE_M, "m", low_inclusive=True) for v in size)
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
    check_keys(data, ("name", "robots"), source)
    specs = tuple(_robot(entry, source, i) for i, entry in enumerate(robots))
    first: dict[str, int] = {}
    for index, spec in enumerate(specs):
        if spec.name in first:
            line = getattr(robots[index], "line", None)
            raise InputError(f"{source}{f' line {line}' if line else ''}: robot name '{spec.name}' is used twice "
                             f"(robots[{first[spec.name]}] and robots[{index}])")
        first[spec.name] = index
    return Fleet(name=str(data.get("name") or Path(source).stem), robots=specs, source=source)


def fleet_to_dict(fleet: Fleet) -> dict:
    """The fleet as the keys of a fleet file (JSON- and YAML-safe): :func:`fleet_from_dict` reads it back
    to the same robots. The construction graph holds it, so RCAN runs from the graph alone."""
    robots = []
    for robot in fleet.robots:
        keys = sorted({key for task in KIND_ACTIVITIES[robot.kind] for key in ACTIVITY_KEYS[task]})
        entry = {"name": robot.name, "kind": robot.kind}
        entry.update({key: list(getattr(robot, key)) if key == "platform_size" else getattr(robot, key) for key in keys})
        entry.update({key: getattr(robot, key) for key in ("load_time", "unload_time") if getattr(robot, key)})
        if Task.ASSEMBLE in KIND_ACTIVITIES[robot.kind]:
            entry["methods"] = list(robot.methods)
        if robot.home is not None:
            entry["home"] = list(robot.home)
        robots.append(entry)
    return {"name": fleet.name, "robots": robots}


def load_fleet(spec: str | Path) -> Fleet:
    """A built-in fleet ("fleet1", "fleet2", "site-crane") or a fleet YAML file, validated."""
    if str(spec) in BUILTIN_FLEETS:
        text = resources.files("bimrobot.coordination").joinpath("fleets", f"{spec}.yaml").read_text()
        source = f"built-in fleet {spec}"
        return fleet_from_dict(parse_yaml(text, source), source)
    if not Path(spec).is_file():
        if str(spec).lower() in BUILTIN_FLEETS:  # --fleet Fleet2: the built-in fleet2
            return load_fleet(str(spec).lower())
        import difflib

        close = difflib.get_close_matches(str(spec).lower(), BUILTIN_FLEETS, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise InputError(f"fleet {spec!r} is neither a built-in fleet ({', '.join(BUILTIN_FLEETS)}) nor a file{hint}")
    return fleet_from_dict(read_yaml_file(spec, "fleet file"), str(spec))
