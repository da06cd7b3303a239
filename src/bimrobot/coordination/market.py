"""The construction market, in Open-RMF's task-allocation vocabulary (thesis section 4.3.1).

A component (or joint) publishes its requirement as a :class:`TaskRequest`; the dispatcher sends a
:class:`BidNotice` to the robots that are capable of it (payload, platform size, reach, assembly
method); each answers with a :class:`BidProposal` (its estimated cost: travel to the work plus handling
time, seconds, and its estimated finish time); an evaluator awards the task to one proposal:

- ``least-cost`` (default, the thesis' "lowest bidding price"): among the idle robots, the lowest cost.
- ``quickest-finish``: among all capable robots, busy ones included (they bid from the end of their
  current task), the earliest finish; when a busy robot wins, the task waits for it.

Two baselines for comparison, not market mechanisms: ``greedy-nearest`` (the nearest idle capable robot,
whatever its handling speed) and ``random`` (a uniformly random idle capable robot, seeded).

Positions are (x, y) in metres in the site frame; times in seconds.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from bimrobot.site.fleet import RobotSpec
from bimrobot.core.errors import InputError
from bimrobot.sco import timing
from bimrobot.core.tasks import Task

TOLERANCE_M = 1e-6


@dataclass(eq=False)
class TaskRequest:
    """One construction task published by a component (transport, position) or a joint (assemble).

    ``start``: where the robot begins the work (yard pick-up for transport, the component or joint
    otherwise), ``end``: where it finishes (x, y metres, site frame). ``reach_needed``: height of the
    highest work point above the floor the robot stands on (metres). ``nodes``: connection nodes to
    position; ``points``: fastening points to make (assemble). ``methods``: assembly methods needed.
    """

    id: str
    activity: Task
    component_id: str
    start: np.ndarray
    end: np.ndarray
    floor: int
    priority: tuple
    weight_kg: float = 0.0
    size: tuple[float, float] = (0.0, 0.0)
    reach_needed: float = 0.0
    nodes: int = 0
    points: int = 0
    methods: frozenset[str] = frozenset()
    joint_id: str | None = None
    node_ids: tuple[str, ...] = ()
    predecessors: tuple[str, ...] = ()
    published_at: float = 0.0
    attempts: int = 0

    def __lt__(self, other: "TaskRequest") -> bool:  # heap order
        return self.priority < other.priority


@dataclass(frozen=True)
class BidNotice:
    """The dispatcher's call for proposals on one task request, at simulation time ``time`` (s)."""

    request: TaskRequest
    time: float


@dataclass(frozen=True)
class BidProposal:
    """A robot's answer to a bid notice: ``cost`` = travel + handling (s), ``finish_time`` (s)."""

    robot: str
    request_id: str
    distance: float
    travel_time: float
    handling_time: float
    finish_time: float
    idle: bool

    @property
    def cost(self) -> float:
        return self.travel_time + self.handling_time


def incapability(spec: RobotSpec, request: TaskRequest) -> str | None:
    """Why ``spec`` cannot do ``request`` (one phrase), or None when it can."""
    if not spec.can(request.activity):
        return f"a {spec.kind} robot does not {request.activity}"
    if request.activity == Task.TRANSPORT:
        if request.weight_kg > spec.carry_kg + TOLERANCE_M:
            return f"carry load {spec.carry_kg:g} kg < {request.weight_kg:.1f} kg"
        platform = spec.platform_m  # None: it carries what it holds in its gripper, of any size
        if platform is not None and (request.size[0] > platform[0] + TOLERANCE_M or request.size[1] > platform[1] + TOLERANCE_M):
            return (
                f"platform {spec.platform_m[0]:g} x {spec.platform_m[1]:g} m < "
                f"component {request.size[0]:.2f} x {request.size[1]:.2f} m"
            )
    elif request.activity == Task.POSITION:
        if request.weight_kg > spec.lift_kg + TOLERANCE_M:
            return f"payload {spec.lift_kg:g} kg < {request.weight_kg:.1f} kg"
        if request.reach_needed > spec.reach_m + TOLERANCE_M:
            return f"reach {spec.reach_m:g} m < {request.reach_needed:.2f} m"
    elif request.activity == Task.ASSEMBLE:
        if request.reach_needed > spec.reach_m + TOLERANCE_M:
            return f"reach {spec.reach_m:g} m < {request.reach_needed:.2f} m"
        missing = request.methods - set(spec.methods)
        if missing:
            return f"cannot {'/'.join(sorted(missing))}"
    return None


