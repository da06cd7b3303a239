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

from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path


from bimrobot.config import parse_yaml
from bimrobot.errors import InputError
from bimrobot.rcan.activities import ActivityKind, Pose, RcanActivity
from bimrobot.rcan.node import RcanNode

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

    def capable_robots(self, kind: ActivityKind, weight_kg: float = 0.0,
                       section_m: tuple[float, float] | None = None) -> list[RobotSpec]:
        """Robots that perform ``kind``, carry ``weight_kg`` and grip ``section_m``, in file order."""
        return [r for r in self.robots.values()
                if r.can(kind) and r.payload_kg >= weight_kg and r.can_grip(section_m)]


def load_capabilities(path: str | Path | None = None) -> CapabilityTable:
    """Read and validate a capability table; ``None`` reads the built-in one.

    Raises :class:`InputError` naming the file and key on any malformed entry.
    """
    if path is None:
        text = resources.files("bimrobot.rcan").joinpath(DEFAULT_CAPABILITIES).read_text()
        source = f"built-in {DEFAULT_CAPABILITIES}"
    else:
        path = Path(path)
        if not path.is_file():
            raise InputError(f"capability table {path} does not exist")
        text = path.read_text()
        source = str(path)
    return parse_capabilities(parse_yaml(text, source), source)


def parse_capabilities(data: object, source: str = "capability table") -> CapabilityTable:
    """Validate the YAML structure of a capability table (see capabilities.yaml)."""
    if not isinstance(data, dict) or not isinstance(data.get("robot_types"), dict):
        raise InputError(f"{source}: expected a mapping with 'robot_types' and 'robots'")
    if not isinstance(data.get("robots"), dict) or not data["robots"]:
        raise InputError(f"{source}: 'robots' must map at least one robot name to its specification")
    robot_types: dict[str, frozenset[ActivityKind]] = {}
    for type_name, entry in data["robot_types"].items():
        activities = (entry or {}).get("activities") if isinstance(entry, dict) else None
        if not isinstance(activities, list):
            raise InputError(f"{source}: robot_types.{type_name}.activities must be a list of activity names")
        try:
            robot_types[type_name] = frozenset(ActivityKind.parse(str(a)) for a in activities)
        except ValueError as exc:
            raise InputError(f"{source}: robot_types.{type_name}: {exc}") from None
    robots = {name: _parse_robot(name, entry, robot_types, source) for name, entry in data["robots"].items()}
    return CapabilityTable(robot_types, robots, source)


def _parse_robot(name: str, entry: object, robot_types: dict, source: str) -> RobotSpec:
    where = f"{source}: robots.{name}"
    if not isinstance(entry, dict):
        raise InputError(f"{where} must be a mapping")
    types = entry.get("types")
    if not isinstance(types, list) or not types:
        raise InputError(f"{where}.types must list the robot types it integrates")
    unknown = [t for t in types if t not in robot_types]
    if unknown:
        raise InputError(f"{where}.types names unknown robot type {unknown[0]!r} (known: {', '.join(robot_types)})")

    def number(key: str, default: float | None = None) -> float:
        value = entry.get(key, default)
        if not isinstance(value, (int, float)) or isinstance(value, bool) or value < 0:
            raise InputError(f"{where}.{key} must be a non-negative number, got {value!r}")
        return float(value)

    home = entry.get("home", [0.0, 0.0, 0.0])
    if not (isinstance(home, list) and len(home) == 3 and all(isinstance(v, (int, float)) for v in home)):
        raise InputError(f"{where}.home must be [x, y, z] in metres, got {home!r}")
    handling = entry.get("handling_s", {}) or {}
    if not isinstance(handling, dict) or not all(isinstance(v, (int, float)) and v >= 0 for v in handling.values()):
        raise InputError(f"{where}.handling_s must map activity names to seconds")
    opening = entry.get("gripper_opening_m")
    if opening is not None and not (isinstance(opening, list) and len(opening) == 2
                                    and all(isinstance(v, (int, float)) for v in opening) and 0 <= opening[0] <= opening[1]):
        raise InputError(f"{where}.gripper_opening_m must be [min, max] in metres, got {opening!r}")
    speed = number("speed_m_s", 1.0)
    if speed == 0:
        raise InputError(f"{where}.speed_m_s must be positive")
    return RobotSpec(
        name=name,
        types=tuple(types),
        activities=frozenset().union(*(robot_types[t] for t in types)),
        payload_kg=number("payload_kg", 0.0),
        reach_m=number("reach_m", 0.0),
        speed_m_s=speed,
        arm_speed_m_s=number("arm_speed_m_s", 0.5) or 0.5,
        handling_s={str(k): float(v) for k, v in handling.items()},
        home=Pose(*(float(v) for v in home)),
        gripper_opening_m=tuple(float(v) for v in opening) if opening is not None else None,
    )


class TaskAllocator:
    """Matches construction activities to capable robots (thesis Figure 5.3).

    A robot is capable when it integrates a robot type that performs the activity (Table 5.2) and its
    payload carries the component's weight (Table 5.1). A robot that started on a component is
    *committed* to it (it may be holding it) until its last install; every activity of that component
    goes to that robot. Otherwise the preference is: the robot the schedule names, then the
    least-loaded capable robot (ties: file order).
    """

    def __init__(self, capabilities: CapabilityTable):
        self.capabilities = capabilities
        self._holder: dict[str, str] = {}  # component -> committed robot
        self._last: dict[str, str] = {}  # component -> the last activity its committed robot took
        self._load: dict[str, int] = {name: 0 for name in capabilities.robots}

    def holder(self, component_id: str) -> str | None:
        """The robot committed to ``component_id``, if any."""
        return self._holder.get(component_id)

    def committed_robots(self) -> set[str]:
        return set(self._holder.values())

    def commit(self, component_id: str, robot: str, activity_id: str | None = None) -> None:
        """Bind ``robot`` to the component; ``activity_id`` is the activity it takes now."""
        self._holder[component_id] = robot
        if activity_id is not None:
            self._last[component_id] = activity_id
        self._load[robot] = self._load.get(robot, 0) + 1

    def continues(self, activity: RcanActivity) -> bool:
        """Whether ``activity`` follows directly on what the committed robot last did for its component
        (a second connection node of the same component must wait until the first is finished)."""
        last = self._last.get(activity.component_id)
        return last is None or last == activity.activity_id or last in activity.predecessors

    def release(self, component_id: str) -> None:
        self._holder.pop(component_id, None)
        self._last.pop(component_id, None)

    def choose(self, activity: RcanActivity, exclude: set[str] = frozenset()) -> str | None:
        """A capable robot not in ``exclude`` (None when all capable robots are excluded)."""
        capable = self.capable(activity)
        holder = self._holder.get(activity.component_id)
        if holder is not None:
            return holder if holder not in exclude else None
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

    def capable(self, activity: RcanActivity) -> list[RobotSpec]:
        capable = self.capabilities.capable_robots(activity.kind, activity.weight_kg, activity.section_m)
        if not capable:
            types = " or ".join(self.capabilities.types_for(activity.kind)) or "no robot type"
            section = (f", section {activity.section_m[0]:.3f} x {activity.section_m[1]:.3f} m"
                       if activity.section_m else "")
            raise InputError(
                f"no robot can take '{activity.kind.label}' of component {activity.component_id} "
                f"(activity {activity.activity_id}, {activity.weight_kg:.1f} kg{section}): it needs a {types} "
                f"with that payload{' and gripper opening' if section else ''} in {self.capabilities.source}"
            )
        return capable


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
