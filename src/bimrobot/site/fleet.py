"""THE fleet: one robot description, read once, used by `simulate`, the thesis loop, CP-SAT, RCAN and the graph.

A fleet file (``version: 2``; units in the key names: metres, seconds, kg, m/s; site frame, z up)::

    version: 2
    name: my_fleet
    robots:
      - {name: T1, kind: transport, speed_m_s: 0.8, carry_kg: 300, platform_m: [5.0, 1.0]}
      - {name: P1, kind: positioning, speed_m_s: 1.0, lift_kg: 300, reach_m: 4.0, time_per_node_s: 60}
      - {name: A1, kind: assembly, speed_m_s: 1.0, reach_m: 4.0, time_per_point_s: 30, methods: [bolt]}

A robot's ``kind`` says which construction tasks it bids for in `simulate` (:mod:`bimrobot.core.tasks`):

================== =========================================================================
kind               tasks and the keys it needs
================== =========================================================================
transport          transport: speed_m_s, carry_kg, platform_m [length, width]
positioning        position: speed_m_s, lift_kg, reach_m, time_per_node_s
assembly           assemble: speed_m_s, reach_m, time_per_point_s (methods: [bolt, weld] by default)
mobile_manipulator all three: every key above; without ``platform_m`` it carries what it holds in its
                   gripper, of any size
================== =========================================================================

Optional keys: ``load_s`` and ``unload_s`` (transport: hooking on, setting down), ``methods`` (assembly),
``reach_m`` (a transport robot loads over its platform: half its length by default), ``home_m`` [x, y] or
[x, y, z] (else the site's robot homes in turn), and for RCAN's executors ``arm_speed_m_s`` (end effector;
absent: the handling times include the arm's motions), ``gripper_opening_m`` [min, max] (absent: any
section), ``footprint_m`` [length, width] of the base and ``rcan_activities`` (the RCAN activities it
performs, thesis Table 5.2 names; default all six: every robot drives to its work and handles the
component or tool). A file-level ``home_frame: model`` says the homes are in the IFC model's frame (RCAN's
lab robots) instead of on the site.

Every number must be finite and physically plausible (:data:`RANGES`); a value outside its range is
refused before anything is simulated, naming the file, the robot, the key and its line.

Older files still load, converted to the one type with one warning naming the old keys and the new ones:
a version-1 chapter-4 fleet (``speed``, ``carry_load``, ``payload``, ``platform_size``, ``reach``,
``time_per_node``, ``time_per_point``, ``load_time``, ``unload_time``, ``home``; :data:`V1_KEYS`) and an
RCAN capability table (``robot_types`` and ``robots`` with ``payload_kg``, ``reach_m``, ``speed_m_s``,
``arm_speed_m_s``, ``handling_s``, ``gripper_opening_m``, ``home``, ``footprint_m``; read by
:func:`fleet_from_capability_table`): each of its robots becomes a mobile manipulator that carries (in its
gripper, no platform) and lifts its ``payload_kg``, loads in ``handling_s.pick_up`` and installs a node or
point in ``handling_s.install``, performing the activities of its types; its home stays in the model frame. ``bimrobot fleet convert old.yaml -o new.yaml`` writes the new form.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path

from bimrobot.core.config import check_keys, line_of, parse_yaml, read_yaml_file
from bimrobot.core.errors import InputError
from bimrobot.sco.timing import RobotTimes
from bimrobot.site.site import SITE_COORDINATE_LIMIT_M
from bimrobot.core.schema import (At, Choice, Coordinates, Custom, Name, Ordered, Quantity, Subset, Vector, keys_of,
                                  quantities_of, read_keys, rule, rules_of)
from bimrobot.core.tasks import KIND_TASKS, TASKS, ActivityKind, Task

log = logging.getLogger(__name__)

#: The version of the fleet format this module writes.
VERSION = 2
#: The tasks (:class:`bimrobot.core.tasks.Task`) and, per robot kind, the tasks its robots bid for.
ACTIVITIES = TASKS
KIND_ACTIVITIES = KIND_TASKS
#: The fields a robot needs for each task it does.
ACTIVITY_KEYS = {
    Task.TRANSPORT: ("speed_m_s", "carry_kg", "platform_m"),
    Task.POSITION: ("speed_m_s", "lift_kg", "reach_m", "time_per_node_s"),
    Task.ASSEMBLE: ("speed_m_s", "reach_m", "time_per_point_s"),
}
#: Keys any robot may have.
OPTIONAL_KEYS = ("load_s", "unload_s", "methods", "home_m", "reach_m", "arm_speed_m_s", "gripper_opening_m",
                 "footprint_m", "rcan_activities")
#: A version-1 chapter-4 fleet's keys -> the keys of this format (the same quantities, renamed).
V1_KEYS = {"speed": "speed_m_s", "carry_load": "carry_kg", "payload": "lift_kg", "platform_size": "platform_m",
           "reach": "reach_m", "time_per_node": "time_per_node_s", "time_per_point": "time_per_point_s",
           "load_time": "load_s", "unload_time": "unload_s", "home": "home_m", "methods": "methods"}
#: Keys a version-1 fleet robot may have (the RCAN keys came with version 2).
V1_OPTIONAL = ("load_s", "unload_s", "methods", "home_m")
#: The built-in fleets: ``fleets/<name>.yaml`` beside this module.
FLEETS_FOLDER = "fleets"
METHODS = ("bolt", "weld")
#: An RCAN robot's end-effector speed when its file gives none (m/s), as the thesis' UR5 moves a part.
DEFAULT_ARM_SPEED_M_S = 0.5
HOME_FRAMES = ("site", "model")

#: The physical range of each robot number, declared on :class:`RobotSpec`'s fields (:data:`RANGES` lists
#: them as (low, high, unit), both bounds inclusive). Upper bounds: the fastest
#: site vehicle is far below 50 m/s (180 km/h); the largest mobile cranes lift about 1,200 t, so 1e6
#: kg; a reach or platform beyond 300 m / 100 m is a typo; one handling step longer than a day
#: (86,400 s) is not a step. Lower bounds, so that no time a simulation derives from them overflows
#: what a schedule holds (1e9 s): 0.01 m/s (36 m an hour, slower than any site robot crawls; a 1e-300
#: m/s robot made a 302-digit makespan) crosses a 10 km site in 11.6 days; 1 kg is less than any
#: building part or tool a robot carries; a reach under 0.1 m reaches nothing; a node or assembly point
#: takes at least 0.1 s; loading and unloading may take no time at all; an arm faster than 10 m/s is no
#: construction robot's.
#: Platform length and width (m), both inclusive: 0.1 m is a tray, 100 m longer than any transport deck.
#: Gripper jaw opening (m): closed to 20 m (a crane hook takes any section: leave the key out). A mobile
#: base's length and width (m): a small robot's to a crawler crane's.
_PLATFORM = Vector(Quantity(0.1, 100.0, "m"), "[length, width] in metres")
_GRIPPER = Vector(Quantity(0.0, 20.0, "m"), "[min, max] in metres")
_FOOTPRINT = Vector(Quantity(0.05, 100.0, "m"), "[length, width] in metres")
_HOME = Vector(Quantity(-SITE_COORDINATE_LIMIT_M, SITE_COORDINATE_LIMIT_M, "m"), "[x, y] or [x, y, z] in metres", (2, 3))
_SECONDS = Quantity(0.1, 86_400.0, "s")
_HANDLING_S = Quantity(0.0, 86_400.0, "s")
#: Homes in the model frame may be georeferenced (far from the IFC origin): within 1e7 m.
MODEL_HOME_LIMIT_M = 1.0e7


def _rcan_activities(names, at: At) -> frozenset:
    if not isinstance(names, list) or not names:
        raise at.fail(f"must be a non-empty list of RCAN activity names, got {names!r}")
    try:
        return frozenset(ActivityKind.parse(str(name)).value for name in names)
    except ValueError as exc:
        raise InputError(f"{at}: {exc}") from None


@dataclass(frozen=True)
class RobotSpec:
    """One robot: what it can do and how fast. Metres, seconds, kg, m/s; ``home_m`` in the fleet's
    ``home_frame`` (the site's, z up, unless the fleet says model); None: the site's robot homes in turn.

    ``carry_kg`` is what it carries on its platform (``platform_m`` = length, width; None: no deck, it
    carries what it holds in its gripper, of any size), ``lift_kg`` what it lifts into place within ``reach_m``; ``arm_speed_m_s`` None: the handling times include the arm's
    motions (every chapter-4 robot); ``rcan_activities`` None: all six RCAN activities.
    """

    name: str = field(metadata=rule(Name()))
    kind: str = field(metadata=rule(Choice(tuple(KIND_TASKS))))
    speed_m_s: float = field(metadata=rule(Quantity(0.01, 50.0, "m/s")))
    carry_kg: float = field(default=0.0, metadata=rule(Quantity(1.0, 1e6, "kg")))
    lift_kg: float = field(default=0.0, metadata=rule(Quantity(1.0, 1e6, "kg")))
    platform_m: tuple[float, float] | None = field(default=None, metadata=rule(_PLATFORM))
    reach_m: float = field(default=0.0, metadata=rule(Quantity(0.1, 300.0, "m")))
    time_per_node_s: float = field(default=0.0, metadata=rule(_SECONDS))
    time_per_point_s: float = field(default=0.0, metadata=rule(_SECONDS))
    load_s: float = field(default=0.0, metadata=rule(_HANDLING_S))
    unload_s: float = field(default=0.0, metadata=rule(_HANDLING_S))
    methods: tuple[str, ...] = field(default=METHODS, metadata=rule(Subset(METHODS)))
    home_m: tuple[float, ...] | None = field(default=None, metadata=rule(_HOME))
    arm_speed_m_s: float | None = field(default=None, metadata=rule(Quantity(0.01, 10.0, "m/s")))
    gripper_opening_m: tuple[float, float] | None = field(default=None, metadata=rule(Ordered(_GRIPPER)))
    footprint_m: tuple[float, float] | None = field(default=None, metadata=rule(_FOOTPRINT))
    rcan_activities: frozenset[str] | None = field(default=None, metadata=rule(
        Custom(_rcan_activities, "list of RCAN activities (thesis Table 5.2 names; default all six)")))

    # ------------------------------------------------------------ chapter 4 (simulate, thesis, CP-SAT)
    @property
    def activities(self) -> tuple[Task, ...]:
        """The construction tasks it bids for (its kind's)."""
        return KIND_TASKS[self.kind]

    def can(self, activity: Task | str) -> bool:
        """Whether it bids for construction task ``activity`` (transport, position, assemble)."""
        return activity in KIND_TASKS[self.kind]

    @property
    def times(self) -> RobotTimes:
        """Its speeds and handling times in the one time model (:mod:`bimrobot.sco.timing`)."""
        arm = math.inf if self.arm_speed_m_s is None else self.arm_speed_m_s
        return RobotTimes(self.speed_m_s, self.load_s, self.unload_s, self.time_per_node_s, self.time_per_point_s, arm)

    # ------------------------------------------------------------ RCAN's views
    @property
    def payload_kg(self) -> float:
        """The heaviest component it handles (kg): the larger of what it carries and what it lifts; 0 for
        an assembly robot, which lifts nothing."""
        return max(self.carry_kg, self.lift_kg)

    @property
    def arm_speed(self) -> float:
        """Its end effector's speed for an executor that moves the arm (m/s): its own or 0.5 m/s."""
        return DEFAULT_ARM_SPEED_M_S if self.arm_speed_m_s is None else self.arm_speed_m_s

    @property
    def handling_s(self) -> dict[str, float]:
        """Seconds per RCAN gripper activity: ``pick_up`` is loading, ``install`` a point (assembly robot)
        or a connection node."""
        install = self.time_per_point_s if self.kind == Task.ASSEMBLE.robot_kind else self.time_per_node_s
        return {"pick_up": self.load_s, "install": install}

    def performs(self, kind) -> bool:
        """Whether it performs RCAN activity ``kind`` (:class:`bimrobot.core.tasks.ActivityKind`)."""
        return self.rcan_activities is None or str(getattr(kind, "value", kind)) in self.rcan_activities

    def can_grip(self, section_m: tuple[float, float] | None) -> bool:
        """Whether the gripper closes on a section (width, depth in m) across its narrower side."""
        if section_m is None or self.gripper_opening_m is None or not self.performs("pick_up"):
            return True
        low, high = self.gripper_opening_m
        return low <= min(section_m) <= high


#: Each robot number's physical range, (low, high, unit), both inclusive: read from RobotSpec's fields.
RANGES = quantities_of(RobotSpec)
#: Platform, gripper opening and base footprint sides (m), both inclusive: read from RobotSpec's fields.
PLATFORM_RANGE_M, GRIPPER_RANGE_M, FOOTPRINT_RANGE_M = ((r.item.low, r.item.high) for r in (_PLATFORM, _GRIPPER, _FOOTPRINT))


@dataclass(frozen=True)
class Fleet:
    """The robots of one fleet file, in file order; ``home_frame``: where their ``home_m`` are ("site" or
    "model", the IFC's world frame)."""

    name: str
    robots: tuple[RobotSpec, ...]
    source: str
    home_frame: str = "site"
    by_name: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "by_name", {robot.name: robot for robot in self.robots})

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.by_name)

    def by_activity(self, activity: Task | str) -> list[RobotSpec]:
        """The robots that bid for construction task ``activity``."""
        return [r for r in self.robots if r.can(activity)]

    def capable_robots(self, kind, weight_kg: float | None = None,
                       section_m: tuple[float, float] | None = None) -> list[RobotSpec]:
        """RCAN: the robots that perform activity ``kind``, carry ``weight_kg`` and grip ``section_m``, in
        file order. An unknown weight (None) cannot be checked against a payload: every robot passes."""
        return [r for r in self.robots
                if r.performs(kind) and (weight_kg is None or r.payload_kg >= weight_kg) and r.can_grip(section_m)]

    def home_on_site(self, robot: RobotSpec, model_offset) -> tuple[float, float] | None:
        """``robot``'s home (x, y) in the site frame (m), None when it has none; ``model_offset``: the
        model -> site translation, used when the fleet's homes are in the model frame."""
        if robot.home_m is None:
            return None
        if self.home_frame == "model":
            return (robot.home_m[0] + float(model_offset[0]), robot.home_m[1] + float(model_offset[1]))
        return (robot.home_m[0], robot.home_m[1])


