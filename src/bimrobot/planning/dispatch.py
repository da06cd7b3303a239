"""The dispatching environment (issue 38): an agent, not the market, decides who does what on the event
simulation of ``bimrobot simulate``.

``import bimrobot.planning.dispatch`` registers ``bimrobot/Dispatch-v0``. The environment drives the one
event simulation, :class:`~bimrobot.coordination.simulation.ConstructionSimulation`, with an agent as its
dispatcher (:class:`~bimrobot.coordination.market.Dispatcher`): no second copy of the simulation exists,
so :class:`MarketPolicy`, which plays the market's own awards, reproduces ``simulate``'s schedule exactly.

Units: metres, seconds, kg, m/s; robot and task positions (x, y) in the site frame, heights z in the model
frame (z up).
"""

from __future__ import annotations

import tempfile
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from bimrobot.site.fleet import Fleet, Site, load_fleet
from bimrobot.coordination.market import Dispatcher, MarketDispatcher, handling_time, incapability, make_evaluator
from bimrobot.coordination.simulation import ConstructionSimulation, SimulationResult
from bimrobot.core.errors import BimrobotError, InputError
from bimrobot.sco.build import SmartModel
from bimrobot.sco.states import State
from bimrobot.core.tasks import Task

ENV_ID = "bimrobot/Dispatch-v0"
#: bound of every observed number (metres, seconds, kg): finite, far beyond any site or build (about 32 years)
BOUND = 1e9
KINDS = ("transport", "position", "assemble", "gate")
STATES = ("waiting", "ready", "running", "done")
#: columns of ``node_features``
NODE_FEATURES = (
    "is_transport", "is_position", "is_assemble", "is_gate", "floor", "mass_kg", "mass_known",
    "x_site_m", "y_site_m", "z_m", "is_waiting", "is_ready", "is_running", "is_done",
    "earliest_start_s", "shortest_handling_s",
)
#: columns of ``robot_features``
ROBOT_FEATURES = (
    "x_site_m", "y_site_m", "speed_m_s", "does_transport", "does_position", "does_assemble",
    "busy", "free_in_s", "broken",
)


@dataclass(frozen=True)
class DispatchProblem:
    """One build to plan: the smart model, the fleet, the site (placed on the building), the storey
    elevations (m), the task granularity (``per_node`` as ``simulate``'s default, else per joint) and
    breakdowns ((robot, time s[, repair s]) as ``simulate --breakdown``)."""

    smart: SmartModel
    fleet: Fleet
    site: Site | None = None
    storey_elevations: list[float] | None = None
    per_node: bool = True
    breakdowns: tuple = ()


def frame_problem(fleet: str = "fleet2", per_node: bool = True, size: tuple[int, int, int] = (2, 2, 1)) -> DispatchProblem:
    """A generated steel frame (no IFC file) of ``size`` = (columns along x, along y, storeys), built by
    ``fleet`` on its site; the default is the thesis' chapter-4 frame."""
    from bimrobot.coordination.generate import generated_frame
    from bimrobot.sco.build import build_smart_model
    from bimrobot.site.site import site_for

    model = generated_frame(*size)
    return DispatchProblem(build_smart_model(model), load_fleet(fleet), site_for(None, model.elements.values()),
                           [s.elevation for s in model.storeys], per_node)


def simulate_problem(argv: list[str]) -> DispatchProblem:
    """The problem that ``bimrobot simulate ARGV`` runs, read by simulate's own parser and readers
    (model, ``--fleet``, ``--site``, ``--prebuilt``, selection, ``--per-joint``, ``--breakdown``, ...).
    Give no ``-o``: nothing is written."""
    from bimrobot.cli import parser_for
    from bimrobot.coordination.inputs import prepare

    with tempfile.TemporaryDirectory() as folder:
        argv = ["simulate", *argv, "-o", str(Path(folder) / "unused")]
        args = parser_for(argv).parse_args(argv)
        if args.mode != "event":
            raise InputError("the dispatching environment runs the event simulation, not --mode thesis")
        _, elevations, fleet, site, _, smart_model = prepare(args, "simulate")
    return DispatchProblem(smart_model(), fleet, site, elevations, not args.per_joint, tuple(args.breakdown))


