"""The state of one simulated build (:mod:`bimrobot.coordination.simulation`): the robots on site, what a
run changes as it goes on (:class:`BuildState`), and what it produced (:class:`SimulationResult`).

Times in seconds since the build started; positions in the site frame (x, y), metres.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass, field

import numpy as np
import simpy

from bimrobot.coordination.market import TaskRequest
from bimrobot.core.tasks import Activity
from bimrobot.sco import timing
from bimrobot.sco.build import SmartModel
from bimrobot.site.fleet import RobotSpec


@dataclass
class RobotStats:
    """What one robot did in a run: allocation steps it took and its busy, travel and handling seconds."""

    name: str
    kind: str
    steps: int = 0
    busy_time: float = 0.0
    travel_time: float = 0.0
    handling_time: float = 0.0
    broken_at: float | None = None


@dataclass(eq=False)
class SiteRobot:
    """A robot of the fleet during a run: where it is (site frame x, y, metres), its task and its drive."""

    spec: RobotSpec
    position: np.ndarray
    stats: RobotStats
    task: TaskRequest | None = None
    process: simpy.Process | None = None
    broken: bool = False
    free_at: float = 0.0
    end_position: np.ndarray | None = None
    leg: tuple | None = None  # (t0, p0, t1, p1) of the current drive
    returning: simpy.Process | None = None  # driving back to the yard while idle

    @property
    def times(self) -> timing.RobotTimes:
        """The robot's speeds and handling times in the one time model."""
        return self.spec.times


@dataclass(eq=False)
class BuildState:
    """What one run changes as the build goes on, set up by :meth:`ConstructionSimulation.start` (the
    simulation's other attributes are its inputs). Times in seconds since the build started; ids are
    component GlobalIds, joint and node ids, request ids ``R00001`` and schedule ids ``A0001``."""

    env: simpy.Environment
    robots: dict[str, SiteRobot]  # name -> the robot, in fleet order
    robots_per_activity: dict[str, int]
    idle: dict[str, set[str]]  # activity -> the idle, working robots that do it
    pending: dict[str, list[TaskRequest]]  # activity -> heap of published requests not yet awarded
    history: dict[str, list[tuple[float, str]]]  # component -> (time, state) changes
    open_on_floor: list[int]  # floor -> work left before it closes (joints, or nodes per node)
    activities: list[Activity] = field(default_factory=list)  # schedule rows, in finish order until numbered
    events: list[dict] = field(default_factory=list)
    lines: list[str] = field(default_factory=list)  # the log, as events.log
    steps: int = 0  # allocation rounds that awarded a task
    sequence: int = 0  # requests published
    activity_counter: int = 0
    dispatch_scheduled: bool = False
    awaiting_decision: bool = False  # an agent's allocation round is open
    round_awarded: bool = False  # the current round awarded a task
    repairs: list = field(default_factory=list)  # the breakdown processes
    floor_finish: list[float] = field(default_factory=list)
    current_floor: int = 0
    floor_gate: dict[int, str] = field(default_factory=dict)  # floor -> the activity that closed the one below
    # component -> the activities after which its position is fixed (its own positioning; for a prebuilt
    # component made later, the positioning of the robot-built parts it rests on)
    position_activity: dict[str, tuple[str, ...]] = field(default_factory=dict)
    missing_supporters: dict[str, int] = field(default_factory=dict)  # component -> supporters not yet fixed
    dependants: dict[str, list[str]] = field(default_factory=dict)  # component -> what rests on it
    ready_by_floor: dict[int, list[str]] = field(default_factory=dict)  # floor -> components ready to carry
    assembly_published: set[str] = field(default_factory=set)  # joints
    transport_activity: dict[str, str] = field(default_factory=dict)  # per node: component -> its transport
    node_position_activity: dict[str, str] = field(default_factory=dict)
    node_position_published: set[str] = field(default_factory=set)
    node_assembly_published: set[str] = field(default_factory=set)
    # per node: robot-built node -> the prebuilt nodes of its joint assembled with it; and back
    attached_nodes: dict[str, list[str]] = field(default_factory=dict)
    attached_to: dict[str, str] = field(default_factory=dict)


@dataclass
class SimulationResult:
    """Everything a run produced. ``steps``: allocation rounds that awarded at least one task."""

    model: str
    fleet: str
    evaluator: str
    makespan: float
    steps: int
    activities: list[Activity]
    robots: list[RobotStats]
    events: list[dict]
    log_lines: list[str]
    state_history: dict[str, list[tuple[float, str]]]
    floor_finish: list[float]
    smart_summary: dict
    breakdowns: list[tuple] = field(default_factory=list)
    per_node: bool = False  # tasks per connection node (--per-node); False: per component / per joint
    built: SmartModel | None = None  # the run's copy of the model, in its final states (the input is unchanged)
    #: the site (its file, or the default) and the model -> site translation (x, y) in metres the run used
    site_source: str = ""
    model_offset: tuple[float, float] = (0.0, 0.0)

    @property
    def utilisation(self) -> float:
        """Busy time of all robots / (number of robots x makespan)."""
        if not self.robots or self.makespan <= 0:
            return 0.0
        return sum(r.busy_time for r in self.robots) / (len(self.robots) * self.makespan)

    def robot_utilisation(self, name: str) -> float:
        robot = next(r for r in self.robots if r.name == name)
        return robot.busy_time / self.makespan if self.makespan > 0 else 0.0


def remove_from_heap(pool: list, request) -> None:
    """Take ``request`` (the object itself) out of the heap ``pool``: O(log n), as heappop does, so a rule
    that awards deep in a pool of thousands of requests does not pop and push back all those before it
    (10,000 components: 23.9 million pops for the nearest rule). Priorities are unique, so which of two
    heap layouts holds the same requests changes no choice: every reader takes the pool by priority
    (or its top)."""
    at = next(i for i, waiting in enumerate(pool) if waiting is request)
    last = pool.pop()
    if at < len(pool):
        pool[at] = last  # heapq's own repair of a replaced entry: down to a leaf and back (_siftup stops
        heapq._siftup(pool, at)  # at ``at``), then up past ``at`` where the entry is smaller than its parent
        heapq._siftdown(pool, 0, at)