# ---------------------------------------------------------------- reading
class _Keys:
    """The key names of the file being read: this format's, or a version-1 file's (messages name the
    keys the user wrote)."""

    def __init__(self, v1: bool):
        self.v1 = v1
        self.of = {new: old for old, new in V1_KEYS.items()} if v1 else {}

    def __call__(self, name: str) -> str:
        return self.of.get(name, name)


def _robot(entry, source: str, index: int, keys: _Keys, home: Vector) -> RobotSpec:
    """One robot of a fleet file, read by RobotSpec's declared rules; its kind says the keys it needs;
    ``home``: the rule of its home (within the fleet's frame's limit)."""
    at = At(source, where=f"robots[{index}]")
    if not isinstance(entry, dict):
        raise InputError(f"{source}: {at.where} must be a mapping with name, kind, {keys('speed_m_s')}, ..., got {entry!r}")
    name = Name().read(entry.get("name"), at.of(entry, "name"))
    at = replace(at, where=f"{at.where} ({name})")
    kind = rules_of(RobotSpec)["kind"].read(entry.get("kind"), at.of(entry, "kind"))
    needed = {key for activity in KIND_ACTIVITIES[kind] for key in ACTIVITY_KEYS[activity]}
    optional = set(V1_OPTIONAL if keys.v1 else OPTIONAL_KEYS)
    if kind == "mobile_manipulator" and not keys.v1:  # it may carry what it holds in its gripper
        needed.discard("platform_m")
        optional.add("platform_m")
    numbers = sorted((needed | optional) & set(RANGES))  # read in this order: the first refusal is the same
    order = [*numbers, *(k for k in ("platform_m", "methods", "home_m", "gripper_opening_m", "footprint_m",
                                     "rcan_activities") if k in needed | optional)]
    values = read_keys(entry, RobotSpec, at, only=["name", "kind", *order], names=keys, detail=f" for a {kind} robot",
                       required=needed, needs=f" (a {kind} robot needs {', '.join(sorted(keys(k) for k in needed))})",
                       rules={"home_m": home})
    if "platform_m" in values:
        values["platform_m"] = (max(values["platform_m"]), min(values["platform_m"]))
        values.setdefault("reach_m", values["platform_m"][0] / 2)  # a transport robot loads over its platform
    return RobotSpec(**values)