def task_key(activity: str, component: str, joint: str | None, node: str | None) -> str:
    """The graph node of a published request: ``transport:<component>``, ``position:<node or component>``,
    ``assemble:<node or joint>`` (per node or per joint)."""
    if activity == Task.ASSEMBLE:
        return f"assemble:{node or joint}"
    if activity == Task.POSITION:
        return f"position:{node or component}"
    return f"transport:{component}"


def request_key(sim, request) -> str:
    """The task graph's node (:func:`task_key`) of a request published in ``sim``, a running
    :class:`~bimrobot.coordination.simulation.ConstructionSimulation` (per node when ``sim.per_node``)."""
    node = request.node_ids[0] if request.node_ids and sim.per_node else None
    return task_key(request.activity, request.component_id, request.joint_id, node)


@dataclass
class TaskGraph:
    """The build's tasks and floor gates as a graph: ``keys[i]`` names node i, ``requests[i]`` is its
    task request (None for a gate), ``edges`` (E, 2) are precedences (before, after). ``groups`` (E,):
    the edges of one group release their ``after`` node once the first of them is done (per node: a
    component stands once its first node is positioned); a node waits for all its groups."""

    keys: list[str]
    kinds: np.ndarray
    requests: list
    edges: np.ndarray
    groups: np.ndarray

    @property
    def any_of(self) -> np.ndarray:
        """(E,) True for an edge that is one of several alternatives of its group."""
        return np.bincount(self.groups, minlength=len(self.groups))[self.groups] > 1 if len(self.groups) else np.zeros(0, bool)


def task_graph(sim: ConstructionSimulation) -> TaskGraph:
    """The tasks ``sim`` will publish, with what waits for what: transport after the positioning of what a
    component rests on and after the gate of the floor below; positioning after the transport (per node:
    after the transports of the joint's partners too, ACC); assembly after the positioning of its members
    (per node: of its node). One gate per floor closes it: after every assembly (and every positioning of
    a part without nodes) of the floor, and after the gate below. Call after ``sim.start()``."""
    smart, per_node = sim.smart, sim.per_node
    keys, kinds, requests, edges = [], [], [], []
    index: dict[str, int] = {}

    def add(key, kind, request):
        index[key] = len(keys)
        keys.append(key)
        kinds.append(KINDS.index(kind))
        requests.append(request)

    position_of: dict[str, list[str]] = {}  # component -> its positioning tasks
    built = [c for c in smart.components.values() if not c.prebuilt]
    for c in built:
        add(f"transport:{c.id}", "transport", sim.request_for(Task.TRANSPORT, c))
        if per_node and c.connection_nodes:
            position_of[c.id] = [f"position:{n.id}" for n in c.connection_nodes]
            for n in c.connection_nodes:
                add(f"position:{n.id}", "position", sim.request_for(Task.POSITION, c, node=n))
        else:
            position_of[c.id] = [f"position:{c.id}"]
            add(f"position:{c.id}", "position", sim.request_for(Task.POSITION, c))
    closes: dict[int, list[str]] = {}  # floor -> the tasks that close it
    if per_node:
        for c in built:
            for n in c.connection_nodes:
                if n.state != State.ASSEMBLED:
                    add(f"assemble:{n.id}", "assemble", sim.request_for(Task.ASSEMBLE, c, node=n))
                    edges.append((f"position:{n.id}", f"assemble:{n.id}"))
                    closes.setdefault(n.level, []).append(f"assemble:{n.id}")
                    joint = smart.joints[n.joint_id]
                    for partner in joint.component_ids:
                        if partner != c.id and not smart.components[partner].prebuilt and not sim.rests_on(partner, c.id):
                            edges.append((f"transport:{partner}", f"position:{n.id}"))
    else:
        for joint in sim.joints_to_build():
            members = [smart.components[g] for g in joint.component_ids]
            add(f"assemble:{joint.id}", "assemble", sim.request_for(Task.ASSEMBLE, members[0], joint))
            closes.setdefault(joint.floor, []).append(f"assemble:{joint.id}")
            before = [p for m in members if not m.prebuilt for p in position_of[m.id]]
            before += [p for m in members if m.prebuilt for s in smart.robot_supporters(m.id) for p in position_of[s]]
            edges += [(p, f"assemble:{joint.id}") for p in dict.fromkeys(before)]
    for c in built:
        if not c.connection_nodes:
            closes.setdefault(c.floor, []).append(position_of[c.id][0])
    floors = len(smart.floors)
    for f in range(floors - 1):
        add(f"gate:{f}", "gate", None)
        edges += [(k, f"gate:{f}") for k in closes.get(f, ())]
        if f:
            edges.append((f"gate:{f - 1}", f"gate:{f}"))
    for c in built:
        edges += [(f"transport:{c.id}", p) for p in position_of[c.id]]
        edges += [(p, f"transport:{c.id}", f"{s}>{c.id}") for s in smart.robot_supporters(c.id) for p in position_of.get(s, ())]
        if c.floor:
            edges.append((f"gate:{c.floor - 1}", f"transport:{c.id}"))
    unique = list(dict.fromkeys(e if len(e) == 3 else (*e, None) for e in edges))
    pairs = np.array([(index[a], index[b]) for a, b, _ in unique], dtype=np.int64).reshape(-1, 2)
    group_ids: dict = {}
    groups = [group_ids.setdefault(g if g is not None else ("edge", i), len(group_ids)) for i, (_, _, g) in enumerate(unique)]
    return TaskGraph(keys, np.array(kinds, dtype=np.int64), requests, pairs, np.array(groups, dtype=np.int64))


