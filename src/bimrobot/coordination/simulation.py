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
from dataclasses import replace

import numpy as np
import simpy

from bimrobot.site.fleet import ACTIVITIES, Fleet
from bimrobot.site.site import Site, default_site
from bimrobot.coordination.market import (
    Award,
    Dispatcher,
    MarketDispatcher,
    TaskRequest,
    incapability,
    make_evaluator,
    propose,
)
from bimrobot.coordination.node_release import NodeRelease
from bimrobot.coordination.preflight import check_capabilities
from bimrobot.coordination.robot_work import RobotWork
from bimrobot.coordination.run_state import BuildState, RobotStats, SimulationResult, SiteRobot, remove_from_heap
from bimrobot.core.errors import BimrobotError, InputError
from bimrobot.sco.build import SmartModel, gc_paused
from bimrobot.sco.component import Component, Joint
from bimrobot.sco.states import Event, State, at_least
from bimrobot.core.tasks import TASKS, Task

__all__ = ["ConstructionSimulation", "simulate"]

log = logging.getLogger(__name__)

ACTIVITY_RANK = {task: task.rank for task in TASKS}  # assemble first: the work nearest to done
#: A yard or robot home farther than this from the building (metres) is a mistake in the site file
#: (e.g. a georeferenced model_offset), not a site: robots would drive for days.
MAX_SITE_DISTANCE_M = 10_000.0


def gid_on_site(component: Component, later: set[str]) -> bool:
    """A prebuilt component on site from the start (not one made once what it rests on is placed)."""
    return component.prebuilt and component.id not in later


def _storey_base(z: float, elevations: list[float]) -> float:
    """Elevation of the floor a robot stands on to work at height z (highest storey at or below z)."""
    below = [e for e in elevations if e <= z + 1e-6]
    return max(below) if below else min(elevations, default=0.0)


class ConstructionSimulation(RobotWork, NodeRelease):
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
        check_capabilities(self)  # raises before simulating when the fleet cannot do a task

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
        robots: dict[str, SiteRobot] = {}
        for index, spec in enumerate(self.fleet.robots):
            home = np.array(self.site.robot_start(index, self.fleet.home_on_site(spec, self.offset)), dtype=float)
            robots[spec.name] = SiteRobot(spec, home.copy(), RobotStats(spec.name, spec.kind), end_position=home.copy())
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
        waiting = sorted(t for pool in self.build.pending.values() for t in pool)  # by priority, not heap layout
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
        remove_from_heap(self.build.pending[award.request.activity], award.request)
        if not self.build.round_awarded:
            self.build.round_awarded = True
            self.build.steps += 1
            self._step_header()
        self._award(award.request, self.build.robots[award.robot], award.proposal, award.bidders)

    def position_now(self, robot: SiteRobot) -> np.ndarray:
        """Where an idle ``robot`` bids from (site frame x, y, metres): part way along its drive back to
        the yard, else where it stands."""
        return self._position_now(robot) if robot.returning else robot.position

    def where(self, robot: SiteRobot) -> np.ndarray:
        """Where ``robot`` is now (site frame x, y, metres), part way along any drive."""
        return self._position_now(robot)

    def _step_header(self) -> None:
        self.build.lines.append("-" * 48)
        self.build.lines.append(f"Start a new construction step, NO.{self.build.steps}, in floor {self.build.current_floor + 1} (t = {self.build.env.now:.2f} s)")
        self.build.lines.append("-" * 48)
        self.build.lines.append("Get components requirement from site")

    def _award(self, request: TaskRequest, robot: SiteRobot, proposal, bidders: int) -> None:
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