def fleet_from_dict(data, source: str) -> Fleet:
    """A validated Fleet from a parsed fleet file of any version; errors name ``source`` and the key.
    A version-1 chapter-4 fleet or an RCAN capability table is converted, with one warning."""
    if isinstance(data, dict) and isinstance(data.get("robot_types"), dict):
        return fleet_from_capability_table(data, source)  # RCAN's own older format
    if not isinstance(data, dict) or "robots" not in data:
        raise InputError(f"{source}: expected a mapping with 'version: {VERSION}' and a 'robots' list")
    version = data.get("version", 1)
    if version not in (1, VERSION):
        raise InputError(f"{source}{line_of(data, 'version')}: key 'version' must be {VERSION} (or 1, the older "
                         f"keys), got {version!r}")
    keys = _Keys(v1=version == 1)
    robots = data["robots"]
    if not isinstance(robots, list) or not robots:
        raise InputError(f"{source}: key 'robots' must be a non-empty list")
    check_keys(data, ("name", "robots") if keys.v1 and "version" not in data else ("version", "name", "home_frame", "robots"), source)
    frame = data.get("home_frame", "site")
    if frame not in HOME_FRAMES:
        raise InputError(f"{source}{line_of(data, 'home_frame')}: key 'home_frame' must be one of {', '.join(HOME_FRAMES)}, got {frame!r}")
    limit = MODEL_HOME_LIMIT_M if frame == "model" else SITE_COORDINATE_LIMIT_M
    home = _HOME.within(limit) if not keys.v1 else _HOME.within(limit, (2,), "a pair of numbers [x, y] in metres")
    specs = tuple(_robot(entry, source, i, keys, home) for i, entry in enumerate(robots))
    first: dict[str, int] = {}
    for index, spec in enumerate(specs):
        if spec.name in first:
            line = getattr(robots[index], "line", None)
            raise InputError(f"{source}{f' line {line}' if line else ''}: robot name '{spec.name}' is used twice "
                             f"(robots[{first[spec.name]}] and robots[{index}])")
        first[spec.name] = index
    if keys.v1:
        used = sorted({key for entry in robots for key in entry if key in V1_KEYS and key != "methods"})
        warn_old_format(source, "a version-1 fleet", ", ".join(f"{k} -> {V1_KEYS[k]}" for k in used))
    return Fleet(name=str(data.get("name") or Path(source).stem), robots=specs, source=source, home_frame=frame)


