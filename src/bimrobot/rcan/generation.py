"""RCAN generation system: capability table, task allocator and node generator (thesis 5.2.1-5.2.2).

1. The capability table (Table 5.2, editable YAML) says which robot type performs which activity and
   which robots are on site.
2. The :class:`TaskAllocator` matches each published activity to a capable robot: it must integrate
   the robot type the activity needs and carry the component's weight; once a robot holds a component
   it keeps every later activity of that component until it is installed.
3. The :class:`NodeGenerator` instantiates an :class:`~bimrobot.rcan.node.RcanNode` (component,
   activity, robot, target pose, backend).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from bimrobot.config import check_keys, line_of, parse_yaml, read_yaml_file
from bimrobot.config import number as config_number
from bimrobot.errors import InputError
from bimrobot.rcan.activities import ActivityKind, Pose, RcanActivity
from bimrobot.rcan.node import RcanNode
from bimrobot.sco.timing import RobotTimes

DEFAULT_CAPABILITIES = "capabilities.yaml"


@dataclass(frozen=True)
class RobotSpec:
    """A robot on site. Lengths in metres, speeds in m/s, times in seconds, payload in kg.

    ``reach_m`` is measured horizontally from the base; ``handling_s`` maps an activity name
    (``pick_up``, ``install``) to the time the gripper needs for it; ``home`` is the start pose;
    ``gripper_opening_m`` the (min, max) jaw opening, matched against a component's section (Table 5.1),
    or None when the gripper takes any section.
    """

    name: str
    types: tuple[str, ...]
    activities: frozenset[ActivityKind]
    payload_kg: float
    reach_m: float
    speed_m_s: float
    arm_speed_m_s: float
    handling_s: dict[str, float] = field(default_factory=dict)
    home: Pose = Pose(0.0, 0.0, 0.0)
    gripper_opening_m: tuple[float, float] | None = None
    #: the mobile base's (length, width) in metres, when the capability file gives it (``footprint_m``);
    #: None: the physics backend's model family decides
    footprint_m: tuple[float, float] | None = None
    #: the robot's times in the one time model (:mod:`bimrobot.sco.timing`) when it comes from a fleet
    #: file (Table 4.1); None: from ``speed_m_s``, ``arm_speed_m_s`` and ``handling_s`` (:meth:`time_model`)
    times: RobotTimes | None = None

    def time_model(self) -> RobotTimes:
        """The robot's speeds and handling times in the one time model: a fleet robot's own (its
        handling includes the arm's motions), else the capability table's: ``pick_up`` is the load
        time, ``install`` the time per node and per point."""
        if self.times is not None:
            return self.times
        install = self.handling_s.get(ActivityKind.INSTALL.value, 0.0)
        return RobotTimes(self.speed_m_s, load_s=self.handling_s.get(ActivityKind.PICK_UP.value, 0.0),
                          per_node_s=install, per_point_s=install, arm_speed_m_s=self.arm_speed_m_s)

    def can(self, kind: ActivityKind) -> bool:
        """Whether one of this robot's types performs ``kind`` (Table 5.2)."""
        return kind in self.activities

    def can_grip(self, section_m: tuple[float, float] | None) -> bool:
        """Whether the gripper closes on a section (width, depth in m) across its narrower side."""
        if section_m is None or self.gripper_opening_m is None or not self.can(ActivityKind.PICK_UP):
            return True
        low, high = self.gripper_opening_m
        return low <= min(section_m) <= high


@dataclass(frozen=True)
class CapabilityTable:
    """Table 5.2 (robot type -> activities) plus the robots on site, read from YAML."""

    robot_types: dict[str, frozenset[ActivityKind]]
    robots: dict[str, RobotSpec]
    source: str = DEFAULT_CAPABILITIES

    def types_for(self, kind: ActivityKind) -> list[str]:
        """The robot types able to perform ``kind``."""
        return sorted(name for name, kinds in self.robot_types.items() if kind in kinds)

    def capable_robots(self, kind: ActivityKind, weight_kg: float | None = None,
                       section_m: tuple[float, float] | None = None) -> list[RobotSpec]:
        """Robots that perform ``kind``, carry ``weight_kg`` and grip ``section_m``, in file order.

        An unknown weight (None) cannot be checked against a payload: every robot of the kind passes,
        and the run reports those components as of unknown weight.
        """
        return [r for r in self.robots.values()
                if r.can(kind) and (weight_kg is None or r.payload_kg >= weight_kg) and r.can_grip(section_m)]


#: Physical ranges of a robot's numbers in a capability table: key -> (low, high, low inclusive, unit).
#: The largest land cranes lift about 5,000 t and reach about 250 m; nothing on a site drives faster
#: than a road vehicle (20 m/s); a gripper takes less than a day per pick-up or install.
ROBOT_RANGES = {
    "payload_kg": (0.0, 5.0e6, True, "kg"),
    "reach_m": (0.0, 250.0, True, "m"),
    "speed_m_s": (0.0, 20.0, False, "m/s"),
    "arm_speed_m_s": (0.0, 10.0, False, "m/s"),
}
#: The keys of a robot entry (capabilities.yaml).
ROBOT_KEYS = ("types", *ROBOT_RANGES, "handling_s", "gripper_opening_m", "home", "footprint_m")
HANDLING_RANGE_S = (0.0, 86400.0)
GRIPPER_RANGE_M = (0.0, 20.0)
FOOTPRINT_RANGE_M = (0.05, 100.0)  # a mobile base's length and width: a small robot's to a crawler crane's
#: A robot's home may be anywhere a site is (georeferenced coordinates included), within 1e7 m.
HOME_RANGE_M = 1.0e7


def load_capabilities(path: str | Path | None = None, site=None, model_offset=(0.0, 0.0)) -> CapabilityTable:
    """Read and validate a capability table; ``None`` reads the built-in one. A fleet (a built-in name such as
    ``fleet2`` or a fleet YAML file, as `simulate` reads) gives one RCAN robot per fleet robot
    (:mod:`bimrobot.rcan.fleet`), its homes taken from ``site`` (a :class:`bimrobot.site.Site`, default
    fig. 4.11) into the model frame with ``model_offset`` (model -> site, metres). A capability table's
    own homes are in the model frame already.

    Raises :class:`InputError` naming the file, key and line on any malformed entry or number out of
    its physical range (:data:`ROBOT_RANGES`).
    """
    from bimrobot.rcan import fleet  # a fleet file (or built-in fleet) describes the robots once, for simulate too

    if path is not None and str(path) in fleet.BUILTIN_FLEETS:
        return fleet.load_fleet_capabilities(str(path), site=site, model_offset=model_offset)
    if path is None:
        text = resources.files("bimrobot.rcan").joinpath(DEFAULT_CAPABILITIES).read_text()
        source = f"built-in {DEFAULT_CAPABILITIES}"
        data = parse_yaml(text, source)
    else:
        data, source = read_yaml_file(path, "capability table"), str(path)
    if fleet.is_fleet(data):
        return fleet.load_fleet_capabilities(str(path), data, source, site, model_offset)
    return parse_capabilities(data, source)


def parse_capabilities(data: object, source: str = "capability table") -> CapabilityTable:
    """Validate the YAML structure of a capability table (see capabilities.yaml)."""
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
    robots = {str(name): _parse_robot(str(name), entry, robot_types, source, line_of(data["robots"], name))
              for name, entry in data["robots"].items()}
    return CapabilityTable(robot_types, robots, source)


def _coordinates(entry: dict, key: str, source: str, robot: str, line: str, count: int, low: float, high: float,
                 default: list | None = None) -> tuple[float, ...] | None:
    """``entry[key]`` as ``count`` numbers in metres, each in ``[low, high]``; None when absent and no
    default. ``line``: the robot's line, used when the key's own is unknown."""
    value = entry.get(key, default)
    if value is None:
        value = default  # 'home:' with nothing after it: as if absent
    if value is None:
        return None
    label = f"{source}{line_of(entry, key) or line}: robot '{robot}': key '{key}'"
    if not (isinstance(value, list) and len(value) == count
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        raise InputError(f"{label} must be a list of {count} numbers in metres, got {value!r}")
    if not all(low <= v <= high and math.isfinite(v) for v in value):
        raise InputError(f"{label} must hold numbers between {low:g} and {high:g} m, got {value!r}")
    return tuple(float(v) for v in value)


def _parse_robot(name: str, entry: object, robot_types: dict, source: str, line: str = "") -> RobotSpec:
    where = f"{source}{line}: robots.{name}"
    if not isinstance(entry, dict):
        raise InputError(f"{where} must be a mapping")
    types = entry.get("types")
    if not isinstance(types, list) or not types:
        raise InputError(f"{where}.types must list the robot types it integrates")
    unknown = [t for t in types if not isinstance(t, str) or t not in robot_types]
    if unknown:
        raise InputError(f"{where}.types names unknown robot type {unknown[0]!r} (known: {', '.join(robot_types)})")
    robot = f"robot '{name}'"
    check_keys(entry, ROBOT_KEYS, source, robot)

    def number(key: str, default: float) -> float:
        low, high, inclusive, unit = ROBOT_RANGES[key]
        return config_number(entry, key, source, low=low, high=high, low_inclusive=inclusive, unit=unit,
                             default=default, where=robot)

    home = _coordinates(entry, "home", source, name, line, 3, -HOME_RANGE_M, HOME_RANGE_M, [0.0, 0.0, 0.0])
    handling = entry.get("handling_s", {}) or {}
    if not isinstance(handling, dict):
        raise InputError(f"{source}{line_of(entry, 'handling_s') or line}: {robot}: key 'handling_s' must map "
                         "activity names (pick_up, install, ...) to seconds")
    handling_s = {}
    for key in handling:
        try:
            kind = ActivityKind.parse(str(key))
        except ValueError as exc:
            raise InputError(f"{source}{line_of(handling, key) or line}: {robot}: handling_s: {exc}") from None
        handling_s[kind.value] = config_number(handling, key, source, low=HANDLING_RANGE_S[0], high=HANDLING_RANGE_S[1],
                                               unit="s", where=f"{robot} handling_s")
    opening = _coordinates(entry, "gripper_opening_m", source, name, line, 2, *GRIPPER_RANGE_M)
    if opening is not None and opening[0] > opening[1]:
        raise InputError(f"{source}{line_of(entry, 'gripper_opening_m') or line}: {robot}: key 'gripper_opening_m' "
                         f"must be [min, max] with min <= max, got {list(opening)}")
    return RobotSpec(
        name=name,
        types=tuple(types),
        activities=frozenset().union(*(robot_types[t] for t in types)),
        payload_kg=number("payload_kg", 0.0),
        reach_m=number("reach_m", 0.0),
        speed_m_s=number("speed_m_s", 1.0),
        arm_speed_m_s=number("arm_speed_m_s", 0.5),
        handling_s=handling_s,
        home=Pose(*home),
        gripper_opening_m=opening,
        footprint_m=_coordinates(entry, "footprint_m", source, name, line, 2, *FOOTPRINT_RANGE_M),
    )


class TaskAllocator:
    """Matches construction activities to capable robots (thesis Figure 5.3).

    A robot is capable when it integrates a robot type that performs the activity (Table 5.2) and its
    payload carries the component's weight (Table 5.1). A robot that started on a component is
    *committed* to it (it may be holding it) until its last install; every activity of that component
    goes to that robot. Otherwise an activity goes to the robot the schedule names when the table has
    it (with ``reallocate``: preferably), else to the least-loaded capable robot (ties: file order).
    """

    def __init__(self, capabilities: CapabilityTable, reallocate: bool = False):
        self.capabilities = capabilities
        self.reallocate = reallocate  # give a schedule's assigned activities to any capable robot
        self._holder: dict[str, str] = {}  # component -> committed robot
        self._last: dict[str, str] = {}  # component -> the last activity its committed robot took
        self._load: dict[str, int] = {name: 0 for name in capabilities.robots}
        self._commitments: dict[str, int] = {}  # robot -> how many components it is committed to
        self._capable: dict[tuple, list[RobotSpec]] = {}  # (kind, weight, section) -> capable robots

    def holder(self, component_id: str) -> str | None:
        """The robot committed to ``component_id``, if any."""
        return self._holder.get(component_id)

    def committed_robots(self) -> set[str]:
        return {robot for robot, n in self._commitments.items() if n}

    def is_committed(self, robot: str) -> bool:
        return self._commitments.get(robot, 0) > 0

    def load(self, robot: str) -> int:
        """How many activities ``robot`` has taken."""
        return self._load.get(robot, 0)

    def commit(self, component_id: str, robot: str, activity_id: str | None = None) -> None:
        """Bind ``robot`` to the component; ``activity_id`` is the activity it takes now."""
        previous = self._holder.get(component_id)
        if previous != robot:
            if previous is not None:
                self._commitments[previous] -= 1
            self._commitments[robot] = self._commitments.get(robot, 0) + 1
        self._holder[component_id] = robot
        if activity_id is not None:
            self._last[component_id] = activity_id
        self._load[robot] = self._load.get(robot, 0) + 1

    def continues(self, activity: RcanActivity) -> bool:
        """Whether ``activity`` follows directly on what the committed robot last did for its component
        (a second connection node of the same component must wait until the first is finished)."""
        last = self._last.get(activity.component_id)
        return last is None or last == activity.activity_id or last in activity.predecessors

    def release(self, component_id: str) -> str | None:
        """Free the robot committed to ``component_id``; returns that robot (None when there was none)."""
        robot = self._holder.pop(component_id, None)
        self._last.pop(component_id, None)
        if robot is not None:
            self._commitments[robot] -= 1
        return robot

    def assigned(self, activity: RcanActivity) -> str | None:
        """The robot the schedule assigned ``activity`` to, when it must take it (a robot of the table and
        no ``reallocate``); None when any capable robot may."""
        if self.reallocate or activity.robot not in self.capabilities.robots:
            return None
        return activity.robot

    def choose(self, activity: RcanActivity, exclude: set[str] = frozenset()) -> str | None:
        """A capable robot not in ``exclude`` (None when all capable robots are excluded).

        A robot the schedule assigned (``activity.robot``, a robot of the table) is the only choice
        unless the allocator was made with ``reallocate=True``: RCAN executes the plan it was given.
        """
        capable = self.capable(activity)
        holder = self._holder.get(activity.component_id)
        if holder is not None:
            return holder if holder not in exclude else None
        if not self.reallocate and activity.robot in self.capabilities.robots:
            assigned = activity.robot in {r.name for r in capable} and activity.robot not in exclude
            return activity.robot if assigned else None
        free = [r for r in capable if r.name not in exclude]
        if not free:
            return None
        for robot in free:
            if robot.name == activity.robot:
                return robot.name
        return min(free, key=lambda r: self._load[r.name]).name

    def allocate(self, activity: RcanActivity) -> RobotSpec:
        """The robot for ``activity`` (committing it to the component)."""
        name = self.choose(activity)
        robot = self.capabilities.robots[name]
        self.commit(activity.component_id, name, activity.activity_id)
        return robot

    @staticmethod
    def requirement(activity: RcanActivity) -> tuple:
        """What limits the robots that can take ``activity``: (kind, weight kg, section m); a component
        in place limits no robot by its weight or section."""
        lifted = activity.lifts
        return (activity.kind, activity.weight_kg if lifted else None, activity.section_m if lifted else None)

    def capable(self, activity: RcanActivity) -> list[RobotSpec]:
        """Robots able to take ``activity`` (file order); InputError naming it when there is none.
        Cached per :meth:`requirement`, so a plan of many activities scans the robots once per kind."""
        key = self.requirement(activity)
        capable = self._capable.get(key)
        if capable is None:
            capable = self._capable[key] = self.capabilities.capable_robots(*key)
        if not capable:
            types = " or ".join(self.capabilities.types_for(activity.kind)) or "no robot type"
            section = (f", section {activity.section_m[0]:.3f} x {activity.section_m[1]:.3f} m"
                       if activity.section_m else "")
            raise InputError(
                f"no robot can take '{activity.kind.label}' of component {activity.component_id} "
                f"(activity {activity.activity_id}, {_kg(activity.weight_kg)}{section}): it needs a {types} "
                f"with that payload{' and gripper opening' if section else ''} in {self.capabilities.source}"
            )
        return capable


def _kg(weight_kg: float | None) -> str:
    return "unknown weight" if weight_kg is None else f"{weight_kg:.1f} kg"


class NodeGenerator:
    """Instantiates RCAN nodes: one node per construction activity, bound to one robot and backend."""

    def __init__(self, allocator: TaskAllocator, backend: str = "sim"):
        self.allocator = allocator
        self.backend = backend

    def instantiate(self, activity: RcanActivity, robot: str | None = None) -> RcanNode:
        """The RCAN node of ``activity`` on ``robot`` (None: the allocator chooses); commits the robot."""
        if robot is None:
            robot = self.allocator.allocate(activity).name
        else:
            self.allocator.commit(activity.component_id, robot, activity.activity_id)
        return RcanNode(node_id=f"rcan/{activity.activity_id}", activity=activity, robot=robot, backend=self.backend)
