"""Discrete-event simulation of a market-coordinated robotic build (SimPy; thesis section 4.5).

Smart components publish their requirements as task requests, capable robots bid, the evaluator awards
and the robots drive (straight lines at their speed, site frame x/y in metres) and work (handling times
from the fleet). Several robots work at once. Rules, as in the thesis:

- Floor by floor (Listing 4.1): the components of floor f+1 are requested only when every joint of
  floor f is Assembled (a column's top joint belongs to the floor of the beams it carries).
- A component is requested for transport (it is a *required connection component*) once the
  components that carry it have their position fixed: columns before the beams they carry.
- On arrival a component asks to be positioned (all its nodes, ``time_per_node`` each); once every
  component of a joint has its position fixed the joint asks to be assembled (all its points,
  ``time_per_point`` each). A component is Assembled when all its nodes are.
- A robot that breaks down (``breakdowns``) drops its task: the component stays where it is, its
  state goes back to the waiting state and the task is auctioned again (logged). It stays out of the
  market for good, or for its repair time when one is given.

Times are seconds from the start of the build.
"""

from __future__ import annotations

import heapq
import logging
from dataclasses import dataclass, field, replace

import numpy as np
import simpy

from bimrobot.site.fleet import ACTIVITIES, Fleet, RobotSpec, Site, default_site
from bimrobot.coordination.market import (
    Award,
    Dispatcher,
    MarketDispatcher,
    TaskRequest,
    incapability,
    make_evaluator,
    propose,
)
from bimrobot.core.errors import BimrobotError, InputError
from bimrobot.sco import timing
from bimrobot.sco.build import SmartModel, gc_paused
from bimrobot.sco.component import Component, Joint
from bimrobot.sco.states import Event, State, at_least
from bimrobot.core.tasks import TASKS, Activity, Task  # Activity: the one schedule row, re-exported here

log = logging.getLogger(__name__)

ACTIVITY_RANK = {task: task.rank for task in TASKS}  # assemble first: the work nearest to done
#: A yard or robot home farther than this from the building (metres) is a mistake in the site file
#: (e.g. a georeferenced model_offset), not a site: robots would drive for days.
MAX_SITE_DISTANCE_M = 10_000.0


@dataclass
class RobotStats:
    name: str
    kind: str
    steps: int = 0
    busy_time: float = 0.0
    travel_time: float = 0.0
    handling_time: float = 0.0
    broken_at: float | None = None


@dataclass(eq=False)
class _Robot:
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
    robots: dict[str, _Robot]  # name -> the robot, in fleet order
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


def gid_on_site(component: Component, later: set[str]) -> bool:
    """A prebuilt component on site from the start (not one made once what it rests on is placed)."""
    return component.prebuilt and component.id not in later


def _storey_base(z: float, elevations: list[float]) -> float:
    """Elevation of the floor a robot stands on to work at height z (highest storey at or below z)."""
    below = [e for e in elevations if e <= z + 1e-6]
    return max(below) if below else min(elevations, default=0.0)