def warn_old_format(source: str, what: str, renames: str) -> None:
    """One warning line: ``source`` is an older fleet format (``what``), read with its keys renamed."""
    log.warning("%s is %s (older keys); read as version %d: %s; `bimrobot fleet convert` writes the new "
                "form", source, what, VERSION, renames)


def fleet_to_dict(fleet: Fleet) -> dict:
    """The fleet as the keys of a version-2 fleet file (JSON- and YAML-safe): :func:`fleet_from_dict` reads
    it back to the same robots. The construction graph holds it, so RCAN runs from the graph alone."""
    robots = []
    for robot in fleet.robots:
        needed = {key for task in KIND_ACTIVITIES[robot.kind] for key in ACTIVITY_KEYS[task]}
        entry: dict = {"name": robot.name, "kind": robot.kind}
        for key in ("speed_m_s", "carry_kg", "lift_kg", "platform_m", "reach_m", "time_per_node_s", "time_per_point_s"):
            if (key in needed and getattr(robot, key) is not None) or (key == "reach_m" and robot.reach_m):
                value = getattr(robot, key)
                entry[key] = list(value) if isinstance(value, tuple) else value
        entry.update({key: getattr(robot, key) for key in ("load_s", "unload_s") if getattr(robot, key)})
        if Task.ASSEMBLE in KIND_ACTIVITIES[robot.kind]:
            entry["methods"] = list(robot.methods)
        for key in ("home_m", "gripper_opening_m", "footprint_m"):
            if getattr(robot, key) is not None:
                entry[key] = list(getattr(robot, key))
        if robot.arm_speed_m_s is not None:
            entry["arm_speed_m_s"] = robot.arm_speed_m_s
        if robot.rcan_activities is not None:
            entry["rcan_activities"] = sorted(robot.rcan_activities)
        robots.append(entry)
    data: dict = {"version": VERSION, "name": fleet.name}
    if fleet.home_frame != "site":
        data["home_frame"] = fleet.home_frame
    data["robots"] = robots
    return data


