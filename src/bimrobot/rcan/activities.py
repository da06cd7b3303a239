"""The six robot construction activities of thesis chapter 5 and how schedule rows break into them.

A schedule row (chapter 4's task decomposition: ``transport``, ``position``, ``assemble``) is broken
down until a robot has a well-defined goal (section 5.2.2):

- ``transport`` -> move to component, position for picking up, pick up, transport
- ``position``  -> position for installing
- ``assemble``  -> install

Each resulting :class:`RcanActivity` has an idempotent id ``<row Identification>.<n>`` (e.g.
``A0001.3``), so a resumed run recognises the activities it already executed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bimrobot.core.tasks import ActivityKind, Task

#: Chapter-4 schedule activity -> the RCAN activities it is broken into, in order.
SCHEDULE_DECOMPOSITION: dict[Task, tuple[ActivityKind, ...]] = {
    Task.TRANSPORT: (
        ActivityKind.MOVE_TO_COMPONENT,
        ActivityKind.POSITION_FOR_PICKING_UP,
        ActivityKind.PICK_UP,
        ActivityKind.TRANSPORT,
    ),
    Task.POSITION: (ActivityKind.POSITION_FOR_INSTALLING,),
    Task.ASSEMBLE: (ActivityKind.INSTALL,),
}


@dataclass(frozen=True)
class Pose:
    """A target pose in the world frame: position in metres, yaw in radians about z (z up)."""

    x: float
    y: float
    z: float
    yaw: float = 0.0

    def as_tuple(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.z)

    def distance_xy(self, other: "Pose") -> float:
        """Horizontal distance in metres."""
        return ((self.x - other.x) ** 2 + (self.y - other.y) ** 2) ** 0.5

    def distance(self, other: "Pose") -> float:
        """Euclidean distance in metres."""
        return ((self.x - other.x) ** 2 + (self.y - other.y) ** 2 + (self.z - other.z) ** 2) ** 0.5


@dataclass(frozen=True)
class RcanActivity:
    """One construction activity a smart component publishes (Table 5.1's properties).

    ``activity_id`` is unique and stable across runs; ``target`` is the activity's goal pose (world
    frame, metres); ``weight_kg`` the component's weight in kg (for matching a robot's payload), None
    when unknown (the model does not give it: no payload can be checked, and reports say so);
    ``section_m`` its section size (width, depth) in metres for matching a gripper, if known;
    ``size_m`` its three extents (m, smallest first: the section, then the length), if known;
    ``robot`` a robot requested by the schedule (None lets the allocator choose); ``predecessors``
    the activity ids that must be done first; ``start``/``finish`` the planned times in seconds.
    ``frees_robot``: after this activity the robot lets go of the component and may take other work
    (None: only after an install; True on a positioning that leaves the component PositionFixed for
    a separate assembly, as in chapter 4). ``lifts``: the robot carries the component in this
    activity's chain (False for work on a component already in place, e.g. fixing a joint on a
    footing or on a prebuilt slab: its weight and section do not limit the robot).

    The work of the one time model (:mod:`bimrobot.sco.timing`), from the schedule row the activity comes
    from: ``task`` the row's chapter-4 task (None: not from a schedule row); ``nodes`` and ``points`` the
    connection nodes it positions and the assembly points it makes (None: not known, one each);
    ``work_point`` where a drive (move to component, transport) ends in the time model, the point the
    robot works at (world frame, m; the base stops beside it, at ``target``; None: at ``target``);
    ``loads``: a pick-up that loads the component from the yard (the robot's load time), False for a
    re-grip at the drop-off point, which the positioning time includes; ``after``: activities of the same robot
    planned before this one, which it follows unless they fail (a soft order, unlike ``predecessors``).
    """

    activity_id: str
    component_id: str
    kind: ActivityKind
    target: Pose
    weight_kg: float | None = None
    section_m: tuple[float, float] | None = None
    size_m: tuple[float, float, float] | None = None
    robot: str | None = None
    predecessors: tuple[str, ...] = field(default_factory=tuple)
    start: float = 0.0
    finish: float = 0.0
    name: str = ""
    frees_robot: bool | None = None
    lifts: bool = True
    task: Task | None = None
    nodes: int | None = None
    points: int | None = None
    work_point: Pose | None = None
    loads: bool = True
    after: tuple[str, ...] = ()

    @property
    def releases_robot(self) -> bool:
        """Whether the robot is free of the component once this activity is done."""
        return self.kind is ActivityKind.INSTALL if self.frees_robot is None else self.frees_robot