def handling_time(spec: RobotSpec, request: TaskRequest) -> float:
    """Seconds of work once the robot is at ``request.start`` (for transport: load, drive, unload), from
    the one time model (:mod:`bimrobot.sco.timing`)."""
    times = spec.times
    if request.activity == Task.TRANSPORT:
        return timing.transport_s(times, float(np.hypot(*(request.end - request.start))))
    if request.activity == Task.POSITION:
        return timing.position_s(times, request.nodes)
    return timing.assemble_s(times, request.points)


def propose(spec: RobotSpec, position: np.ndarray, available_at: float, idle: bool, request: TaskRequest) -> BidProposal:
    """The robot's proposal: travel (``distance`` metres) from ``position`` to the work, then handling."""
    distance = float(np.hypot(*(request.start - position)))
    travel = timing.travel_s(spec.times, distance)
    handling = handling_time(spec, request)
    return BidProposal(spec.name, request.id, distance, travel, handling, available_at + travel + handling, idle)


class Evaluator:
    """Chooses one proposal; one subclass per policy. ``idle_only``: whether busy robots bid at all."""

    name: ClassVar[str]
    idle_only: ClassVar[bool] = True

    def choose(self, proposals: list[BidProposal]) -> BidProposal:
        raise NotImplementedError


class LeastCost(Evaluator):
    """The thesis' lowest bidding price: among the idle robots, the lowest cost (ties: robot name)."""

    name = "least-cost"

    def choose(self, proposals: list[BidProposal]) -> BidProposal:
        return min(proposals, key=lambda p: (p.cost, p.robot))


class QuickestFinish(Evaluator):
    """Among all capable robots, busy ones included, the earliest finish (ties: an idle robot, then name)."""

    name = "quickest-finish"
    idle_only = False

    def choose(self, proposals: list[BidProposal]) -> BidProposal:
        return min(proposals, key=lambda p: (p.finish_time, not p.idle, p.robot))


class GreedyNearest(Evaluator):
    """Baseline: the nearest idle robot, whatever its handling speed (ties: robot name)."""

    name = "greedy-nearest"

    def choose(self, proposals: list[BidProposal]) -> BidProposal:
        return min(proposals, key=lambda p: (p.distance, p.robot))


class RandomChoice(Evaluator):
    """Baseline: a uniformly random idle robot, reproducible with its ``seed``."""

    name = "random"

    def __init__(self, seed: int = 0):
        self.rng = np.random.default_rng(seed)

    def choose(self, proposals: list[BidProposal]) -> BidProposal:
        ordered = sorted(proposals, key=lambda p: p.robot)
        return ordered[int(self.rng.integers(len(ordered)))]


#: Policy name -> its evaluator class, in the order the CLI lists them.
EVALUATOR_CLASSES: dict[str, type[Evaluator]] = {
    cls.name: cls for cls in (LeastCost, QuickestFinish, GreedyNearest, RandomChoice)
}
EVALUATORS = tuple(EVALUATOR_CLASSES)


def make_evaluator(name: str, seed: int = 0) -> Evaluator:
    """The evaluator called ``name`` (one of :data:`EVALUATORS`); ``seed`` drives the random baseline."""
    if name not in EVALUATOR_CLASSES:
        raise InputError(f"unknown evaluator {name!r}: choose one of {', '.join(EVALUATORS)}")
    return RandomChoice(seed) if name == RandomChoice.name else EVALUATOR_CLASSES[name]()