#: The name of the fleet file `simulate` writes beside its schedule: the fleet that built it.
RUN_FLEET_FILE = "fleet.yaml"


def fleet_yaml(fleet: Fleet, what: str) -> str:
    """The fleet as a version-2 fleet file (YAML), with a header saying where it came from; ``what``
    names the run."""
    import yaml

    header = (f"# The fleet of {what} ({fleet.source}), in the one fleet format. Give it to any command with\n"
              "# --fleet to use the same robots (`bimrobot graph` finds it beside the schedule).\n")
    return header + yaml.safe_dump(fleet_to_dict(fleet), sort_keys=False, default_flow_style=None)


def schedule_fleet(schedule: str | Path) -> Fleet | None:
    """The fleet that built a schedule CSV: the :data:`RUN_FLEET_FILE` `simulate` wrote beside it, or None."""
    path = Path(schedule).parent / RUN_FLEET_FILE
    return fleet_from_dict(read_yaml_file(path, "fleet file"), str(path)) if path.is_file() else None


def builtin_fleets() -> tuple[str, ...]:
    """The names of the built-in fleets (the files of the ``fleets`` folder), sorted."""
    folder = resources.files("bimrobot.site").joinpath(FLEETS_FOLDER)
    return tuple(sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml")))


BUILTIN_FLEETS = builtin_fleets()


def load_fleet(spec: str | Path) -> Fleet:
    """A built-in fleet (:data:`BUILTIN_FLEETS`, the files of ``fleets/``: "fleet1", "fleet2", "rcan-robots",
    "site-crane") or a fleet YAML file of any version, validated."""
    if str(spec) in BUILTIN_FLEETS:
        text = resources.files("bimrobot.site").joinpath(FLEETS_FOLDER, f"{spec}.yaml").read_text()
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


# ---------------------------------------------------------------- RCAN's older capability table
#: Physical ranges of a robot's numbers in a capability table, declared on :class:`CapabilityRobot`.
#: The largest land cranes lift about 5,000 t and reach about 250 m; nothing on a site drives faster
#: than a road vehicle (20 m/s); a gripper takes less than a day per pick-up or install.
HANDLING_S = Quantity(0.0, 86400.0, "s")


def _handling(value, at: At) -> dict:
    """``handling_s``: RCAN activity name -> seconds (empty or null: none)."""
    if not value:
        return {}
    if not isinstance(value, dict):
        raise at.fail("must map activity names (pick_up, install, ...) to seconds")
    seconds = {}
    for key in value:
        try:
            kind = ActivityKind.parse(str(key))
        except ValueError as exc:
            raise InputError(f"{at.source}{line_of(value, key) or at.line}: {at.where}: handling_s: {exc}") from None
        seconds[kind] = HANDLING_S.read(value[key], replace(at, line=line_of(value, key), where=f"{at.where} handling_s", key=str(key)))
    return seconds


@dataclass(frozen=True)
class CapabilityRobot:
    """The keys of one robot of a capability table (metres, seconds, kg, m/s; ``home`` [x, y, z] in the
    model frame); ``types`` is checked against the table's ``robot_types`` before (its messages name them)."""

    types: tuple = field(metadata=rule(Custom(lambda value, at: value)))
    home: tuple = field(default=(0.0, 0.0, 0.0), metadata=rule(Coordinates(3, -1.0e7, 1.0e7)))
    handling_s: dict = field(default_factory=dict, metadata=rule(Custom(_handling)))
    gripper_opening_m: tuple | None = field(default=None, metadata=rule(Ordered(Coordinates(2, 0.0, 20.0))))
    payload_kg: float = field(default=0.0, metadata=rule(Quantity(0.0, 5.0e6, "kg")))
    footprint_m: tuple | None = field(default=None, metadata=rule(Coordinates(2, 0.05, 100.0)))
    speed_m_s: float = field(default=1.0, metadata=rule(Quantity(0.0, 20.0, "m/s", low_open=True)))
    reach_m: float = field(default=0.0, metadata=rule(Quantity(0.0, 250.0, "m")))
    arm_speed_m_s: float = field(default=0.5, metadata=rule(Quantity(0.0, 10.0, "m/s", low_open=True)))


#: The keys of a robot entry of a capability table, and the ranges of its numbers (low, high, unit).
ROBOT_KEYS = keys_of(CapabilityRobot)
ROBOT_RANGES = quantities_of(CapabilityRobot)


def fleet_from_capability_table(data: object, source: str = "capability table") -> Fleet:
    """A fleet (homes in the model frame) from RCAN's older capability table, validated; one warning."""
    if not isinstance(data, dict) or not isinstance(data.get("robot_types"), dict):
        raise InputError(f"{source}: expected a mapping with 'robot_types' and 'robots'")
    if not isinstance(data.get("robots"), dict) or not data["robots"]:
        raise InputError(f"{source}{line_of(data, 'robots')}: 'robots' must map at least one robot name to its specification")
    check_keys(data, ("robot_types", "robots"), source)
    robot_types: dict[str, frozenset[ActivityKind]] = {}
    for type_name, entry in data["robot_types"].items():
        activities = (entry or {}).get("activities") if isinstance(entry, dict) else None
        where = f"{source}{line_of(data['robot_types'], type_name)}: robot_types.{type_name}"
        if isinstance(entry, dict):
            check_keys(entry, ("activities",), source, f"robot_types.{type_name}")
        if not isinstance(activities, list):
            raise InputError(f"{where}.activities must be a list of activity names")
        try:
            robot_types[str(type_name)] = frozenset(ActivityKind.parse(str(a)) for a in activities)
        except ValueError as exc:
            raise InputError(f"{where}: {exc}") from None
    robots = tuple(_table_robot(str(name), entry, robot_types, source, line_of(data["robots"], name))
                   for name, entry in data["robots"].items())
    warn_old_format(source, "an RCAN capability table", "robot_types -> rcan_activities, payload_kg -> carry_kg "
                    "and lift_kg, handling_s pick_up -> load_s, install -> time_per_node_s and time_per_point_s, "
                    "home -> home_m (home_frame: model)")
    return Fleet(name=Path(source).stem, robots=robots, source=source, home_frame="model")


def _table_robot(name: str, entry: object, robot_types: dict, source: str, line: str = "") -> RobotSpec:
    where = f"{source}{line}: robots.{name}"
    if not isinstance(entry, dict):
        raise InputError(f"{where} must be a mapping")
    types = entry.get("types")
    if not isinstance(types, list) or not types:
        raise InputError(f"{where}.types must list the robot types it integrates")
    unknown = [t for t in types if not isinstance(t, str) or t not in robot_types]
    if unknown:
        raise InputError(f"{where}.types names unknown robot type {unknown[0]!r} (known: {', '.join(robot_types)})")
    read = read_keys(entry, CapabilityRobot, At(source, line, f"robot '{name}'"))
    spec = CapabilityRobot(**{key: value for key, value in read.items() if value is not None})
    activities = frozenset().union(*(robot_types[t] for t in types))
    install = spec.handling_s.get(ActivityKind.INSTALL, 0.0)
    return RobotSpec(
        name=name, kind="mobile_manipulator", speed_m_s=spec.speed_m_s, carry_kg=spec.payload_kg,
        lift_kg=spec.payload_kg, reach_m=spec.reach_m, time_per_node_s=install, time_per_point_s=install,
        load_s=spec.handling_s.get(ActivityKind.PICK_UP, 0.0), arm_speed_m_s=spec.arm_speed_m_s,
        gripper_opening_m=spec.gripper_opening_m, footprint_m=spec.footprint_m, home_m=spec.home,
        rcan_activities=None if activities == frozenset(ActivityKind) else frozenset(k.value for k in activities),
    )
