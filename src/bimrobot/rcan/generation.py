"""RCAN generation system: the fleet, task allocator and node generator (thesis 5.2.1-5.2.2).

1. The fleet (:mod:`bimrobot.site.fleet`, one robot description for `simulate` and RCAN) says
   which robots are on site and which activities each performs (Table 5.2: :mod:`bimrobot.rcan.fleet`).
2. The :class:`TaskAllocator` matches each published activity to a capable robot: it must integrate
   the robot type the activity needs and carry the component's weight; once a robot holds a component
   it keeps every later activity of that component until it is installed.
3. The :class:`NodeGenerator` instantiates an :class:`~bimrobot.rcan.node.RcanNode` (component,
   activity, robot, target pose, backend).
"""

from __future__ import annotations

from pathlib import Path

from bimrobot.site.fleet import Fleet, RobotSpec
from bimrobot.core.errors import InputError
from bimrobot.rcan.activities import RcanActivity
from bimrobot.rcan.fleet import load_rcan_fleet, types_for
from bimrobot.rcan.node import RcanNode

def load_capabilities(path: str | Path | None = None, site=None, model_offset=(0.0, 0.0)) -> Fleet:
    """The fleet RCAN runs with, placed in the model frame (:func:`bimrobot.rcan.fleet.place_fleet`): a
    built-in fleet name (``fleet2``, ``rcan-robots``, ...) or a fleet file of any version (an older RCAN
    capability table too); ``None``: the built-in ``rcan-robots``. Site-frame homes are taken from ``site``
    (a :class:`bimrobot.site.site.Site`, default fig. 4.11) into the model frame with ``model_offset`` (model ->
    site, metres).

    Raises :class:`InputError` naming the file, key and line on any malformed entry or number out of
    its physical range.
    """
    return load_rcan_fleet(None if path is None else str(path), site=site, model_offset=model_offset)


def parse_capabilities(data: object, source: str = "capability table") -> Fleet:
    """The placed fleet of already parsed fleet data of any version (homes on the site: at fig. 4.11's)."""
    return load_rcan_fleet(data=data, source=source)


class TaskAllocator:
    """Matches construction activities to capable robots (thesis Figure 5.3).

    A robot is capable when it integrates a robot type that performs the activity (Table 5.2) and its
    payload carries the component's weight (Table 5.1). A robot that started on a component is
    *committed* to it (it may be holding it) until its last install; every activity of that component
    goes to that robot. Otherwise an activity goes to the robot the schedule names when the table has
    it (with ``reallocate``: preferably), else to the least-loaded capable robot (ties: file order).
    """

    def __init__(self, capabilities: Fleet, reallocate: bool = False):
        self.capabilities = capabilities
        self.reallocate = reallocate  # give a schedule's assigned activities to any capable robot
        self._holder: dict[str, str] = {}  # component -> committed robot
        self._last: dict[str, str] = {}  # component -> the last activity its committed robot took
        self._load: dict[str, int] = {name: 0 for name in capabilities.names}
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
        if self.reallocate or activity.robot not in self.capabilities.by_name:
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
        if not self.reallocate and activity.robot in self.capabilities.by_name:
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
        robot = self.capabilities.by_name[name]
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
            types = " or ".join(types_for(activity.kind)) or "no robot type"
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