# ---------------------------------------------------------------- dispatchers
@dataclass(frozen=True)
class Award:
    """One decision: ``request`` goes to ``robot`` (a name) on its ``proposal``; ``bidders``: how many
    robots proposed (for the event log)."""

    request: TaskRequest
    robot: str
    proposal: BidProposal
    bidders: int


class Dispatcher:
    """Who decides at a decision point of the event simulation (a robot free with ready work it can do,
    or ready work with a free capable robot): the market, or an agent
    (:class:`bimrobot.planning.dispatch.DispatchEnv`).

    :meth:`awards` is called once per allocation round, at simulation time ``sim.build.env.now``; it changes
    nothing, and the simulation then applies the awards in order. ``None`` means the driver of the
    simulation decides (``ConstructionSimulation.award`` and ``end_round``)."""

    name: ClassVar[str] = "agent"

    def awards(self, sim) -> list[Award] | None:
        return None


class MarketDispatcher(Dispatcher):
    """The thesis' market as a dispatcher: every pending request, highest priority first (assembly, then
    positioning, then transport), goes out as a bid notice to the capable robots, and ``evaluator``
    awards it to one proposal. A request nobody can take now stays pending; after ``4 x robots + 4`` of
    those in a row, an activity's round stops. With ``quickest-finish`` a request may wait for a busy
    robot that would finish it sooner; later requests of the round then queue behind it."""

    def __init__(self, evaluator: Evaluator):
        self.evaluator = evaluator
        self.name = evaluator.name

    def awards(self, sim) -> list[Award]:
        chosen: list[Award] = []
        # robot -> (free at s, where it will stand): awarded in this round, or waited for (quickest finish)
        taken: dict[str, tuple[float, np.ndarray]] = {}
        promised: dict[str, tuple[float, np.ndarray]] = {}
        for activity in (Task.ASSEMBLE, Task.POSITION, Task.TRANSPORT):
            idle = set(sim.build.idle[activity]) - taken.keys()
            pool = list(sim.build.pending[activity])  # a copy of the heap: popped in priority order
            deferred, scan_limit = 0, 4 * sim.build.robots_per_activity[activity] + 4
            while pool and idle and deferred < scan_limit:
                request = heapq.heappop(pool)
                proposals = self._proposals(sim, BidNotice(request, sim.build.env.now), idle, taken, promised)
                if not proposals:
                    deferred += 1
                    continue
                winner = self.evaluator.choose(proposals)
                if not winner.idle:  # quickest finish: wait for the busy robot that finishes sooner
                    promised[winner.robot] = (winner.finish_time, request.end)
                    deferred += 1
                    continue
                chosen.append(Award(request, winner.robot, winner, len(proposals)))
                taken[winner.robot] = (winner.finish_time, request.end)
                idle.discard(winner.robot)
        return chosen

    def _proposals(self, sim, notice: BidNotice, idle: set[str], taken: dict, promised: dict) -> list[BidProposal]:
        """The proposals of the capable robots: idle ones from where they are now; with
        ``quickest-finish`` busy ones too, from where and when their current (or promised) task ends."""
        request, now = notice.request, notice.time
        if self.evaluator.idle_only:
            candidates = [sim.build.robots[name] for name in idle]
        else:
            candidates = [r for r in sim.build.robots.values() if r.spec.can(request.activity) and not r.broken]
        proposals = []
        for robot in candidates:
            if incapability(robot.spec, request):
                continue
            name = robot.spec.name
            if name in promised:  # already waited for by an earlier request
                (available, position), free = promised[name], False
            elif name in taken:
                (finish, position), free = taken[name], False
                available = max(now, finish)
            elif robot.task is None:
                available, position, free = now, sim.position_now(robot), True
            else:
                available, position, free = max(now, robot.free_at), robot.end_position, False
            proposals.append(propose(robot.spec, position, available, free, request))
        return proposals