class AgentDispatcher(Dispatcher):
    """The dispatcher of the environment: the simulation stops at each decision point for the agent."""

    name = "agent"


class DispatchEnv(gym.Env):
    """Dispatch a robot fleet on the event simulation of a real building.

    ## Description
    The building (IFC model or generated) is built by its fleet as in ``bimrobot simulate``: components
    ask for transport once what carries them stands, floor by floor; they are positioned once arrived and
    their joints assembled once positioned. The event simulation runs until a *decision point*: ready
    work (a published task) and an idle robot capable of it. The agent gives one ready task to one idle
    robot, or waits; after an award the same instant may hold another decision (more idle robots, more
    ready work). Driven by :class:`MarketPolicy` it reproduces ``simulate``'s schedule exactly.

    ## Action Space
    ``Discrete(max_tasks * max_robots + 1)``: action ``i * max_robots + r`` gives graph node ``i`` (a
    ready task) to robot ``r`` (fleet order); the last action, ``max_tasks * max_robots``, waits (the
    allocation round ends; the simulation runs to the next decision point). :meth:`action_masks` gives
    the valid actions (as sb3-contrib's ``MaskablePPO`` expects); waiting is valid only while a robot is
    at work or a repair is due, so the build can never stall. An invalid action counts as waiting when
    that is valid, else as the first valid award (``info["invalid_action"]`` is True).

    ## Observation Space
    A ``Dict`` of fixed-size arrays, padded to the sizes given at construction, so that one policy runs on
    any building (``*_mask`` marks the real entries):

    | key | shape | meaning |
    |---|---|---|
    | ``node_features`` | (max_tasks, 16) float32 | one row per task or floor gate, columns :data:`NODE_FEATURES`: kind one-hot (transport, position, assemble, gate), floor (0-based), mass kg (0 with mass_known 0 when the model gives none), where the work is (x, y site frame, z model frame, m), state one-hot (waiting, ready, running, done), earliest start (s from now, a bound from the precedences with each task's shortest handling and no travel), shortest handling time over capable robots (s) |
    | ``node_mask`` | (max_tasks,) int8 | 1 for a real node |
    | ``robot_features`` | (max_robots, 9) float32 | columns :data:`ROBOT_FEATURES`: where it is now (x, y site frame, m), speed m/s, capabilities (transport, position, assemble), busy, seconds until its current task ends, broken |
    | ``robot_mask`` | (max_robots,) int8 | 1 for a real robot |
    | ``precedence`` | (max_edges, 2) int32 | edge (before, after) between nodes: ``after`` waits for ``before`` |
    | ``precedence_mask`` | (max_edges,) int8 | 1 for a real edge |
    | ``precedence_any`` | (max_edges,) int8 | 1 for one of several alternative edges into a node: the first of them to finish releases it (per node: a component stands, and carries what rests on it, once its first node is positioned) |
    | ``compatibility`` | (max_tasks, max_robots) int8 | 1 where the robot can do the task (payload, platform, reach, method) |
    | ``handling_s`` | (max_tasks, max_robots) float32 | the robot's handling time for the task (0 where incompatible) |
    | ``travel_s`` | (max_tasks, max_robots) float32 | driving time from where the robot is now (or where its task ends) to the task |
    | ``time_s`` | (1,) float32 | simulation time, seconds since the build started |

    Components and joints appear through their tasks: a component is its transport and positioning, a
    joint (per node: a connection node) its assembly.

    ## Rewards
    Minus the simulated seconds that pass between two decisions; the last step adds the time to the
    end of the last activity. The return of an episode is minus the makespan (s).

    ## Starting State
    Robots at their homes, the first floor's ready components asking for transport, t = 0; the first
    decision point. ``reset(seed=...)`` seeds ``np_random``, which a ``problem`` callable may use to draw
    a building.

    ## Episode End
    1. Termination: every component is assembled (``info["makespan_s"]``; the full
       :class:`~bimrobot.coordination.simulation.SimulationResult` is ``env.unwrapped.result``), or the build
       stalled (breakdowns left work no robot can do; ``info["stalled"]`` says why).
    2. Truncation: ``max_decisions`` decisions were taken.

    ## Arguments
    ```python
    import gymnasium as gym
    import bimrobot.planning.dispatch
    env = gym.make("bimrobot/Dispatch-v0", problem=None, max_tasks=512, max_robots=16, max_edges=2048)
    ```
    ``problem``: a :class:`DispatchProblem`, a callable ``f(np_random) -> DispatchProblem`` drawn at each
    reset (e.g. generated buildings for training), or None for the chapter-4 steel frame with fleet2
    (:func:`frame_problem`). ``max_tasks`` (tasks + floor gates), ``max_robots``, ``max_edges``: the
    padded sizes; a larger building is refused with one sentence. ``max_decisions``: truncation
    (default 8 x nodes + 64).

    ## Version History
    * v0: initial version (issue 38).
    """

    metadata = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(self, problem: DispatchProblem | Callable | None = None, max_tasks: int = 512, max_robots: int = 16,
                 max_edges: int = 2048, max_decisions: int | None = None, render_mode: str | None = None):
        if min(max_tasks, max_robots, max_edges) < 1:
            raise InputError(f"max_tasks, max_robots and max_edges must be at least 1, got {max_tasks}, {max_robots}, {max_edges}")
        self.problem = problem if problem is not None else frame_problem()
        self.max_tasks, self.max_robots, self.max_edges = max_tasks, max_robots, max_edges
        self.max_decisions = max_decisions
        self.render_mode = render_mode
        n, r, e = max_tasks, max_robots, max_edges
        self.wait_action = n * r
        self.action_space = spaces.Discrete(n * r + 1)
        self.observation_space = spaces.Dict({
            "node_features": spaces.Box(-BOUND, BOUND, (n, len(NODE_FEATURES)), np.float32),
            "node_mask": spaces.MultiBinary(n),
            "robot_features": spaces.Box(-BOUND, BOUND, (r, len(ROBOT_FEATURES)), np.float32),
            "robot_mask": spaces.MultiBinary(r),
            "precedence": spaces.Box(0, n - 1, (e, 2), np.int32),
            "precedence_mask": spaces.MultiBinary(e),
            "precedence_any": spaces.MultiBinary(e),
            "compatibility": spaces.MultiBinary((n, r)),
            "handling_s": spaces.Box(0.0, BOUND, (n, r), np.float32),
            "travel_s": spaces.Box(0.0, BOUND, (n, r), np.float32),
            "time_s": spaces.Box(0.0, BOUND, (1,), np.float32),
        })
        self.sim: ConstructionSimulation | None = None
        self.result: SimulationResult | None = None
        self._ended = True

    # ---------------------------------------------------------------- episode
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        problem = self.problem(self.np_random) if callable(self.problem) else self.problem
        self.sim = ConstructionSimulation(problem.smart, problem.fleet, problem.site, breakdowns=problem.breakdowns,
                                          storey_elevations=problem.storey_elevations, per_node=problem.per_node,
                                          dispatcher=AgentDispatcher())
        self.sim.start()
        self.graph = task_graph(self.sim)
        self._set_up_arrays(problem.fleet)
        self.result, self.round_id, self.decisions, self._clock = None, 0, 0, 0.0
        self._finished_at = np.full(len(self.graph.keys), np.nan)
        self._seen_events = 0
        self._request_node: dict[str, int] = {}
        done, info = self._to_next_decision()
        if done:
            raise BimrobotError(f"{problem.smart.source}: nothing to decide, the build needs no robot")
        self._ended = False
        return self._observation(), info

    def step(self, action):
        if self.sim is None or self._ended:
            raise BimrobotError("call reset() before step(): no episode is running")
        action = int(action)
        invalid = not self._valid(action)
        if invalid:
            mask = self.action_masks()
            action = self.wait_action if mask[self.wait_action] else int(np.flatnonzero(mask)[0])
        self.decisions += 1
        if action == self.wait_action:
            self.sim.end_round()
            done, info = self._to_next_decision()
        else:
            node, robot = divmod(action, self.max_robots)
            self.sim.award(self._pending_request(node), self.robot_names[robot])
            if self.sim.has_decision():
                done, info = False, {"time_s": float(self.sim.build.env.now)}
            else:
                self.sim.end_round()
                done, info = self._to_next_decision()
        reward = self._reward(done, info)
        truncated = not done and self.decisions >= self._decision_limit
        self._ended = done or truncated
        info.update(invalid_action=invalid, decisions=self.decisions)
        return self._observation(), reward, done, truncated, info

    def _to_next_decision(self) -> tuple[bool, dict]:
        """Run the simulation to the next decision point (False) or to its end (True)."""
        while self.sim.advance():
            self.round_id += 1
            if self.sim.has_decision():
                return False, {"time_s": float(self.sim.build.env.now)}
            self.sim.end_round()  # pragma: no cover - advance stops only with candidates
        try:
            self.result = self.sim.result()
        except BimrobotError as exc:
            return True, {"time_s": float(self.sim.build.env.now), "stalled": str(exc)}
        return True, {"time_s": float(self.sim.build.env.now), "makespan_s": self.result.makespan}

    def _reward(self, done: bool, info: dict) -> float:
        """Minus the seconds since the last decision (at the end: up to the end of the last activity)."""
        now = info.get("makespan_s", float(self.sim.build.env.now))
        reward, self._clock = -(now - self._clock), now
        return float(reward)

    # ---------------------------------------------------------------- actions
    def action_masks(self) -> np.ndarray:
        """Valid actions (bool, ``action_space.n``): ready task x idle capable robot, and waiting."""
        mask = np.zeros(self.action_space.n, dtype=bool)
        if self.sim is None or self._ended:
            mask[self.wait_action] = True
            return mask
        for request, robot in self.sim.decision_candidates():
            mask[self._node_of(request) * self.max_robots + self.robot_index[robot]] = True
        mask[self.wait_action] = self.sim.can_wait()
        return mask

    def _valid(self, action: int) -> bool:
        """Whether ``action`` is valid now (one entry of :meth:`action_masks`, without building the mask)."""
        if action == self.wait_action:
            return self.sim.can_wait()
        if not 0 <= action < self.wait_action:
            return False
        node, index = divmod(action, self.max_robots)
        if index >= len(self.robot_names):
            return False
        request, name = self._pending_request(node), self.robot_names[index]
        return (request is not None and name in self.sim.build.idle[request.activity]
                and not incapability(self.sim.build.robots[name].spec, request))

    def action_of(self, request, robot: str) -> int:
        """The action that gives ``request`` (pending) to ``robot`` (a name)."""
        return self._node_of(request) * self.max_robots + self.robot_index[robot]

    def _node_of(self, request) -> int:
        if request.id not in self._request_node:
            node = request.node_ids[0] if request.node_ids and self.sim.per_node else None
            key = task_key(request.activity, request.component_id, request.joint_id, node)
            self._request_node[request.id] = self.graph_index[key]
        return self._request_node[request.id]

    def _pending_request(self, node: int):
        """The pending request of graph node ``node``, or None when it is not ready."""
        for pool in self.sim.build.pending.values():
            for request in pool:
                if self._node_of(request) == node:
                    return request
        return None

    # ---------------------------------------------------------------- observation
    def _set_up_arrays(self, fleet: Fleet) -> None:
        graph, n, r = self.graph, len(self.graph.keys), len(fleet.robots)
        if n > self.max_tasks or r > self.max_robots or len(graph.edges) > self.max_edges:
            raise InputError(
                f"the build has {n} tasks and floor gates, {r} robots and {len(graph.edges)} precedences; this "
                f"environment takes at most {self.max_tasks}, {self.max_robots} and {self.max_edges} (max_tasks, "
                "max_robots, max_edges)"
            )
        self.robot_names = [spec.name for spec in fleet.robots]
        self.robot_index = {name: i for i, name in enumerate(self.robot_names)}
        self.graph_index = {key: i for i, key in enumerate(graph.keys)}
        self._decision_limit = self.max_decisions or 8 * n + 64
        static = np.zeros((self.max_tasks, len(NODE_FEATURES)), np.float32)
        static[np.arange(n), graph.kinds] = 1.0
        self.handling = np.zeros((self.max_tasks, self.max_robots), np.float32)
        self.capable = np.zeros((self.max_tasks, self.max_robots), bool)
        self.start_xy = np.zeros((self.max_tasks, 2))
        for i, (key, request) in enumerate(zip(graph.keys, graph.requests)):
            if request is None:  # a floor gate
                static[i, 4] = float(key.split(":")[1])
                continue
            component = self.sim.smart.components[request.component_id]
            static[i, 4] = request.floor
            static[i, 5:7] = (component.weight_kg or 0.0, component.weight_kg is not None)
            z = self._height(request, component)
            static[i, 7:10] = (request.start[0], request.start[1], z)
            self.start_xy[i] = request.start
            for j, spec in enumerate(fleet.robots):
                if not incapability(spec, request):
                    self.capable[i, j] = True
                    self.handling[i, j] = handling_time(spec, request)
        shortest = np.where(self.capable, self.handling, np.inf).min(axis=1)
        self.shortest = np.where(np.isfinite(shortest), shortest, 0.0)[:n]
        static[:n, 15] = self.shortest
        self.static = static
        self.robot_static = np.zeros((self.max_robots, len(ROBOT_FEATURES)), np.float32)
        for j, spec in enumerate(fleet.robots):
            self.robot_static[j, 2] = spec.speed_m_s
            self.robot_static[j, 3:6] = [spec.can(a) for a in (Task.TRANSPORT, Task.POSITION, Task.ASSEMBLE)]
        self.speeds = np.array([spec.speed_m_s for spec in fleet.robots])
        self.precedence = np.zeros((self.max_edges, 2), np.int32)
        self.precedence[: len(graph.edges)] = graph.edges
        self.precedence_any = np.zeros(self.max_edges, np.int8)
        self.precedence_any[: len(graph.edges)] = graph.any_of
        self.levels = _levels(n, graph.edges)  # (nodes, indices of the edges into them) per depth
        self.group_after = np.zeros(int(graph.groups.max(initial=-1)) + 1, np.int64)
        self.group_after[graph.groups] = graph.edges[:, 1]
        self.state = np.zeros(n, np.int64)  # index into STATES

    def _height(self, request, component) -> float:
        if request.node_ids and request.activity != Task.TRANSPORT:
            return float(self.sim.smart.nodes[request.node_ids[0]].position[2])
        if request.joint_id:
            return float(self.sim.smart.joints[request.joint_id].position[2])
        return float(component.target_position[2])

    def _follow_events(self) -> None:
        """Node states from the simulation's event log since the last look."""
        events = self.sim.build.events
        for event in events[self._seen_events:]:
            kind = event["event"]
            if kind == "task_request":
                key = task_key(event["activity"], event["component"], event["joint"], event["node"])
                node = self.graph_index[key]
                self._request_node[event["request"]] = node
                self.state[node] = 1
            elif kind == "award":
                self.state[self._request_node[event["request"]]] = 2
            elif kind == "reauction":
                self.state[self._request_node[event["request"]]] = 1
            elif kind == "finish":
                node = self._request_node[event["request"]]
                self.state[node], self._finished_at[node] = 3, event["time"]
        self._seen_events = len(events)

    def _observation(self) -> dict:
        self._follow_events()
        n, now = len(self.graph.keys), float(self.sim.build.env.now)
        robots = [self.sim.build.robots[name] for name in self.robot_names]
        running_until = np.full(n, np.nan)
        for robot in robots:
            if robot.task is not None:
                running_until[self._node_of(robot.task)] = robot.free_at
        gates = self.graph.kinds == KINDS.index("gate")
        self._close_gates(gates)
        start = self._earliest_starts(now, running_until, gates)
        nodes = self.static.copy()
        nodes[np.arange(n), 10 + self.state] = 1.0
        nodes[:n, 14] = start - now
        robot_features = self.robot_static.copy()
        where = np.zeros((self.max_robots, 2))
        for j, robot in enumerate(robots):
            busy = robot.task is not None
            here = self.sim.where(robot)
            where[j] = robot.end_position if busy else here
            robot_features[j, 0:2] = here
            robot_features[j, 6:9] = (busy, max(0.0, robot.free_at - now) if busy else 0.0, robot.broken)
        travel = np.zeros((self.max_tasks, self.max_robots), np.float32)
        k = len(robots)
        distance = np.hypot(*(self.start_xy[:n, None, :] - where[None, :k, :]).transpose(2, 0, 1))
        travel[:n, :k] = np.where(self.capable[:n, :k], distance / self.speeds[None, :], 0.0)
        return {
            "node_features": nodes,
            "node_mask": _mask(self.max_tasks, n),
            "robot_features": robot_features,
            "robot_mask": _mask(self.max_robots, k),
            "precedence": self.precedence.copy(),
            "precedence_mask": _mask(self.max_edges, len(self.graph.edges)),
            "precedence_any": self.precedence_any.copy(),
            "compatibility": self.capable.astype(np.int8),
            "handling_s": self.handling.copy(),
            "travel_s": travel,
            "time_s": np.array([now], np.float32),
        }

    def _close_gates(self, gates: np.ndarray) -> None:
        """A floor gate is done once every node before it is (gates are not tasks: no events)."""
        for i in np.flatnonzero(gates & (self.state != 3)):
            before = self.graph.edges[self.graph.edges[:, 1] == i, 0]
            if np.all(self.state[before] == 3):
                self.state[i] = 3
                self._finished_at[i] = np.max(self._finished_at[before], initial=0.0)

    def _earliest_starts(self, now: float, running_until: np.ndarray, gates: np.ndarray) -> np.ndarray:
        """Earliest start (s) of every node: now for ready, running and done work; for waiting work the
        latest earliest finish of what it waits for (shortest handling, no travel; a gate takes none)."""
        # waiting nodes: overwritten level by level before anything after them reads them
        finish = np.where(self.state == 3, self._finished_at, now)
        finish = np.where(self.state == 2, np.nan_to_num(running_until, nan=now), finish)
        ready = self.state == 1
        finish[ready] = now + self.shortest[ready]
        start = np.full(len(self.state), now)
        bound = np.full(len(self.state), now)
        first = np.full(len(self.group_after), np.inf)  # per group: the first of its alternatives to finish
        for level, into in self.levels:
            todo = level[self.state[level] == 0]
            if todo.size == 0:
                continue
            groups = self.graph.groups[into]
            np.minimum.at(first, groups, finish[self.graph.edges[into, 0]])
            np.maximum.at(bound, self.group_after[groups], first[groups])
            start[todo] = bound[todo]
            finish[todo] = bound[todo] + np.where(gates[todo], 0.0, self.shortest[todo])
        return start

    def render(self):
        if self.render_mode != "ansi" or self.sim is None:
            return None
        counts = {s: int(np.sum(self.state == i)) for i, s in enumerate(STATES)}
        return f"t = {self.sim.build.env.now:.1f} s, decision {self.decisions}: " + ", ".join(f"{v} {k}" for k, v in counts.items())