class ConstructionSimulation:
    """One build of ``smart`` by ``fleet`` on ``site``; call :meth:`run`.

    ``evaluator``: least-cost | quickest-finish | greedy-nearest | random. ``breakdowns``: (robot name,
    time s) pairs, the robot stops for good at that time, or (robot name, time s, repair s) triples, it
    is back in the market after the repair. ``storey_elevations``: metres, to compute the
    reach a node needs (height above the floor the robot stands on); defaults to ground level 0.
    ``on_assembled``: called with the component id whenever a component becomes Assembled (progress).
    ``per_node``: positioning and assembly are tasks per connection node (thesis l.4214-4218), as in the
    thesis' loop: a node asks to be positioned once its component and its joint partners have arrived
    (ACC), to be assembled once its position is fixed; a component carries others once one of its nodes
    is fixed. A node of a prebuilt component (a footing's anchor bolts) is assembled with the robot-built
    node of its joint (the column's foot): that node's assembly task carries both nodes' points and is
    published once the prebuilt node is in place, so every assembly point is some robot's work. Default
    True; False (``--per-joint``): positioning per component, assembly per joint.
    ``dispatcher``: who awards the tasks at each allocation round (:class:`~bimrobot.coordination.market.Dispatcher`);
    default the market with ``evaluator``. An agent drives the run itself: :meth:`start`, then
    :meth:`advance` to each decision point, :meth:`award` and :meth:`end_round`, and :meth:`result`.
    Raises InputError before simulating when a component cannot be handled by any robot of the fleet.
    """

    def __init__(
        self,
        smart: SmartModel,
        fleet: Fleet,
        site: Site | None = None,
        evaluator: str = "least-cost",
        seed: int = 0,
        breakdowns: list[tuple] | tuple = (),
        storey_elevations: list[float] | None = None,
        on_assembled=None,
        per_node: bool = False,
        dispatcher: Dispatcher | None = None,
    ):
        # A run moves and advances its components: it works on a copy, so the caller's model stays as
        # built and can be simulated again (another fleet, evaluator or seed).
        self.smart = smart.copy_for_run()
        self.per_node = per_node
        self.on_assembled = on_assembled
        self.fleet = fleet
        self.site = site or default_site()
        self.evaluator = make_evaluator(evaluator, seed)
        self.dispatcher = dispatcher or MarketDispatcher(self.evaluator)
        self.breakdowns = [(b[0], float(b[1]), float(b[2]) if len(b) > 2 and b[2] is not None else None) for b in breakdowns]
        self.elevations = sorted(storey_elevations or [0.0])
        names = {r.name for r in fleet.robots}
        for robot, when, repair in self.breakdowns:
            if robot not in names:
                raise InputError(f"breakdown names robot {robot!r}, which is not in fleet {fleet.name} ({', '.join(sorted(names))})")
            if when < 0 or (repair is not None and repair <= 0):
                raise InputError(f"breakdown of {robot}: time must be >= 0 s and repair > 0 s, got {when} and {repair}")
        self._rests_memo: dict[tuple[str, str], bool] = {}
        self._anchor_memo: dict[str, bool] = {}
        self._place_on_site()
        self._check_capabilities()

    # ---------------------------------------------------------------- set-up
    def _place_on_site(self) -> None:
        comps = list(self.smart.components.values())
        if all(c.prebuilt for c in comps):
            raise InputError(
                f"every one of the {len(comps)} components of {self.smart.source} is prebuilt: nothing is left for "
                "the robots to build (see --prebuilt)"
            )
        centres = np.array([c.target_position[:2] for c in comps])
        self.offset = self.site.offset_for(centres.min(axis=0), centres.max(axis=0))
        building = (centres.min(axis=0) + centres.max(axis=0)) / 2 + self.offset
        places = [("yard position", p, self.site.source) for p in self.site.yard]
        places += [("robot home", p, self.site.source) for p in self.site.robot_home]
        places += [(f"home of robot {r.name}", self.fleet.home_on_site(r, self.offset), self.fleet.source)
                   for r in self.fleet.robots if r.home_m]
        for what, point, source in places:
            distance = float(np.hypot(*(np.asarray(point, dtype=float) - building)))
            if distance > MAX_SITE_DISTANCE_M:
                raise InputError(
                    f"{source}: {what} ({point[0]:g}, {point[1]:g}) is {distance / 1000:,.1f} km from the building "
                    f"(centred at ({building[0]:.1f}, {building[1]:.1f}) m in the site frame); a site is at most "
                    f"{MAX_SITE_DISTANCE_M / 1000:g} km across: check the positions and model_offset"
                )
        self.yard_of: dict[str, np.ndarray] = {}
        to_build = sorted((c for c in comps if not c.prebuilt), key=lambda c: (c.floor, c.bottom_z, c.id))
        for index, component in enumerate(to_build):
            slot = np.array(self.site.yard[index % len(self.site.yard)], dtype=float)
            self.yard_of[component.id] = slot
            component.position = np.array([slot[0], slot[1], 0.0])

    def site_xy(self, model_point: np.ndarray) -> np.ndarray:
        """Model-frame point -> site-frame (x, y), metres."""
        return np.asarray(model_point[:2], dtype=float) + self.offset

    def _reach_for_component(self, component: Component) -> float:
        points = [n.position[2] for n in component.connection_nodes] or [component.target_position[2]]
        return max(z - _storey_base(z, self.elevations) for z in points)

    def _reach_for_joint(self, joint: Joint) -> float:
        z = float(joint.position[2])
        return z - _storey_base(z, self.elevations)

    def request_for(self, activity: Task, component: Component, joint: Joint | None = None, node=None) -> TaskRequest:
        """The task request for ``activity`` of ``component`` (or ``joint``): where the work is on the site,
        what it weighs, the reach, nodes and points it needs; with ``node`` a per-node positioning or assembly
        task. The market, the thesis loop and the exact planner all ask here, so a task is described once."""
        if node is not None:
            request = self.request_for(activity, component, self.smart.joints[node.joint_id] if activity == Task.ASSEMBLE else None)
            request.start = request.end = self.site_xy(node.position)
            request.node_ids = (node.id,)
            if activity == Task.ASSEMBLE:  # with the prebuilt nodes of its joint (e.g. a footing's anchor bolts)
                request.node_ids += tuple(self.build.attached_nodes.get(node.id, ()))
            request.floor = node.level
            z = float(node.position[2])
            request.reach_needed = z - _storey_base(z, self.elevations)
            if activity == Task.POSITION:
                request.nodes = 1
            else:
                nodes = [self.smart.nodes[n] for n in request.node_ids]
                request.points = sum(n.assembly_point_number for n in nodes)
                request.methods = frozenset(n.assembly_method for n in nodes)
            return request
        if activity == Task.TRANSPORT:
            start, end = self.yard_of[component.id], self.site_xy(component.target_position)
        elif activity == Task.POSITION:
            start = end = self.site_xy(component.target_position)
        else:
            start = end = self.site_xy(joint.position)
        request = TaskRequest(
            id="",
            activity=activity,
            component_id=component.id,
            start=start,
            end=end,
            floor=joint.floor if joint else component.floor,
            priority=(0,),
            weight_kg=component.weight_kg or 0.0,
            size=(component.size[0], component.size[1]),
        )
        if activity == Task.POSITION:
            request.nodes = component.node_number
            request.reach_needed = self._reach_for_component(component)
        elif activity == Task.ASSEMBLE:
            nodes = [self.smart.nodes[n] for n in joint.node_ids]
            request.joint_id = joint.id
            request.node_ids = joint.node_ids
            request.points = sum(n.assembly_point_number for n in nodes)
            request.methods = frozenset(n.assembly_method for n in nodes)
            request.reach_needed = self._reach_for_joint(joint)
        return request

    def joints_to_build(self) -> list[Joint]:
        """Joints with at least one node still to assemble (joints among prebuilt parts are done)."""
        return [
            joint for joint in self.smart.joints.values()
            if any(self.smart.nodes[n].state != State.ASSEMBLED for n in joint.node_ids)
        ]

    def _check_capabilities(self) -> None:
        """Pre-flight: every component and joint must be doable by some robot of the fleet.

        Raises ONE InputError listing everything the fleet cannot do, grouped by IFC class with the
        capacity it would need (mass, platform length x width, reach), and what the fleet has.
        """
        # Robots with the same abilities answer alike: check one of each.
        distinct: dict[str, list[RobotSpec]] = {}
        for activity in ACTIVITIES:
            seen = {}
            for r in self.fleet.by_activity(activity):
                seen.setdefault((r.kind, r.carry_kg, r.platform_m, r.lift_kg, r.reach_m, r.methods), r)
            distinct[activity] = list(seen.values())

        def impossible(request: TaskRequest) -> bool:
            return all(incapability(r, request) for r in distinct[request.activity])

        by_class: dict[str, dict] = {}
        to_build = [c for c in self.smart.components.values() if not c.prebuilt]
        for component in to_build:
            for activity in (Task.TRANSPORT, Task.POSITION):
                request = self.request_for(activity, component)
                if not impossible(request):
                    continue
                need = by_class.setdefault(component.what, {"ids": set(), Task.TRANSPORT: None, Task.POSITION: None})
                need["ids"].add(component.id)
                worst = need[activity] or {"kg": 0.0, "length": 0.0, "width": 0.0, "reach": 0.0, "example": component.id}
                if request.weight_kg > worst["kg"]:
                    worst["example"] = component.id
                worst["kg"] = max(worst["kg"], request.weight_kg)
                worst["length"] = max(worst["length"], request.size[0])
                worst["width"] = max(worst["width"], request.size[1])
                worst["reach"] = max(worst["reach"], request.reach_needed)
                need[activity] = worst
        joints = self.joints_to_build()
        failing_joints, joint_reach, joint_methods = [], 0.0, set()
        for joint in joints:
            owner = self.smart.components[joint.component_ids[0]]
            request = self.request_for(Task.ASSEMBLE, owner, joint)
            if impossible(request):
                failing_joints.append(joint.id)
                joint_reach = max(joint_reach, request.reach_needed)
                joint_methods |= set(request.methods)
        if not by_class and not failing_joints:
            return
        parts = []
        for ifc_class, need in sorted(by_class.items(), key=lambda item: (-len(item[1]["ids"]), item[0])):
            wants = []
            if need[Task.TRANSPORT]:
                t = need[Task.TRANSPORT]
                wants.append(f"a carrier for up to {t['kg']:,.0f} kg and {t['length']:.2f} x {t['width']:.2f} m")
            if need[Task.POSITION]:
                q = need[Task.POSITION]
                wants.append(f"a positioner for up to {q['kg']:,.0f} kg at {q['reach']:.2f} m reach")
            example = (need[Task.TRANSPORT] or need[Task.POSITION])["example"]
            count = len(need["ids"])
            parts.append(f"{count} {ifc_class} need{'s' if count == 1 else ''} {' and '.join(wants)} (e.g. {example})")
        if failing_joints:
            parts.append(
                f"{len(failing_joints)} joints need an assembler with {joint_reach:.2f} m reach doing "
                f"{', '.join(sorted(joint_methods))} (e.g. {failing_joints[0]})"
            )
        stronger = ", e.g. --fleet site-crane" if self.fleet.name != "site-crane" else ""
        remedy = f"give a stronger fleet{stronger}"
        if any(self.smart.components[i].part_ids for need in by_class.values() for i in need["ids"]):  # units
            remedy = f"build the units element by element with --by-element, give a fleet with a longer platform and payload{stronger}"
        counts = []
        if by_class:
            counts.append(f"{sum(len(n['ids']) for n in by_class.values())} of {len(to_build)} components")
        if failing_joints:
            counts.append(f"{len(failing_joints)} of {len(joints)} joints")
        raise InputError(
            f"fleet {self.fleet.name} cannot build {' and '.join(counts)}: {'; '.join(parts)}; "
            f"the fleet {self._capacity_text(distinct)} ({remedy}, mark cast-in-place "
            "classes as work of others with --prebuilt, or leave elements out with --exclude)"
        )

    @staticmethod
    def _capacity_text(distinct: dict[str, list[RobotSpec]]) -> str:
        """What the fleet can do at most, per activity, in words."""
        words = []
        carriers, positioners, assemblers = distinct[Task.TRANSPORT], distinct[Task.POSITION], distinct[Task.ASSEMBLE]
        if carriers:
            decks = [r.platform_m for r in carriers if r.platform_m is not None]
            size = ("of any size in a gripper" if len(decks) < len(carriers) else
                    f"on up to {max(d[0] for d in decks):g} x {max(d[1] for d in decks):g} m")
            words.append(f"carries at most {max(r.carry_kg for r in carriers):,.0f} kg {size}")
        else:
            words.append("has no transport robot")
        if positioners:
            words.append(
                f"positions at most {max(r.lift_kg for r in positioners):,.0f} kg with up to "
                f"{max(r.reach_m for r in positioners):g} m reach"
            )
        else:
            words.append("has no positioning robot")
        if assemblers:
            methods = sorted({m for r in assemblers for m in r.methods})
            words.append(f"assembles with up to {max(r.reach_m for r in assemblers):g} m reach ({', '.join(methods)})")
        else:
            words.append("has no assembly robot")
        return ", ".join(words[:-1]) + " and " + words[-1]

    # ---------------------------------------------------------------- run
    def run(self) -> SimulationResult:
        """Build the whole structure with the market (or the given dispatcher) and return the result."""
        self.start()
        with gc_paused():
            self.build.env.run()
        return self.result()

    def advance(self) -> bool:
        """Run the events until an agent's decision is due (True) or nothing is left to happen (False).
        Only with a dispatcher whose ``awards`` returns None (an agent)."""
        while not self.build.awaiting_decision:
            if self.build.env.peek() == float("inf"):
                return False
            self.build.env.step()
        return True

    def start(self) -> None:
        """Set up the run: robots at their homes, the first floor's requests published, breakdowns
        scheduled; the first allocation round is due at t = 0."""
        robots: dict[str, _Robot] = {}
        for index, spec in enumerate(self.fleet.robots):
            home = np.array(self.site.robot_start(index, self.fleet.home_on_site(spec, self.offset)), dtype=float)
            robots[spec.name] = _Robot(spec, home.copy(), RobotStats(spec.name, spec.kind), end_position=home.copy())
        self.build = BuildState(
            env=simpy.Environment(),
            robots=robots,
            robots_per_activity={a: len(self.fleet.by_activity(a)) for a in ACTIVITIES},
            idle={a: {r.spec.name for r in robots.values() if r.spec.can(a)} for a in ACTIVITIES},
            pending={a: [] for a in ACTIVITIES},
            history={c.id: [(0.0, str(c.state))] for c in self.smart.components.values()},
            open_on_floor=[0] * len(self.smart.floors),
        )
        components = self.smart.components
        later = set(self.smart.prebuilt_later)
        # Everything not in place yet waits for its supporters: robot-built components and prebuilt ones
        # that rest on robot-built ones (made by others once those are fixed).
        self.build.missing_supporters = {
            gid: sum(1 for s in self.smart.supporters[gid] if not at_least(components[s].state, State.POSITION_FIXED))
            for gid, c in components.items()
            if not c.prebuilt or gid in later
        }
        for gid, supporters in self.smart.supporters.items():
            for s in supporters:
                self.build.dependants.setdefault(s, []).append(gid)
        if self.per_node:
            for joint in self.smart.joints.values():
                robot_nodes = [n for n in joint.node_ids if not components[self.smart.nodes[n].component_id].prebuilt]
                for node_id in joint.node_ids:
                    if robot_nodes and node_id not in robot_nodes and self.smart.nodes[node_id].state != State.ASSEMBLED:
                        self.build.attached_nodes.setdefault(robot_nodes[0], []).append(node_id)
                        self.build.attached_to[node_id] = robot_nodes[0]
            for component in components.values():
                if component.prebuilt and gid_on_site(component, later):
                    self._prebuilt_nodes_done(component)
            for node in self.smart.nodes.values():
                if (not components[node.component_id].prebuilt or node.id in self.build.attached_to) and node.state != State.ASSEMBLED:
                    self.build.open_on_floor[node.level] += 1
        else:
            for joint in self.joints_to_build():
                self.build.open_on_floor[joint.floor] += 1
        for component in components.values():
            if not component.connection_nodes and not component.prebuilt:
                self.build.open_on_floor[component.floor] += 1
        for gid, missing in self.build.missing_supporters.items():
            if missing == 0 and gid not in later:
                self.build.ready_by_floor.setdefault(components[gid].floor, []).append(gid)
        for joint in self.joints_to_build() if not self.per_node else ():  # e.g. a footing joint of prebuilt parts only
            self._maybe_publish_assembly(joint)
        self._open_floor(0)
        self.build.repairs = [self.build.env.process(self._breakdown(robot, when, repair)) for robot, when, repair in self.breakdowns]
        self._request_dispatch()

    def result(self) -> SimulationResult:
        """The finished run. Raises BimrobotError when the build stalled with components unfinished."""
        components = self.smart.components
        unfinished = [c.id for c in components.values() if c.state != State.ASSEMBLED]
        if unfinished:
            raise BimrobotError(self._stall_reason(unfinished))
        makespan = max((a.finish for a in self.build.activities if not a.aborted), default=0.0)
        self._number_by_start()
        log.info("%s built by %s (%s): makespan %.1f s, %d allocation rounds", self.smart.source, self.fleet.name, self.dispatcher.name, makespan, self.build.steps)
        return SimulationResult(
            model=self.smart.source,
            fleet=self.fleet.name,
            evaluator=self.dispatcher.name,
            makespan=makespan,
            steps=self.build.steps,
            activities=self.build.activities,
            robots=[r.stats for r in self.build.robots.values()],
            events=self.build.events,
            log_lines=self.build.lines,
            state_history=self.build.history,
            floor_finish=self.build.floor_finish,
            smart_summary=self.smart.summary(),
            breakdowns=self.breakdowns,
            per_node=self.per_node,
            built=self.smart,
            site_source=self.site.source,
            model_offset=(round(float(self.offset[0]), 4), round(float(self.offset[1]), 4)),
        )

    def _number_by_start(self) -> None:
        """Identifications A0001... in start order (they were given in finish order)."""
        self.build.activities.sort(key=lambda a: (a.start, a.finish, a.id))
        width = max(4, len(str(len(self.build.activities))))
        new_id = {a.id: f"A{i:0{width}d}" for i, a in enumerate(self.build.activities, start=1)}
        self.build.activities[:] = [replace(a, id=new_id[a.id], predecessors=tuple(new_id[p] for p in a.predecessors))
                              for a in self.build.activities]

    def _stall_reason(self, unfinished: list[str]) -> str:
        waiting = [t for pool in self.build.pending.values() for t in pool]
        alive = [r.spec for r in self.build.robots.values() if not r.broken]
        for task in waiting:
            if all(incapability(spec, task) for spec in alive):
                broken = ", ".join(r.spec.name for r in self.build.robots.values() if r.broken) or "none"
                what = f"joint {task.joint_id}" if task.activity == Task.ASSEMBLE else f"component {task.component_id}"
                return (
                    f"the build stalled at t = {self.build.env.now:.1f} s: no working robot can {task.activity} "
                    f"{what} (broken down: {broken}); {len(unfinished)} components unfinished"
                )
        return f"the build stalled at t = {self.build.env.now:.1f} s with {len(unfinished)} components unfinished, e.g. {unfinished[0]}"

    # ---------------------------------------------------------------- bookkeeping
    def _event(self, kind: str, **data) -> None:
        self.build.events.append({"time": round(self.build.env.now, 3), "step": self.build.steps, "event": kind, **data})

    def _say(self, text: str) -> None:
        self.build.lines.append(f"[{self.build.env.now:9.2f} s] {text}")

    def _note_state(self, component: Component) -> None:
        history = self.build.history[component.id]
        if history[-1][1] != str(component.state):
            history.append((self.build.env.now, str(component.state)))
            self._event("state", component=component.id, state=str(component.state))
            if component.state == State.ASSEMBLED and self.on_assembled is not None:
                self.on_assembled(component.id)

    def _publish(self, activity: Task, component: Component, joint: Joint | None = None, predecessors=(), node=None) -> None:
        request = self.request_for(activity, component, joint, node)
        self.build.sequence += 1
        request.priority = (request.floor, ACTIVITY_RANK[activity], round(component.bottom_z, 3), self.build.sequence)
        request.id = f"R{self.build.sequence:05d}"
        request.published_at = self.build.env.now
        request.predecessors = tuple(p for p in predecessors if p)
        heapq.heappush(self.build.pending[activity], request)
        self._event(
            "task_request",
            request=request.id,
            activity=activity,
            component=component.id,
            joint=joint.id if joint else None,
            node=node.id if node is not None else None,
            release=self._release_rule(activity, node),
            requirement=str(Task(activity).requirement),
        )
        self._request_dispatch()

    def _release_rule(self, activity: Task, node) -> str:
        """Why a request is released (thesis l.4240-4262): transport of a required connection component
        (RCC) once what carries it stands; a node's positioning once its arrived connection components
        (ACC) are all there; per joint, a component's positioning once it has arrived (Arrived); assembly
        once the position is fixed (PositionFixed)."""
        if activity == Task.TRANSPORT:
            return "RCC"
        if activity == Task.POSITION:
            return "ACC" if node is not None else "Arrived"
        return "PositionFixed"

    def _open_floor(self, floor: int) -> None:
        """Make ``floor`` current and request the components whose supporters are in place."""
        self.build.current_floor = floor
        self._say(f"Floor {floor + 1} ({self.smart.floor_names[floor]}) starts")
        self._event("floor_start", floor=floor + 1, storey=self.smart.floors[floor])
        for gid in sorted(self.build.ready_by_floor.pop(floor, []), key=lambda g: (self.smart.components[g].bottom_z, g)):
            self._publish_transport(gid)
        self._maybe_close_floor()

    def _publish_transport(self, gid: str) -> None:
        component = self.smart.components[gid]
        supporters = self.smart.supporters[gid]
        if supporters:
            self._say(
                f"Component: {gid} is a required connection component (RCC) of {', '.join(supporters)}, "
                f"whose position is fixed: publish its transport"
            )
        predecessors = [a for s in supporters for a in self.build.position_activity.get(s, ())]
        predecessors.append(self.build.floor_gate.get(component.floor))
        self._publish(Task.TRANSPORT, component, predecessors=list(dict.fromkeys(predecessors)))

    def _maybe_close_floor(self) -> None:
        while self.build.open_on_floor[self.build.current_floor] == 0:
            self.build.floor_finish.append(self.build.env.now)
            self._say(f"Floor {self.build.current_floor + 1} is complete")
            self._event("floor_complete", floor=self.build.current_floor + 1)
            if self.build.current_floor + 1 >= len(self.smart.floors):
                return
            # the activity that completed the floor (an assembly, or the positioning of a part without
            # nodes) gates the next floor's transports: the schedule says so, and RCAN waits for it too
            last = next((a.id for a in reversed(self.build.activities) if not a.aborted), None)
            self.build.floor_gate[self.build.current_floor + 1] = last
            self.build.current_floor += 1
            self._say(f"Floor {self.build.current_floor + 1} ({self.smart.floor_names[self.build.current_floor]}) starts")
            self._event("floor_start", floor=self.build.current_floor + 1, storey=self.smart.floors[self.build.current_floor])
            for gid in sorted(self.build.ready_by_floor.pop(self.build.current_floor, []), key=lambda g: (self.smart.components[g].bottom_z, g)):
                self._publish_transport(gid)

    def _maybe_publish_assembly(self, joint: Joint) -> None:
        if joint.id in self.build.assembly_published:
            return
        if all(self.smart.nodes[n].state == State.ASSEMBLED for n in joint.node_ids):
            return  # made with the prebuilt parts it joins
        members = [self.smart.components[g] for g in joint.component_ids]
        if not all(at_least(m.state, State.POSITION_FIXED) for m in members):
            return
        self.build.assembly_published.add(joint.id)
        for node_id in joint.node_ids:
            node = self.smart.nodes[node_id]
            component = self.smart.components[node.component_id]
            component.node_event(node, Event.PUBLISH_ASSEMBLY)
            self._note_state(component)
        predecessors = [a for m in members for a in self.build.position_activity.get(m.id, ())]
        self._publish(Task.ASSEMBLE, members[0], joint, list(dict.fromkeys(predecessors)))

    # ---------------------------------------------------------------- market
    def _request_dispatch(self) -> None:
        if not self.build.dispatch_scheduled:
            self.build.dispatch_scheduled = True
            self.build.env.process(self._dispatch_soon())

    def _dispatch_soon(self):
        """One allocation round, once the events of this instant have published their requests: the
        dispatcher's awards, then (``idle_robots: yard``) idle robots drive back to the yard. With an
        agent as dispatcher the round stays open (``awaiting_decision``) until its driver calls
        :meth:`end_round`, and nothing else happens in between."""
        yield self.build.env.timeout(0)
        self.build.dispatch_scheduled = False
        self.build.round_awarded = False
        awards = self.dispatcher.awards(self)
        if awards is None:  # an agent decides
            if self.has_decision():
                self.build.awaiting_decision = True
                return
        else:
            for award in awards:
                self.apply_award(award)
        self.end_round()

    def end_round(self) -> None:
        """Close the allocation round: robots left without a task drive to the yard (``idle_robots: yard``)."""
        self.build.awaiting_decision = False
        if self.site.idle_robots == "yard":
            self._send_idle_robots_to_yard()

    def _send_idle_robots_to_yard(self) -> None:
        """Robots left without a task after working drive to the nearest yard position (thesis 4.5.3)."""
        yard = np.array(self.site.yard, dtype=float)
        for robot in self.build.robots.values():
            if robot.task is not None or robot.broken or robot.returning is not None or robot.stats.steps == 0:
                continue
            target = yard[int(np.argmin(np.hypot(*(yard - robot.position).T)))]
            if np.hypot(*(target - robot.position)) > 1e-6:
                robot.returning = self.build.env.process(self._return_to_yard(robot, target))

    def _return_to_yard(self, robot: _Robot, target: np.ndarray):
        self._say(f"{robot.spec.name} has no task and returns to the yard at ({target[0]:.2f}, {target[1]:.2f})")
        try:
            yield from self._drive(robot, target)
        except simpy.Interrupt:
            return  # called away: _stop_return already took the position where it was
        robot.returning = None

    def _stop_return(self, robot: _Robot) -> None:
        """Stop a robot on its way back to the yard, where it is now (travel so far counted)."""
        if robot.returning is None:
            return
        if robot.returning.is_alive:
            t0 = robot.leg[0] if robot.leg else self.build.env.now
            robot.position = self._position_now(robot)
            robot.stats.travel_time += self.build.env.now - t0
            robot.leg = None
            robot.returning.interrupt("new task")
            self._event("return_stopped", robot=robot.spec.name, x=round(float(robot.position[0]), 3), y=round(float(robot.position[1]), 3))
        robot.returning = None

    # ---------------------------------------------------------------- decisions (any dispatcher)
    def decision_candidates(self) -> list[tuple[TaskRequest, str]]:
        """Every (pending request, idle robot name) pair that could be awarded now, in the market's order:
        assembly, positioning, transport; each pool by priority; robots by name."""
        pairs = []
        for activity in (Task.ASSEMBLE, Task.POSITION, Task.TRANSPORT):
            names = sorted(self.build.idle[activity])
            if not names:
                continue
            for request in sorted(self.build.pending[activity]):
                pairs += [(request, name) for name in names if not incapability(self.build.robots[name].spec, request)]
        return pairs

    def has_decision(self) -> bool:
        """Whether some pending request has an idle robot that can do it (a decision point)."""
        for activity, pool in self.build.pending.items():
            names = self.build.idle[activity]
            if pool and names and any(not incapability(self.build.robots[n].spec, r) for r in pool for n in names):
                return True
        return False

    def can_wait(self) -> bool:
        """Whether leaving the ready work pending can lead anywhere: a robot is at work (it will finish and
        open a new round) or a broken one will be repaired. Otherwise waiting would stall the build."""
        return any(r.task is not None for r in self.build.robots.values()) or any(p.is_alive for p in self.build.repairs)

    def award(self, request: TaskRequest, robot_name: str) -> Award:
        """Award ``request`` (pending) to the idle robot ``robot_name`` now, as the market would: the
        robot's proposal from where it is now. Raises ValueError when the pair is not a candidate."""
        robot = self.build.robots.get(robot_name)
        if (robot is None or robot_name not in self.build.idle[request.activity] or request not in self.build.pending[request.activity]
                or incapability(robot.spec, request)):
            raise ValueError(f"{robot_name} cannot take request {request.id} now")
        bidders = sum(1 for name in self.build.idle[request.activity] if not incapability(self.build.robots[name].spec, request))
        proposal = propose(robot.spec, self.position_now(robot), self.build.env.now, True, request)
        award = Award(request, robot_name, proposal, bidders)
        self.apply_award(award)
        return award

    def apply_award(self, award: Award) -> None:
        """Take the awarded request out of its pool and send the robot (the first award of a round opens
        a construction step in the log)."""
        pool = self.build.pending[award.request.activity]
        passed = []
        while (request := heapq.heappop(pool)) is not award.request:
            passed.append(request)
        for request in passed:
            heapq.heappush(pool, request)
        if not self.build.round_awarded:
            self.build.round_awarded = True
            self.build.steps += 1
            self._step_header()
        self._award(award.request, self.build.robots[award.robot], award.proposal, award.bidders)

    def position_now(self, robot: _Robot) -> np.ndarray:
        """Where an idle ``robot`` bids from (site frame x, y, metres): part way along its drive back to
        the yard, else where it stands."""
        return self._position_now(robot) if robot.returning else robot.position

    def where(self, robot: _Robot) -> np.ndarray:
        """Where ``robot`` is now (site frame x, y, metres), part way along any drive."""
        return self._position_now(robot)

    def _step_header(self) -> None:
        self.build.lines.append("-" * 48)
        self.build.lines.append(f"Start a new construction step, NO.{self.build.steps}, in floor {self.build.current_floor + 1} (t = {self.build.env.now:.2f} s)")
        self.build.lines.append("-" * 48)
        self.build.lines.append("Get components requirement from site")

    def _award(self, request: TaskRequest, robot: _Robot, proposal, bidders: int) -> None:
        for activity in robot.spec.activities:
            self.build.idle[activity].discard(robot.spec.name)
        self._stop_return(robot)
        robot.task = request
        robot.free_at = proposal.finish_time
        robot.end_position = request.end
        self.build.lines.append(f"Publish {Task(request.activity).word} requirements to robot")
        cost = proposal.cost
        if request.activity == Task.TRANSPORT:
            self.build.lines.append(f"{robot.spec.name} is working for component: {request.component_id}, total work time is {cost:.2f}s")
        elif request.activity == Task.POSITION:
            nodes = [n.id for n in self.smart.components[request.component_id].connection_nodes]
            self.build.lines.append(
                f"{robot.spec.name} is positioning component: {request.component_id} with nodes: {', '.join(nodes) or '(none)'}, total work time is {cost:.2f}s"
            )
        else:
            self.build.lines.append(f"{robot.spec.name} is finding nodes: {' and '.join(request.node_ids)}, total work time is {cost:.2f}s")
        self._event(
            "award",
            request=request.id,
            activity=request.activity,
            component=request.component_id,
            joint=request.joint_id,
            robot=robot.spec.name,
            cost=round(cost, 3),
            estimated_finish=round(proposal.finish_time, 3),
            bidders=bidders,
        )
        robot.process = self.build.env.process(self._execute(robot, request))

    # ---------------------------------------------------------------- robots
    def _drive(self, robot: _Robot, target: np.ndarray):
        distance = float(np.hypot(*(target - robot.position)))
        duration = timing.travel_s(robot.times, distance)
        robot.leg = (self.build.env.now, robot.position.copy(), self.build.env.now + duration, np.array(target, dtype=float))
        yield self.build.env.timeout(duration)
        robot.position = np.array(target, dtype=float)
        robot.leg = None
        robot.stats.travel_time += duration

    def _position_now(self, robot: _Robot) -> np.ndarray:
        if robot.leg is None:
            return robot.position.copy()
        t0, p0, t1, p1 = robot.leg
        fraction = 1.0 if t1 <= t0 else min(1.0, max(0.0, (self.build.env.now - t0) / (t1 - t0)))
        return p0 + fraction * (p1 - p0)

    def _execute(self, robot: _Robot, request: TaskRequest):
        started = self.build.env.now
        component = self.smart.components[request.component_id]
        spec = robot.spec
        node_windows = None
        try:
            yield from self._drive(robot, request.start)
            if request.activity == Task.TRANSPORT:
                component.update_state(Event.START_TRANSPORT)
                self._note_state(component)
                self.build.lines.append(f"[{self.build.env.now:9.2f} s] Current progress: {spec.name} is loading {component.id}")
                yield self.build.env.timeout(spec.load_s)
                yield from self._drive(robot, request.end)
                yield self.build.env.timeout(spec.unload_s)
                component.position = np.array([*request.end, component.target_position[2]])
                robot.stats.handling_time += spec.load_s + spec.unload_s
            elif request.activity == Task.POSITION:
                if request.node_ids:  # per node
                    self._node_step(self.smart.nodes[request.node_ids[0]], Event.START_POSITIONING)
                else:
                    component.start_positioning()
                self._note_state(component)
                duration = timing.position_s(robot.times, request.nodes)
                yield self.build.env.timeout(duration)
                robot.stats.handling_time += duration
            else:
                nodes = [self.smart.nodes[n] for n in request.node_ids]
                for node in nodes:
                    self._node_step(node, Event.START_ASSEMBLY)
                node_windows = []
                for node in nodes:
                    begin = self.build.env.now
                    duration = timing.assemble_s(robot.times, node.assembly_point_number)
                    yield self.build.env.timeout(duration)
                    robot.stats.handling_time += duration
                    node_windows.append((node, begin, self.build.env.now))
        except simpy.Interrupt:
            self._abort(robot, request, started)
            return
        robot.stats.steps += 1
        robot.stats.busy_time += self.build.env.now - started
        self._finish(robot, request, started, node_windows)

    def _finish(self, robot: _Robot, request: TaskRequest, started: float, node_windows) -> None:
        """The task is done: update the smart objects, record the activity, free the robot."""
        if request.activity == Task.TRANSPORT:
            self._finish_transport(robot, request, started)
        elif request.activity == Task.POSITION:
            self._finish_positioning(robot, request, started)
        else:
            self._finish_assembly(robot, request, started, node_windows)
        name = robot.spec.name
        robot.task = None
        for activity_name in robot.spec.activities:
            self.build.idle[activity_name].add(name)
        self._event("finish", request=request.id, activity=request.activity, component=request.component_id, robot=name)
        self._maybe_close_floor()
        self._request_dispatch()

    def _finish_transport(self, robot: _Robot, request: TaskRequest, started: float) -> None:
        component, name = self.smart.components[request.component_id], robot.spec.name
        component.update_state(Event.FINISH_TRANSPORT)
        self._note_state(component)
        self._say(f"Component: {component.id} is arrived, {name} is free for next work")
        activity = self._record(Task.TRANSPORT, component, f"{Task.TRANSPORT.title} {component.id}", name, started,
                                request.predecessors, work=self._work(request, 0.0, end_z=component.target_position[2]))
        component.publish_positioning()
        self._note_state(component)
        if self.per_node and component.connection_nodes:
            self.build.transport_activity[component.id] = activity.id
            for joint in self.smart.joints_of(component.id):
                for node_id in joint.node_ids:
                    self._maybe_publish_node_positioning(self.smart.nodes[node_id])
            return
        self._publish(Task.POSITION, component, predecessors=[activity.id])

    def _finish_positioning(self, robot: _Robot, request: TaskRequest, started: float) -> None:
        component, name = self.smart.components[request.component_id], robot.spec.name
        if request.node_ids:
            self._finish_node_positioning(robot, request, started)
            return
        component.finish_positioning()
        self._note_state(component)
        self._say(f"Component: {component.id} position is fixed, {name} is free for next work")
        activity = self._record(Task.POSITION, component, f"{Task.POSITION.title} {component.id}", name, started,
                                request.predecessors, work=self._work(request, component.target_position[2], nodes=request.nodes))
        self.build.position_activity[component.id] = (activity.id,)
        if component.state == State.ASSEMBLED:  # no nodes to fasten
            self.build.open_on_floor[component.floor] -= 1
        self._position_fixed(component)

    def _position_fixed(self, component: Component, joints: bool = True) -> None:
        """``component`` stands in place: release what it carries and (``joints``) the joints it completes."""
        for dependant in self.build.dependants.get(component.id, []):  # components it carries
            if dependant not in self.build.missing_supporters:
                continue  # prebuilt and on site from the start
            self.build.missing_supporters[dependant] -= 1
            if self.build.missing_supporters[dependant] == 0:
                carried = self.smart.components[dependant]
                if carried.prebuilt:
                    self._prebuilt_in_place(carried)
                    continue
                if carried.floor <= self.build.current_floor:
                    self._publish_transport(dependant)
                else:
                    self.build.ready_by_floor.setdefault(carried.floor, []).append(dependant)
        for node in component.connection_nodes if joints and not self.per_node else ():
            self._maybe_publish_assembly(self.smart.joints[node.joint_id])

    def _prebuilt_in_place(self, component: Component) -> None:
        """A prebuilt component resting on robot-built ones is made by others now, in no robot time."""
        component.state = State.POSITION_FIXED
        for node in component.connection_nodes:
            if node.state != State.ASSEMBLED:
                done = self.per_node and node.id not in self.build.attached_to  # per node: no robot node assembles it
                node.state = State.ASSEMBLED if done else State.POSITION_FIXED
        if all(node.state == State.ASSEMBLED for node in component.connection_nodes):
            component.state = State.ASSEMBLED
        self._note_state(component)
        supporters = self.smart.supporters[component.id]
        # what put it in place, known before the work that waited for it is published (its predecessors)
        self.build.position_activity[component.id] = tuple(
            dict.fromkeys(a for s in supporters for a in self.build.position_activity.get(s, ()))
        )
        for node in component.connection_nodes:  # per node: the robot-built node it waited for
            if node.id in self.build.attached_to:
                self._maybe_publish_node_assembly(self.smart.nodes[self.build.attached_to[node.id]])
        self._say(
            f"Component: {component.id} (prebuilt, work of others) is in place: what it rests on "
            f"({', '.join(supporters)}) has its position fixed"
        )
        self._event("prebuilt_in_place", component=component.id, supporters=list(supporters))
        self._position_fixed(component)

    def _finish_assembly(self, robot: _Robot, request: TaskRequest, started: float, node_windows) -> None:
        """One schedule row per node: the first includes the drive to the joint."""
        joint, name = self.smart.joints[request.joint_id], robot.spec.name
        previous = None
        for node, begin, end in node_windows:
            owner = self.smart.components[node.component_id]
            self._node_step(node, Event.FINISH_ASSEMBLY)
            if self.per_node:
                self.build.open_on_floor[node.level] -= 1
            row_start = started if previous is None else begin
            predecessors = tuple(request.predecessors) + ((previous,) if previous else ())
            work = self._work(request, node.position[2], points=node.assembly_point_number)
            activity = self._record(Task.ASSEMBLE, owner, f"{Task.ASSEMBLE.title} {node.id}", name, row_start, predecessors,
                                    finish=end, work=work)
            previous = activity.id
        self._say(f"Nodes: {' and '.join(request.node_ids)} are assembled, {name} is free for next work")
        if not self.per_node:
            self.build.open_on_floor[joint.floor] -= 1

    # ---------------------------------------------------------------- per-node work
    def _node_step(self, node, event: Event) -> None:
        """Apply ``event`` to one node and update its component (per node: the component follows its nodes)."""
        owner = self.smart.components[node.component_id]
        if self.per_node and not owner.prebuilt:
            node.update_state(event)
            owner.sync_from_nodes()
        else:  # a prebuilt component's node (per node: assembled with its joint's robot-built node)
            owner.node_event(node, event)
        self._note_state(owner)

    def _prebuilt_nodes_done(self, component: Component) -> None:
        """Per node: a prebuilt component on site has nothing of its own to do (as the footings in Table 4.2);
        its nodes joined to robot-built ones (anchor bolts) are assembled with those nodes."""
        for node in component.connection_nodes:
            if node.id not in self.build.attached_to:
                node.state = State.ASSEMBLED
        if all(node.state == State.ASSEMBLED for node in component.connection_nodes):
            component.state = State.ASSEMBLED
            self.build.history[component.id].append((0.0, str(State.ASSEMBLED)))

    def _maybe_publish_node_positioning(self, node) -> None:
        """Per node: position ``node`` once its component and every partner of its joint have arrived (ACC)."""
        component = self.smart.components[node.component_id]
        if node.id in self.build.node_position_published or component.prebuilt or not at_least(component.state, State.ARRIVED):
            return
        partners = [self.smart.components[p] for p in self.smart.joints[node.joint_id].component_ids if p != component.id]
        if not self._has_anchor(component):
            # every node of it waits for something that rests on it: waiting would deadlock, so its nodes
            # wait only for the partners that can come before it is fixed
            partners = [p for p in partners if not self.rests_on(p.id, component.id)]
        if not all(p.prebuilt or at_least(p.state, State.ARRIVED) for p in partners):
            return
        if self._in_hands(component, node):
            return  # one robot handles a component at a time: its other nodes follow its first positioning
        self.build.node_position_published.add(node.id)
        names = ", ".join(p.id for p in partners)
        self._say(f"Node: {node.id} asks to be positioned: its connection components have arrived (ACC){': ' + names if names else ''}")
        predecessors = [self.build.transport_activity.get(c.id) for c in (component, *partners)]
        predecessors += self.build.position_activity.get(component.id, ())[:1]  # the row that put it in place
        self._publish(Task.POSITION, component, predecessors=predecessors, node=node)

    def _in_hands(self, component: Component, node) -> bool:
        """Whether another node of ``component`` is being positioned and none is fixed yet: the robot doing
        it holds the component, so ``node`` waits until the component stands in place (RCAN's robots hold
        a component one at a time; the schedule says so, and RCAN executes it in the same time)."""
        return component.id not in self.build.position_activity and any(
            other.id != node.id and other.id in self.build.node_position_published for other in component.connection_nodes)

    def rests_on(self, upper: str, lower: str) -> bool:
        """Does ``upper`` rest on ``lower``, directly or through what it rests on (so it cannot arrive first)?"""
        key = (upper, lower)
        if key not in self._rests_memo:
            supporters = self.smart.supporters.get(upper, ())
            self._rests_memo[key] = lower in supporters or any(self.rests_on(s, lower) for s in supporters)
        return self._rests_memo[key]

    def _has_anchor(self, component: Component) -> bool:
        """Per node: has ``component`` a node whose joint partners do not rest on it (a column's foot)? Once
        that node is fixed the component carries what rests on it, so its other nodes can wait for those."""
        if component.id not in self._anchor_memo:
            self._anchor_memo[component.id] = any(
                not any(self.rests_on(p, component.id) for p in self.smart.joints[n.joint_id].component_ids if p != component.id)
                for n in component.connection_nodes
            )
        return self._anchor_memo[component.id]

    def _finish_node_positioning(self, robot: _Robot, request: TaskRequest, started: float) -> None:
        """Per node: the node's position is fixed; it asks to be assembled; the first fixed node lets the
        component carry what rests on it."""
        component, name = self.smart.components[request.component_id], robot.spec.name
        node = self.smart.nodes[request.node_ids[0]]
        self._node_step(node, Event.FINISH_POSITIONING)
        self._say(f"Node: {node.id} position is fixed, {name} is free for next work")
        activity = self._record(Task.POSITION, component, f"{Task.POSITION.title} {node.id}", name, started,
                                request.predecessors, work=self._work(request, node.position[2], nodes=1))
        self.build.node_position_activity[node.id] = activity.id
        first = component.id not in self.build.position_activity
        self.build.position_activity[component.id] = self.build.position_activity.get(component.id, ()) + (activity.id,)
        if first:
            self._position_fixed(component, joints=False)
            for other in component.connection_nodes:  # they waited for the component to stand in place
                if other.id != node.id:
                    self._maybe_publish_node_positioning(other)
        self._maybe_publish_node_assembly(node)

    def _maybe_publish_node_assembly(self, node) -> None:
        """Per node: assemble ``node`` once its position is fixed and the prebuilt nodes assembled with it
        (a footing's anchors) are in place; the task carries their points too."""
        if node.id in self.build.node_assembly_published or node.id not in self.build.node_position_activity:
            return
        attached = [self.smart.nodes[n] for n in self.build.attached_nodes.get(node.id, ())]
        if not all(at_least(n.state, State.POSITION_FIXED) for n in attached):
            return  # a prebuilt component made later is not in place yet
        self.build.node_assembly_published.add(node.id)
        component = self.smart.components[node.component_id]
        predecessors = [self.build.node_position_activity[node.id]]
        for other in attached:
            self._node_step(other, Event.PUBLISH_ASSEMBLY)
            predecessors += self.build.position_activity.get(other.component_id, ())
        self._node_step(node, Event.PUBLISH_ASSEMBLY)
        self._publish(Task.ASSEMBLE, component, self.smart.joints[node.joint_id], predecessors=list(dict.fromkeys(predecessors)), node=node)

    def _work(self, request: TaskRequest, z: float, nodes: int | None = None, points: int | None = None,
              end_z: float | None = None) -> dict:
        """The work columns of a schedule row: where the robot began and ended (``request.start`` and
        ``request.end`` taken back into the model frame, at heights ``z`` and ``end_z`` m) and the nodes or
        points it did (:mod:`bimrobot.sco.timing`)."""
        def model_point(site_xy, height):
            x, y = self.site.to_model(site_xy, self.offset)
            return (round(float(x), 4), round(float(y), 4), round(float(height), 4))

        return {"work_from": model_point(request.start, z), "work_to": model_point(request.end, z if end_z is None else end_z),
                "nodes": nodes, "points": points}

    def _record(self, activity, component, name, robot, start, predecessors, finish=None, aborted=False,
                work: dict | None = None) -> Activity:
        self.build.activity_counter += 1
        origin = self.smart_origin(component)
        row = Activity(
            id=f"A{self.build.activity_counter:04d}",
            activity=activity,
            global_id=component.id,
            name=name,
            robot=robot,
            start=start,
            finish=self.build.env.now if finish is None else finish,
            target=origin,
            storey=component.storey_id or "",
            predecessors=tuple(p for p in predecessors if p),
            aborted=aborted,
            **(work or {}),
        )
        self.build.activities.append(row)
        return row

    @staticmethod
    def smart_origin(component: Component) -> tuple[float, float, float]:
        """Installed position of the component's origin (placement), model frame, metres."""
        point = component.target_position if component.origin is None else component.origin
        return (float(point[0]), float(point[1]), float(point[2]))

    def _breakdown(self, name: str, when: float, repair: float | None):
        yield self.build.env.timeout(when)
        robot = self.build.robots[name]
        self._stop_return(robot)
        robot.broken = True
        robot.stats.broken_at = self.build.env.now
        for activity in ACTIVITIES:
            self.build.idle[activity].discard(name)
        self._say(f"{name} broke down")
        self._event("breakdown", robot=name, request=robot.task.id if robot.task else None)
        if robot.task is not None and robot.process is not None and robot.process.is_alive:
            robot.process.interrupt("breakdown")
        if repair is None:
            return
        yield self.build.env.timeout(repair)
        robot.broken = False
        for activity in robot.spec.activities:
            self.build.idle[activity].add(name)
        self._say(f"{name} is repaired after {repair:g} s and back in the market")
        self._event("repaired", robot=name)
        self._request_dispatch()

    def _abort(self, robot: _Robot, request: TaskRequest, started: float) -> None:
        """Roll the interrupted task back and auction it again; nothing is lost."""
        component = self.smart.components[request.component_id]
        if robot.leg is not None:  # stopped while driving: count the part of the drive it made
            robot.stats.travel_time += self.build.env.now - robot.leg[0]
        robot.position = self._position_now(robot)
        robot.leg = None
        robot.stats.busy_time += self.build.env.now - started
        robot.task = None
        if request.activity == Task.TRANSPORT and component.state == State.IN_TRANSIT:
            component.update_state(Event.ABORT)
            component.position = np.array([robot.position[0], robot.position[1], 0.0])
            self.yard_of[component.id] = robot.position.copy()  # picked up again where it was dropped
        elif request.activity == Task.POSITION and request.node_ids:
            node = self.smart.nodes[request.node_ids[0]]
            if node.state == State.WORKING_IN_POSITIONING:
                self._node_step(node, Event.ABORT)
        elif request.activity == Task.POSITION and component.state == State.WORKING_IN_POSITIONING:
            component.abort_positioning()
        elif request.activity == Task.ASSEMBLE:
            for node_id in request.node_ids:
                node = self.smart.nodes[node_id]
                if node.state == State.WORKING_IN_ASSEMBLY:
                    self._node_step(node, Event.ABORT)
                elif node.state == State.ASSEMBLED:
                    continue
        self._note_state(component)
        self._record(request.activity, component, f"{request.activity.capitalize()} {component.id} (aborted)", robot.spec.name, started, (), aborted=True)
        # Only the nodes not yet assembled remain to be done.
        if request.activity == Task.ASSEMBLE:
            remaining = tuple(n for n in request.node_ids if self.smart.nodes[n].state != State.ASSEMBLED)
            request.node_ids = remaining
            request.points = sum(self.smart.nodes[n].assembly_point_number for n in remaining)
        else:
            request.start = self.yard_of[component.id] if request.activity == Task.TRANSPORT else request.start
        request.attempts += 1
        heapq.heappush(self.build.pending[request.activity], request)
        where = f"({robot.position[0]:.2f}, {robot.position[1]:.2f})"
        if request.activity == Task.ASSEMBLE:
            what = f"assembly of nodes {' and '.join(request.node_ids)}: nodes are {State.WAIT_FOR_ASSEMBLY}"
        else:
            what = f"{request.activity} of {component.id}: {component.id} is {component.state}"
            if request.activity == Task.TRANSPORT:
                what += f" at {where}"
        self._say(f"{robot.spec.name} broke down at {where} during {what}; task {request.id} auctioned again")
        self._event("reauction", request=request.id, activity=request.activity, component=component.id, robot=robot.spec.name, state=str(component.state))
        self._request_dispatch()


def simulate(
    smart: SmartModel,
    fleet: Fleet,
    site: Site | None = None,
    evaluator: str = "least-cost",
    seed: int = 0,
    breakdowns=(),
    storey_elevations: list[float] | None = None,
    on_assembled=None,
    per_node: bool = False,
    dispatcher: Dispatcher | None = None,
) -> SimulationResult:
    """Run one build; see :class:`ConstructionSimulation`. ``smart`` is left as it was (the run works on
    a copy, returned in its final states as ``result.built``), so it can be simulated again."""
    return ConstructionSimulation(smart, fleet, site, evaluator, seed, breakdowns, storey_elevations, on_assembled, per_node,
                                  dispatcher).run()
