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

from collections import deque
from typing import Callable

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from bimrobot.site.fleet import Fleet
from bimrobot.coordination.market import Dispatcher, MarketDispatcher, handling_time, incapability, make_evaluator
from bimrobot.coordination.simulation import ConstructionSimulation
from bimrobot.coordination.run_state import SimulationResult
from bimrobot.core.errors import BimrobotError, InputError
from bimrobot.core.tasks import Task
from bimrobot.planning.dispatch_observation import (CONTEXT, LocalKeeper, _in_edges, _levels, _local_pass,
                                                    _local_travel_pass, _mask,
                                                    _read_only, _starts_pass, _travel_pass, rebuild_observation)
from bimrobot.planning.dispatch_problem import (KINDS, DispatchProblem, PublishingSimulation, TaskGraph, frame_problem,
                                                problem_graph, request_key, simulate_problem, task_graph, task_key)

ENV_ID = "bimrobot/Dispatch-v0"
#: bound of every observed number (metres, seconds, kg): finite, far beyond any site or build (about 32 years)
BOUND = 1e9
STATES = ("waiting", "ready", "running", "done")
#: the observations of :class:`DispatchEnv`: the whole building, or the ready tasks' neighbourhood
OBSERVATIONS = ("full", "local")
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

    ## Local observation
    ``observation="local"``: the same keys and shapes plus ``context`` (16,) float32, the share of the
    building's nodes per kind and state (:data:`~bimrobot.planning.dispatch_observation.CONTEXT`), but
    ``node_mask`` marks only the first ready tasks of each request pool (``LOCAL_READY``, the market's
    order) and the nodes within ``REACH`` precedence edges of them (not through a floor gate);
    ``precedence_mask`` the edges between those; ``earliest_start_s`` is local (from the direct
    predecessors; 0 outside the neighbourhood and for gates); ``travel_s`` holds those ready tasks' rows
    only. Its cost per decision grows with that neighbourhood, not the building; :meth:`local_actions`
    are the valid awards of the observed ready tasks. The action space and masks are unchanged.

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
    (default 8 x nodes + 64). ``copy_observation`` (default True, gymnasium's contract): every
    observation is new data; False hands out read-only views of the arrays the environment keeps up,
    valid until the next ``step`` or ``reset`` (the caller copies what it keeps; for a planner that
    reads each observation once, e.g. the learned planner on a large building).

    ## Version History
    * v0: initial version (issue 38).
    """

    metadata = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(self, problem: DispatchProblem | Callable | None = None, max_tasks: int = 512, max_robots: int = 16,
                 max_edges: int = 2048, max_decisions: int | None = None, render_mode: str | None = None,
                 copy_observation: bool = True, observation: str = "full"):
        if observation not in OBSERVATIONS:
            raise InputError(f"unknown observation {observation!r}: choose one of {', '.join(OBSERVATIONS)}")
        self.observation = observation
        if min(max_tasks, max_robots, max_edges) < 1:
            raise InputError(f"max_tasks, max_robots and max_edges must be at least 1, got {max_tasks}, {max_robots}, {max_edges}")
        self.problem = problem if problem is not None else frame_problem()
        self.max_tasks, self.max_robots, self.max_edges = max_tasks, max_robots, max_edges
        self.max_decisions = max_decisions
        self.render_mode = render_mode
        self.copy_observation = copy_observation
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
            **({"context": spaces.Box(0.0, 1.0, (len(CONTEXT),), np.float32)} if observation == "local" else {}),
        })
        self.sim: ConstructionSimulation | None = None
        self._local: LocalKeeper | None = None
        self.result: SimulationResult | None = None
        self._ended = True
        self._episode = 0

    # ---------------------------------------------------------------- episode
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        problem = self.problem(self.np_random) if callable(self.problem) else self.problem
        self.sim = PublishingSimulation(problem.smart, problem.fleet, problem.site, breakdowns=problem.breakdowns,
                                          storey_elevations=problem.storey_elevations, per_node=problem.per_node,
                                          dispatcher=AgentDispatcher())
        self.sim.start()
        self._episode += 1
        self.graph = problem_graph(problem, self.sim)  # built once per problem
        self._set_up_arrays(problem.fleet)
        self.result, self.round_id, self.decisions, self._clock = None, 0, 0, 0.0
        self.awarded: list[tuple[float, str, str]] = []  # (time s, task key, robot) of each award, in order
        self._finished_at = np.full(len(self.graph.keys), np.nan)
        self._seen_events = 0
        self._request_node: dict[str, int] = {}
        done, info = self._to_next_decision()
        if done:
            raise BimrobotError(f"{problem.smart.source}: nothing to decide, the build needs no robot")
        self._ended = False
        return self._handout(), info

    def step(self, action):
        if self.sim is None or self._ended:
            raise BimrobotError("call reset() before step(): no episode is running")
        action = int(action)
        award = self._award_of(action)
        if invalid := award is None:
            mask = self.action_masks()
            action = self.wait_action if mask[self.wait_action] else int(np.flatnonzero(mask)[0])
            award = self._award_of(action)
        self.decisions += 1
        if action == self.wait_action:
            self.sim.end_round()
            done, info = self._to_next_decision()
        else:
            self.sim.award(*award)
            self.awarded.append((float(self.sim.build.env.now), self.graph.keys[self._node_of(award[0])], award[1]))
            if self.sim.has_decision():
                done, info = False, {"time_s": float(self.sim.build.env.now)}
            else:
                self.sim.end_round()
                done, info = self._to_next_decision()
        reward = self._reward(done, info)
        truncated = not done and self.decisions >= self._decision_limit
        self._ended = done or truncated
        info.update(invalid_action=invalid, decisions=self.decisions)
        return self._handout(), reward, done, truncated, info

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
        mask[self.valid_actions()] = True
        return mask

    def valid_actions(self) -> list[int]:
        """The valid actions in increasing order (waiting, the last action, among them when it is valid):
        :meth:`action_masks` without the dense mask, whose size grows with tasks x robots."""
        if self.sim is None or self._ended:
            return [self.wait_action]
        actions = sorted({self.action_of(request, robot) for request, robot in self.sim.decision_candidates()})
        return actions + [self.wait_action] if self.sim.can_wait() else actions

    def local_actions(self) -> list[int]:
        """Local observation: the valid actions among the awards of the observed ready tasks (and waiting,
        where valid), in increasing order; where none of those tasks can go to an idle robot and waiting
        is not valid, :meth:`valid_actions`. Its cost grows with the observed tasks, not the building."""
        sim, actions, index, capable = self.sim, [], self.robot_index, self.capable  # capable: incapability's, per node
        for node in self._local.ready:
            request = self._request_of[node]
            actions += [node * self.max_robots + index[name] for name in sim.build.idle[request.activity] if capable[node, index[name]]]
        actions.sort()
        if sim.can_wait():
            return actions + [self.wait_action]
        return actions or self.valid_actions()

    def _valid(self, action: int) -> bool:
        """Whether ``action`` is valid now (one entry of :meth:`action_masks`, without building the mask)."""
        return self._award_of(action) is not None

    def _award_of(self, action: int):
        """(pending request, robot name) of a valid award, () for valid waiting, None for an invalid action."""
        if action == self.wait_action:
            return () if self.sim.can_wait() else None
        if not 0 <= action < self.wait_action:
            return None
        node, index = divmod(action, self.max_robots)
        if index >= len(self.robot_names):
            return None
        request, name = self._pending_request(node), self.robot_names[index]
        if (request is not None and name in self.sim.build.idle[request.activity]
                and not incapability(self.sim.build.robots[name].spec, request)):
            return request, name
        return None

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
        """The pending request of graph node ``node``, or None when it is not ready (looked for in the
        pool of the node's activity only)."""
        task = self.graph.requests[node] if node < len(self.graph.requests) else None
        if task is None:  # a floor gate, or padding
            return None
        if self._local is not None:  # the events are followed at every step: the state says
            return self._request_of[node] if self.state[node] == 1 else None
        for request in self.sim.build.pending[task.activity]:
            if self._node_of(request) == node:
                return request
        return None

    # ---------------------------------------------------------------- observation
    def _set_up_arrays(self, fleet: Fleet) -> None:
        """What holds for the whole episode (task and robot features, compatibility, handling times,
        precedences and the order earliest starts are computed in) and the observation's buffers."""
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
        self.shortest = np.where(np.isfinite(shortest), shortest, 0.0)[:n]  # float32, as the observation
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
        depth = graph.depths()
        self.levels = _levels(depth, graph.edges)  # (nodes, indices of the edges into them) per depth
        self.group_after = np.zeros(int(graph.groups.max(initial=-1)) + 1, np.int64)
        self.group_after[graph.groups] = graph.edges[:, 1]
        self.state = np.zeros(n, np.int64)  # index into STATES
        self._fixed = {  # what does not change during the episode
            "node_mask": _mask(self.max_tasks, n), "robot_mask": _mask(self.max_robots, r),
            "precedence": self.precedence, "precedence_mask": _mask(self.max_edges, len(graph.edges)),
            "precedence_any": self.precedence_any, "compatibility": self.capable.astype(np.int8), "handling_s": self.handling,
        }
        self._set_up_buffers(n, r, depth)

    def _set_up_buffers(self, n: int, r: int, depth: np.ndarray) -> None:
        """The arrays the observation keeps between decisions and updates where the last decision changed
        something: node states, the gates' open predecessors, travel columns, earliest starts; and the
        read-only views of them that :meth:`_observation` hands out."""
        graph = self.graph
        self._gates = graph.kinds == KINDS.index("gate")
        self._adds = np.where(self._gates, 0.0, self.shortest)  # what a waiting node's finish adds to its start (s)
        self._order, self._node_groups, self._group_edges, self._sources = _in_edges(n, graph.edges, graph.groups, depth)
        self._is_root = (depth == 0).astype(np.int8)  # a waiting root finishes "now" (no level computes it)
        self._waiting = n  # nodes still waiting; ``_order`` is cut down to them as they leave
        into_gate = self._gates[graph.edges[:, 1]] if len(graph.edges) else np.zeros(0, bool)
        self._open_before = np.bincount(graph.edges[into_gate, 1], minlength=n)  # per gate: predecessors not done
        self._gates_after: dict[int, list[int]] = {}
        for a, b in graph.edges[into_gate].tolist():
            self._gates_after.setdefault(a, []).append(b)
        self._gate_nodes = np.flatnonzero(self._gates).tolist()
        self._gate_before = {g: graph.edges[graph.edges[:, 1] == g, 0] for g in self._gate_nodes}
        self._nodes = self.static.copy()
        self._nodes[np.arange(n), 10] = 1.0  # every node waiting
        self._robots = self.robot_static.copy()
        self._time = np.zeros(1, np.float32)
        self._travel = np.zeros((self.max_tasks, self.max_robots), np.float32)
        self._travel_from = np.full((r, 2), np.nan)  # where each robot's travel column was computed from
        self._rows = [np.flatnonzero(self.capable[:n, j]) for j in range(r)]
        self._rows_xy = [self.start_xy[rows] for rows in self._rows]
        self._finish = np.empty(n)
        self._running_until = np.full(n, np.nan)
        self._running: list[int] = []
        self._observed = None
        fixed = self._fixed
        self._views = {key: _read_only(value) for key, value in (
            ("node_features", self._nodes), ("node_mask", fixed["node_mask"]), ("robot_features", self._robots),
            ("robot_mask", fixed["robot_mask"]), ("precedence", fixed["precedence"]),
            ("precedence_mask", fixed["precedence_mask"]), ("precedence_any", fixed["precedence_any"]),
            ("compatibility", fixed["compatibility"]), ("handling_s", fixed["handling_s"]), ("travel_s", self._travel),
            ("time_s", self._time))}
        self._local, self._request_of = None, {}
        if self.observation == "local":  # the masks are the neighbourhood's, kept up; the context added
            self._local = LocalKeeper(graph, self.max_tasks, self.max_edges, self._nodes)
            self._views.update(node_mask=_read_only(self._local.node_mask), precedence_mask=_read_only(self._local.edge_mask),
                               context=_read_only(self._local.context))

    def _height(self, request, component) -> float:
        if request.node_ids and request.activity != Task.TRANSPORT:
            return float(self.sim.smart.nodes[request.node_ids[0]].position[2])
        if request.joint_id:
            return float(self.sim.smart.joints[request.joint_id].position[2])
        return float(component.target_position[2])

    def _set_state(self, node: int, state: int) -> None:
        """Node ``node`` is now in ``state`` (index into :data:`STATES`): its one-hot, the gates after it;
        a node that stops waiting starts now (earliest start 0 s from now, for good: none waits again)."""
        old = int(self.state[node])
        self.state[node] = state
        self._nodes[node, 10 + old] = 0.0
        self._nodes[node, 10 + state] = 1.0
        if old == 0 and state != 0:
            self._nodes[node, 14] = 0.0
            self._waiting -= 1
        if state == 3 and old != 3:
            for gate in self._gates_after.get(node, ()):
                self._open_before[gate] -= 1
        if self._local is not None:
            self._local.state_changed(node, old, state)

    def _follow_events(self) -> None:
        """Node states from the simulation's event log since the last look."""
        events = self.sim.build.events
        for event in events[self._seen_events:]:
            kind = event["event"]
            if kind == "task_request":
                key = task_key(event["activity"], event["component"], event["joint"], event["node"])
                node = self.graph_index[key]
                self._request_node[event["request"]] = node
                if self._local is not None:
                    request = self._request_of[node] = self.sim.published[event["request"]]
                    self._local.priority[node] = request.priority[:1] + request.priority[2:]  # one pool: one rank
                self._set_state(node, 1)
            elif kind == "award":
                self._set_state(self._request_node[event["request"]], 2)
            elif kind == "reauction":
                self._set_state(self._request_node[event["request"]], 1)
            elif kind == "finish":
                node = self._request_node[event["request"]]
                self._finished_at[node] = event["time"]
                self._set_state(node, 3)
        self._seen_events = len(events)

    def _close_gates(self) -> None:
        """A floor gate is done once every node before it is (gates are not tasks: no events). In index
        order, so that closing one floor's gate may close the next one's at once."""
        for gate in self._gate_nodes:
            if self.state[gate] != 3 and self._open_before[gate] == 0:
                self._finished_at[gate] = np.max(self._finished_at[self._gate_before[gate]], initial=0.0)
                self._set_state(gate, 3)

    def _observation(self) -> dict:
        """The observation now, as read-only views of the arrays kept between decisions (valid until the
        next step): node states follow the new events, the gates their counts of open predecessors, a
        robot's travel column is recomputed only when where it drives from changed; the earliest starts,
        which move with the clock, are one compiled pass over the nodes still waiting. The values are
        those of :func:`rebuild_observation` (tests compare them)."""
        now = float(self.sim.build.env.now)
        key = (self._episode, self.decisions, len(self.sim.build.events), now)
        if key == self._observed:  # asked again with nothing changed (a policy reading the last step's)
            return self._views
        self._follow_events()
        self._close_gates()
        robots = [self.sim.build.robots[name] for name in self.robot_names]
        self._update_starts(now, robots)
        moved = []
        for j, robot in enumerate(robots):
            busy = robot.task is not None
            here = self.sim.where(robot)
            self._robots[j, 0:2] = here
            self._robots[j, 6:9] = (busy, max(0.0, robot.free_at - now) if busy else 0.0, robot.broken)
            moved.append(self._update_travel(j, robot.end_position if busy else here))
        if self._local is not None:
            self._update_local_travel(moved)
        self._time[0] = now
        self._observed = key
        return self._views

    def _handout(self) -> dict:
        """The observation as ``reset`` and ``step`` return it: new arrays (``copy_observation``, gymnasium's
        contract) or the read-only views themselves, in a new dict."""
        views = self._observation()
        return {k: v.copy() for k, v in views.items()} if self.copy_observation else dict(views)

    def _update_starts(self, now: float, robots: list) -> None:
        """Column ``earliest_start_s`` of the waiting nodes (see :func:`_earliest_starts_pass`); the order
        of the pass is cut down to the waiting nodes once fewer than half of it still wait."""
        for node in self._running:
            self._running_until[node] = np.nan
        self._running = [self._node_of(robot.task) for robot in robots if robot.task is not None]
        for node, robot in zip(self._running, (robot for robot in robots if robot.task is not None)):
            self._running_until[node] = robot.free_at
        if self._local is not None:
            local = self._local
            _local_pass()(local.nodes, self._gates, self._node_groups, self._group_edges, self._sources, self.state, self._finished_at,
                          self._running_until, self.shortest, self._adds, now, self._nodes)
            local.update_context()
            return
        if 2 * self._waiting < len(self._order):
            self._order = self._order[self.state[self._order] == 0]
        _starts_pass()(self._order, self._node_groups, self._group_edges, self._sources, self.state, self._is_root,
                       self._finished_at, self._running_until, self.shortest, self._adds, now, self._finish, self._nodes)

    def _update_travel(self, j: int, where) -> bool:
        """Robot ``j``'s travel column (s to every task it can do, from ``where``, site frame m), when
        ``where`` moved since it was last computed (True); local: only where it is read, see
        :meth:`_update_local_travel`."""
        x, y = float(where[0]), float(where[1])
        if self._travel_from[j, 0] == x and self._travel_from[j, 1] == y:
            return False
        self._travel_from[j] = (x, y)
        if self._local is None:
            _travel_pass()(self._rows[j], self._rows_xy[j], x, y, float(self.speeds[j]), self._travel, j)
        return True

    def _update_local_travel(self, moved: list[bool]) -> None:
        """The local observation's travel: rows of the ready tasks only (0 elsewhere): the rows that
        stopped being ready cleared, the columns of the robots that moved over every ready row, the rows
        that became ready for the other robots."""
        local = self._local
        for row in local.left_ready:
            self._travel[row] = 0.0
        ready = np.fromiter(local.ready, np.int64, len(local.ready))
        new = np.fromiter(local.newly_ready, np.int64, len(local.newly_ready))
        _local_travel_pass()(ready, new, np.array(moved), self.capable, self.start_xy, self._travel_from, self.speeds,
                             self._travel)
        local.left_ready.clear()
        local.newly_ready.clear()

    def render(self):
        if self.render_mode != "ansi" or self.sim is None:
            return None
        counts = {s: int(np.sum(self.state == i)) for i, s in enumerate(STATES)}
        return f"t = {self.sim.build.env.now:.1f} s, decision {self.decisions}: " + ", ".join(f"{v} {k}" for k, v in counts.items())


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


__all__ = ["ENV_ID", "BOUND", "KINDS", "STATES", "NODE_FEATURES", "ROBOT_FEATURES", "DispatchProblem", "frame_problem",
           "simulate_problem", "task_key", "request_key", "TaskGraph", "task_graph", "AgentDispatcher", "DispatchEnv",
           "rebuild_observation", "MarketPolicy", "play"]


def _register() -> None:
    if ENV_ID not in gym.registry:
        gym.register(id=ENV_ID, entry_point="bimrobot.planning.dispatch:DispatchEnv")


_register()