def _mask(size: int, real: int) -> np.ndarray:
    mask = np.zeros(size, np.int8)
    mask[:real] = 1
    return mask


def _levels(n: int, edges: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(nodes, the edges into them) per depth in the precedence graph (longest path from a source), from
    depth 1 on: each node's predecessors lie at smaller depths."""
    depth = np.zeros(n, np.int64)
    indegree = np.bincount(edges[:, 1], minlength=n) if len(edges) else np.zeros(n, np.int64)
    after: list[list[int]] = [[] for _ in range(n)]
    for a, b in edges:
        after[a].append(b)
    queue = deque(np.flatnonzero(indegree == 0).tolist())
    seen = 0
    while queue:
        a = queue.popleft()
        seen += 1
        for b in after[a]:
            depth[b] = max(depth[b], depth[a] + 1)
            indegree[b] -= 1
            if indegree[b] == 0:
                queue.append(b)
    if seen < n:
        raise BimrobotError("the task graph has a cycle")
    into = depth[edges[:, 1]] if len(edges) else np.zeros(0, np.int64)
    return [(np.flatnonzero(depth == d), np.flatnonzero(into == d)) for d in range(1, int(depth.max(initial=0)) + 1)]


class MarketPolicy:
    """The market as a policy of :class:`DispatchEnv`: at each allocation round it plays the awards the
    market (``evaluator``, ``seed``) would make, in the market's order, then waits. With the same
    evaluator and seed the episode is ``simulate``'s run, schedule for schedule."""

    def __init__(self, evaluator: str = "least-cost", seed: int = 0):
        self.dispatcher = MarketDispatcher(make_evaluator(evaluator, seed))
        self._round, self._plan = None, deque()

    def __call__(self, env: gym.Env) -> int:
        env = env.unwrapped
        if self._round != (id(env.sim), env.round_id):
            self._round = (id(env.sim), env.round_id)
            self._plan = deque(self.dispatcher.awards(env.sim))
        if self._plan:
            award = self._plan.popleft()
            return env.action_of(award.request, award.robot)
        return env.wait_action


def play(env: gym.Env, policy, seed: int | None = None) -> tuple[float, SimulationResult | None]:
    """One episode of ``policy`` (``policy(env) -> action``); returns (return, the simulation result)."""
    env.reset(seed=seed)
    total, done, truncated = 0.0, False, False
    while not (done or truncated):
        _, reward, done, truncated, _ = env.step(policy(env))
        total += reward
    return total, env.unwrapped.result


def _register() -> None:
    if ENV_ID not in gym.registry:
        gym.register(id=ENV_ID, entry_point="bimrobot.planning.dispatch:DispatchEnv")


_register()
