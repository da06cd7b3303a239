"""The observation of the dispatching environment rebuilt from nothing (:func:`rebuild_observation`, the
definition its kept-up arrays must equal bit for bit) and the precedence-graph arithmetic both share:
depths and levels, earliest starts level by level (numpy) and in one compiled pass (numba), and the
compiled travel column of a robot.

Units: seconds, metres (site frame x, y; model frame z, z up).
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from bimrobot.planning.dispatch_problem import KINDS, request_key, task_key


def rebuild_observation(env) -> dict:
    """The observation of ``env`` (a :class:`~bimrobot.planning.dispatch.DispatchEnv`, maybe wrapped) now,
    rebuilt from nothing: node states replayed from the whole event log, gates closed, earliest starts
    level by level through the precedence graph, travel of every task and robot. The definition the
    environment's kept-up arrays must equal (bit for bit); it leaves ``env`` as it is. Seconds, metres
    (site frame x, y; model frame z)."""
    env = env.unwrapped
    graph, sim = env.graph, env.sim
    n, now = len(graph.keys), float(sim.build.env.now)
    state, finished_at, request_node = np.zeros(n, np.int64), np.full(n, np.nan), {}
    for event in sim.build.events:
        kind = event["event"]
        if kind == "task_request":
            node = env.graph_index[task_key(event["activity"], event["component"], event["joint"], event["node"])]
            request_node[event["request"]], state[node] = node, 1
        elif kind in ("award", "reauction"):
            state[request_node[event["request"]]] = 2 if kind == "award" else 1
        elif kind == "finish":
            node = request_node[event["request"]]
            state[node], finished_at[node] = 3, event["time"]
    robots = [sim.build.robots[name] for name in env.robot_names]
    running_until = np.full(n, np.nan)
    for robot in (r for r in robots if r.task is not None):
        running_until[env.graph_index[request_key(sim, robot.task)]] = robot.free_at
    gates = graph.kinds == KINDS.index("gate")
    for i in np.flatnonzero(gates & (state != 3)):
        before = graph.edges[graph.edges[:, 1] == i, 0]
        if np.all(state[before] == 3):
            state[i], finished_at[i] = 3, np.max(finished_at[before], initial=0.0)
    start = _level_starts(env, state, finished_at, now, running_until, gates)
    nodes = env.static.copy()
    nodes[np.arange(n), 10 + state] = 1.0
    nodes[:n, 14] = start - now
    robot_features = env.robot_static.copy()
    where = np.zeros((env.max_robots, 2))  # where each robot drives from
    for j, robot in enumerate(robots):
        busy = robot.task is not None
        here = sim.where(robot)
        where[j] = robot.end_position if busy else here
        robot_features[j, 0:2] = here
        robot_features[j, 6:9] = (busy, max(0.0, robot.free_at - now) if busy else 0.0, robot.broken)
    travel = np.zeros((env.max_tasks, env.max_robots), np.float32)
    k = len(robots)
    distance = np.hypot(*(env.start_xy[:n, None, :] - where[None, :k, :]).transpose(2, 0, 1))
    travel[:n, :k] = np.where(env.capable[:n, :k], distance / env.speeds[None, :], 0.0)
    if env.observation == "local":
        return _rebuild_local(env, state, finished_at, running_until, now, nodes, robot_features, travel)
    return {
        "node_features": nodes,
        "node_mask": _mask(env.max_tasks, n),
        "robot_features": robot_features,
        "robot_mask": _mask(env.max_robots, k),
        "precedence": env.precedence.copy(),
        "precedence_mask": _mask(env.max_edges, len(graph.edges)),
        "precedence_any": env.precedence_any.copy(),
        "compatibility": env.capable.astype(np.int8),
        "handling_s": env.handling.copy(),
        "travel_s": travel,
        "time_s": np.array([now], np.float32),
    }


def _rebuild_local(env, state, finished_at, running_until, now, nodes, robot_features, travel) -> dict:
    """The local observation (``observation="local"``) from the states rebuilt by :func:`rebuild_observation`:
    the ready tasks' neighbourhood (:func:`local_nodes`) masked in with the edges between its nodes, the
    local earliest starts (:func:`local_starts`), travel of the ready tasks only, the context."""
    graph, n, k = env.graph, len(env.graph.keys), len(env.robot_names)
    gates = graph.kinds == KINDS.index("gate")
    held = observed_ready(state, graph.kinds, _priorities(env))
    seen = local_nodes(held, _adjacency(n, graph.edges), gates)
    node_mask = np.zeros(env.max_tasks, np.int8)
    node_mask[list(seen)] = 1
    edge_mask = np.zeros(env.max_edges, np.int8)
    if len(graph.edges):
        edge_mask[: len(graph.edges)] = node_mask[graph.edges[:, 0]] & node_mask[graph.edges[:, 1]]
    nodes[:n, 14] = local_starts(env, state, finished_at, running_until, seen, now)
    travel[np.setdiff1d(np.arange(n), held)] = 0.0
    counts = np.bincount(graph.kinds * 4 + state, minlength=len(CONTEXT))
    return {
        "node_features": nodes, "node_mask": node_mask, "robot_features": robot_features,
        "robot_mask": _mask(env.max_robots, k), "precedence": env.precedence.copy(), "precedence_mask": edge_mask,
        "precedence_any": env.precedence_any.copy(), "compatibility": env.capable.astype(np.int8),
        "handling_s": env.handling.copy(), "travel_s": travel, "time_s": np.array([now], np.float32),
        "context": (counts / n).astype(np.float32),
    }


def _priorities(env) -> dict[int, tuple]:
    """Each published task's place in its request pool, from the event log: (floor, the component's bottom
    z rounded to mm, publication sequence), the simulation's request priority less the activity's rank
    (one pool holds one activity)."""
    out = {}
    for event in env.sim.build.events:
        if event["event"] == "task_request":
            node = env.graph_index[task_key(event["activity"], event["component"], event["joint"], event["node"])]
            bottom = round(env.sim.smart.components[event["component"]].bottom_z, 3)
            out[node] = (env.graph.requests[node].floor, bottom, int(event["request"][1:]))
    return out


def _level_starts(env, state, finished_at, now: float, running_until, gates) -> np.ndarray:
    """Earliest start (s) of every node: now for ready, running and done work; for waiting work the
    latest earliest finish of what it waits for (shortest handling, no travel; a gate takes none), the
    first of a group of alternatives counting. Level by level (numpy), the definition."""
    graph = env.graph
    # waiting nodes: overwritten level by level before anything after them reads them
    finish = np.where(state == 3, finished_at, now)
    finish = np.where(state == 2, np.nan_to_num(running_until, nan=now), finish)
    ready = state == 1
    finish[ready] = now + env.shortest[ready]
    start = np.full(len(state), now)
    bound = np.full(len(state), now)
    first = np.full(len(env.group_after), np.inf)  # per group: the first of its alternatives to finish
    for level, into in env.levels:
        todo = level[state[level] == 0]
        if todo.size == 0:
            continue
        groups = graph.groups[into]
        np.minimum.at(first, groups, finish[graph.edges[into, 0]])
        np.maximum.at(bound, env.group_after[groups], first[groups])
        start[todo] = bound[todo]
        finish[todo] = bound[todo] + np.where(gates[todo], 0.0, env.shortest[todo])
    return start


def _earliest_starts_pass(order, node_groups, group_edges, sources, state, is_root, finished_at, running_until,
                          shortest, adds, now, finish, nodes):
    """Compiled by numba (:func:`_starts_pass`): :func:`_level_starts` for the waiting nodes in ``order``
    (by depth, all of depth >= 1; others in it are skipped), written into column 14 of ``nodes`` as
    seconds from ``now`` (the other nodes' 0 is kept there by the environment). Node v's alternative
    groups are ``node_groups[v]:node_groups[v + 1]``, group g's edges ``group_edges[g]:group_edges[g + 1]``,
    their first nodes ``sources``; a source's finish comes from its state (done: when it finished;
    running: when its robot is free; ready: now + its shortest handling, in float32; waiting: this pass's
    ``finish``, a root's now). Same arithmetic as the levels (NaN kept by min and max), so the same bits."""
    now32 = np.float32(now)
    for v in order:
        if state[v] != 0:
            continue
        bound = now
        for g in range(node_groups[v], node_groups[v + 1]):
            first = np.inf
            for e in range(group_edges[g], group_edges[g + 1]):
                u = sources[e]
                s = state[u]
                if s == 3:
                    x = finished_at[u]
                elif s == 2:
                    x = running_until[u]
                    if x != x:
                        x = now
                    elif x == np.inf:
                        x = 1.7976931348623157e308  # nan_to_num's largest finite float
                    elif x == -np.inf:
                        x = -1.7976931348623157e308
                elif s == 1:
                    x = now32 + shortest[u]
                elif is_root[u]:
                    x = now
                else:
                    x = finish[u]
                if x < first or x != x:
                    first = x
            if first > bound or first != first:
                bound = first
        finish[v] = bound + np.float64(adds[v])
        nodes[v, 14] = bound - now


def _travel_column(rows, xy, x, y, speed, travel, j):
    """Compiled by numba (:func:`_travel_pass`): column ``j`` of ``travel`` at ``rows``, the driving time
    (s) from (x, y) to each row's point ``xy`` (site frame, m) at ``speed`` (m/s), stored as float32: the
    bits of ``np.hypot(dx, dy) / speed`` of :func:`rebuild_observation`, at the cost of a square root.
    sqrt(dx^2 + dy^2) / speed is within a few float64 ulps (about 1e-15) of hypot's; where every value
    within 1e-14 of it rounds to the same float32, so does hypot's, else (about one in 10^7) hypot decides."""
    for k in range(rows.size):
        dx = xy[k, 0] - x
        dy = xy[k, 1] - y
        d = math.sqrt(dx * dx + dy * dy) / speed
        if np.float32(d * (1.0 - 1e-14)) != np.float32(d * (1.0 + 1e-14)):
            d = math.hypot(dx, dy) / speed
        travel[rows[k], j] = d


def _local_travel(ready, new, moved, capable, xy, origin, speeds, travel):
    """Compiled by numba (:func:`_local_travel_pass`): the local observation's travel, as
    :func:`_travel_column` per robot j: for every row of ``ready`` where ``moved[j]``, else for the rows of
    ``new``; capable rows only, from ``origin[j]`` (site frame, m) at ``speeds[j]`` (m/s)."""
    for j in range(speeds.size):
        rows = ready if moved[j] else new
        x, y, speed = origin[j, 0], origin[j, 1], speeds[j]
        for k in range(rows.size):
            i = rows[k]
            if not capable[i, j]:
                continue
            dx = xy[i, 0] - x
            dy = xy[i, 1] - y
            d = math.sqrt(dx * dx + dy * dy) / speed
            if np.float32(d * (1.0 - 1e-14)) != np.float32(d * (1.0 + 1e-14)):
                d = math.hypot(dx, dy) / speed
            travel[i, j] = d


_COMPILED: dict = {}


def _compiled(function):
    """``function`` compiled by numba (cached next to this file; compiled on first use)."""
    if function.__name__ not in _COMPILED:
        from numba import njit

        _COMPILED[function.__name__] = njit(cache=True)(function)
    return _COMPILED[function.__name__]


def _starts_pass():
    """:func:`_earliest_starts_pass` compiled."""
    return _compiled(_earliest_starts_pass)


def _local_travel_pass():
    """:func:`_local_travel` compiled."""
    return _compiled(_local_travel)


def _travel_pass():
    """:func:`_travel_column` compiled."""
    return _compiled(_travel_column)


def _read_only(array: np.ndarray) -> np.ndarray:
    """A view of ``array`` that cannot be written through (the environment's kept arrays, handed out)."""
    view = array.view()
    view.flags.writeable = False
    return view


def _mask(size: int, real: int) -> np.ndarray:
    mask = np.zeros(size, np.int8)
    mask[:real] = 1
    return mask


def _levels(depth: np.ndarray, edges: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(nodes, the edges into them) per depth, from depth 1 on: each node's predecessors lie at smaller depths."""
    into = depth[edges[:, 1]] if len(edges) else np.zeros(0, np.int64)
    return [(np.flatnonzero(depth == d), np.flatnonzero(into == d)) for d in range(1, int(depth.max(initial=0)) + 1)]


def _in_edges(n: int, edges: np.ndarray, groups: np.ndarray, depth: np.ndarray):
    """The precedences as :func:`_earliest_starts_pass` reads them: (the nodes of depth >= 1 by depth,
    per node the range of its groups, per group the range of its edges, the edges' first nodes)."""
    order = np.flatnonzero(depth >= 1)
    order = order[np.argsort(depth[order], kind="stable")]
    if not len(edges):
        return order, np.zeros(n + 1, np.int64), np.zeros(1, np.int64), np.zeros(0, np.int64)
    by = np.lexsort((groups, edges[:, 1]))  # edges by the node they lead into, then by group
    after, group = edges[by, 1], groups[by]
    first = np.flatnonzero(np.r_[True, (group[1:] != group[:-1]) | (after[1:] != after[:-1])])
    group_edges = np.r_[first, len(by)].astype(np.int64)
    node_groups = np.searchsorted(after[first], np.arange(n + 1)).astype(np.int64)
    return order, node_groups, group_edges, np.ascontiguousarray(edges[by, 0], dtype=np.int64)


# ---------------------------------------------------------------- the local observation (``observation="local"``)
#: how far from a ready task the local observation reaches, in precedence edges (the message passing's rounds)
REACH = 2
#: the ready tasks the local observation holds, per activity: the first of its request pool (the market's order)
LOCAL_READY = 16
#: ``context`` of the local observation: per node kind (transport, position, assemble, gate) and state
#: (waiting, ready, running, done) the share of the building's nodes (0-1), kind-major
CONTEXT = tuple(f"{kind}_{state}" for kind in KINDS for state in ("waiting", "ready", "running", "done"))


def _adjacency(n: int, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The precedences as compressed rows over both directions: node v's incident edges are
    ``edge_of[start[v]:start[v + 1]]`` and the nodes at their other ends ``other[...]``."""
    if not len(edges):
        return np.zeros(n + 1, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    ends = np.concatenate([edges[:, 0], edges[:, 1]])
    far = np.concatenate([edges[:, 1], edges[:, 0]])
    ids = np.concatenate([np.arange(len(edges)), np.arange(len(edges))])
    by = np.argsort(ends, kind="stable")
    start = np.searchsorted(ends[by], np.arange(n + 1)).astype(np.int64)
    return start, ids[by].astype(np.int64), far[by].astype(np.int64)


def _owned(n: int, edges: np.ndarray, gates: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each edge once, at one of its nodes: its first node, unless that is a floor gate and the second is
    not (a gate has an edge to every task of its floor): node v's edges are ``ids[start[v]:start[v + 1]]``.
    Reading the edges between observed nodes then costs what those nodes' own edges cost."""
    if not len(edges):
        return np.zeros(n + 1, np.int64), np.zeros(0, np.int64)
    owner = np.where(gates[edges[:, 0]] & ~gates[edges[:, 1]], edges[:, 1], edges[:, 0])
    ids = np.argsort(owner, kind="stable")
    return np.searchsorted(owner[ids], np.arange(n + 1)).astype(np.int64), ids.astype(np.int64)


def ball(node: int, adjacency, gates: np.ndarray, reach: int = REACH) -> set[int]:
    """The nodes within ``reach`` precedence edges of ``node`` (either direction, ``node`` included), on
    paths that do not pass through a floor gate: a gate is reached but not gone through (it has an edge to
    every task of its floor). Independent of the building's size."""
    start, _, other = adjacency
    seen, frontier = {node}, [node]
    for _ in range(reach):
        step = []
        for v in frontier:
            if gates[v] and v != node:
                continue
            for u in other[start[v]:start[v + 1]].tolist():
                if u not in seen:
                    seen.add(u)
                    step.append(u)
        frontier = step
    return seen


def observed_ready(state: np.ndarray, kinds: np.ndarray, priority: dict) -> list[int]:
    """The ready tasks the local observation holds, from nothing: per kind (activity) the first
    :data:`LOCAL_READY` ready nodes (``state`` 1) by ``priority`` (node -> its request's priority, the
    order of the simulation's request pools)."""
    held = []
    for kind in range(3):
        ready = [v for v in np.flatnonzero((state == 1) & (kinds == kind)).tolist()]
        held += sorted(ready, key=lambda v: priority[v])[:LOCAL_READY]
    return held


def local_nodes(ready, adjacency, gates: np.ndarray) -> set[int]:
    """The local observation's nodes from nothing: the observed ready nodes and their :func:`ball`."""
    nodes: set[int] = set()
    for v in ready:
        nodes |= ball(v, adjacency, gates)
    return nodes


def local_starts(env, state, finished_at, running_until, nodes, now: float) -> np.ndarray:
    """The local earliest starts (s from now, float32) of ``nodes`` (graph indices; the rest is 0): for a
    waiting task, the latest over its groups of the first finish among each group's predecessors, where a
    predecessor finishes when it did (done), when its robot is free (running), now + its shortest handling
    (ready: the float32 sum, as the full observation) or no earlier than now + its own shortest handling
    (waiting; a gate now). One level of the precedences only, so its cost is that of ``nodes``' edges.
    Ready, running and done work and gates: 0. The definition (numpy) of :func:`_local_starts_pass`."""
    graph = env.graph
    gates = graph.kinds == KINDS.index("gate")
    out = np.zeros(len(state), np.float32)
    todo = np.array(sorted(v for v in nodes if state[v] == 0 and not gates[v]), np.int64)
    if not todo.size:
        return out
    into = np.flatnonzero(np.isin(graph.edges[:, 1], todo))
    u = graph.edges[into, 0]
    x = np.where(state[u] == 3, finished_at[u], now + np.where(gates[u], 0.0, env.shortest[u]).astype(np.float64))
    x = np.where(state[u] == 2, np.nan_to_num(running_until[u], nan=now), x)
    x = np.where(state[u] == 1, (np.float32(now) + env.shortest[u]).astype(np.float64), x)
    first = np.full(len(env.group_after), np.inf)
    np.minimum.at(first, graph.groups[into], x)
    bound = np.full(len(state), now)
    np.maximum.at(bound, env.group_after[graph.groups[into]], first[graph.groups[into]])
    out[todo] = bound[todo] - now
    return out


def _local_starts(observed, gates, node_groups, group_edges, sources, state, finished_at, running_until, shortest,
                  adds, now, nodes):
    """Compiled by numba (:func:`_local_pass`): :func:`local_starts` for the waiting tasks among
    ``observed`` (gates skipped), written into column 14 of ``nodes`` (s from now). The arithmetic of
    :func:`_earliest_starts_pass` with a waiting predecessor's finish at now + ``adds`` (its shortest
    handling; a gate's 0)."""
    now32 = np.float32(now)
    for v in observed:
        if state[v] != 0 or gates[v]:
            continue
        bound = now
        for g in range(node_groups[v], node_groups[v + 1]):
            first = np.inf
            for e in range(group_edges[g], group_edges[g + 1]):
                u = sources[e]
                s = state[u]
                if s == 3:
                    x = finished_at[u]
                elif s == 2:
                    x = running_until[u]
                    if x != x:
                        x = now
                    elif x == np.inf:
                        x = 1.7976931348623157e308
                    elif x == -np.inf:
                        x = -1.7976931348623157e308
                elif s == 1:
                    x = now32 + shortest[u]
                else:
                    x = now + np.float64(adds[u])
                if x < first or x != x:
                    first = x
            if first > bound or first != first:
                bound = first
        nodes[v, 14] = bound - now


def _local_pass():
    """:func:`_local_starts` compiled."""
    return _compiled(_local_starts)


def _cover_ball(nodes, change, cover, node_mask, edge_mask, features, start, edge_of, other, members, where, count):
    """Compiled by numba (:func:`_cover_pass`): one ready task's ball ``nodes`` counted in (``change`` +1) or
    out (-1). A node whose count leaves 0 enters the observation (its mask, the masks of its edges to
    observed nodes, appended to ``members``, its place in ``where``); one whose count reaches 0 leaves it
    (masks cleared, its earliest start column set to 0, swapped out of ``members``). Returns the new count
    of members."""
    for v in nodes:
        cover[v] += change
        if change > 0 and cover[v] == 1:
            node_mask[v] = 1
            for k in range(start[v], start[v + 1]):
                edge_mask[edge_of[k]] = 1 if cover[other[k]] > 0 else 0
            members[count] = v
            where[v] = count
            count += 1
        elif change < 0 and cover[v] == 0:
            node_mask[v] = 0
            for k in range(start[v], start[v + 1]):
                edge_mask[edge_of[k]] = 0
            features[v, 14] = 0.0
            count -= 1
            last = members[count]
            members[where[v]] = last
            where[last] = where[v]
            where[v] = -1
    return count


def _cover_pass():
    """:func:`_cover_ball` compiled."""
    return _compiled(_cover_ball)


class LocalKeeper:
    """What the local observation keeps up between decisions, at a cost per event that does not grow with
    the building: per node how many ready tasks' :func:`ball` hold it (the node is observed while that is
    above 0), the observed nodes (``members[:count]``, any order) and the ready tasks, ``node_mask`` and
    ``precedence_mask`` over the observed nodes, and the counts per kind and state behind ``context``.
    ``features``: the environment's ``node_features``, whose earliest start it clears for a node that
    leaves the observation."""

    def __init__(self, graph, max_tasks: int, max_edges: int, features: np.ndarray):
        n = len(graph.keys)
        self.graph, self.n, self.features = graph, n, features
        self.gates = graph.kinds == KINDS.index("gate")
        self.adjacency = _adjacency(n, graph.edges)
        self.owned = _owned(n, graph.edges, self.gates)
        self.cover = np.zeros(n, np.int64)
        self.members, self.where, self.count = np.zeros(n, np.int64), np.full(n, -1, np.int64), 0
        self.ready: dict[int, None] = {}  # the observed ready tasks
        self.queues: dict[int, list] = {kind: [] for kind in range(3)}  # per kind: (priority, node) of the ready ones, sorted
        self.priority: dict[int, tuple] = {}
        self.newly_ready: set[int] = set()
        self.left_ready: set[int] = set()
        self.node_mask = np.zeros(max_tasks, np.int8)
        self.edge_mask = np.zeros(max_edges, np.int8)
        self.counts = np.bincount(graph.kinds * 4, minlength=len(CONTEXT))  # every node waiting
        self.context = np.zeros(len(CONTEXT), np.float32)
        self.balls: dict[int, np.ndarray] = {}

    @property
    def nodes(self) -> np.ndarray:
        """The observed nodes (graph indices, in no particular order): a view, valid until the next event."""
        return self.members[: self.count]

    def state_changed(self, node: int, old: int, new: int) -> None:
        """Node ``node`` went from state ``old`` to ``new`` (indices into STATES); a task that becomes ready
        has its request's priority in :attr:`priority`."""
        kind = int(self.graph.kinds[node])
        self.counts[4 * kind + old] -= 1
        self.counts[4 * kind + new] += 1
        queue = self.queues.get(kind)
        if new == 1 and old != 1:
            entry = (self.priority[node], node)
            at = bisect.bisect_left(queue, entry)
            queue.insert(at, entry)
            if at < LOCAL_READY:
                self._hold(node, True)
                if len(queue) > LOCAL_READY:
                    self._hold(queue[LOCAL_READY][1], False)
        elif old == 1 and new != 1:
            at = bisect.bisect_left(queue, (self.priority[node], node))
            del queue[at]
            if at < LOCAL_READY:
                self._hold(node, False)
                if len(queue) >= LOCAL_READY:
                    self._hold(queue[LOCAL_READY - 1][1], True)

    def _hold(self, node: int, held: bool) -> None:
        """Ready task ``node`` enters (True) or leaves the observed ready tasks, with its ball."""
        if held:
            self.ready[node] = None
            self.newly_ready.add(node)
            self.left_ready.discard(node)
        else:
            del self.ready[node]
            self.newly_ready.discard(node)
            self.left_ready.add(node)
        self._cover(node, +1 if held else -1)

    def _cover(self, node: int, change: int) -> None:
        """Count ``node``'s ball in (+1) or out (-1) (:func:`_cover_ball`)."""
        if node not in self.balls:
            self.balls[node] = np.array(sorted(ball(node, self.adjacency, self.gates)), np.int64)
        start, edge_of, other = self.adjacency
        self.count = _cover_pass()(self.balls[node], change, self.cover, self.node_mask, self.edge_mask, self.features,
                                   start, edge_of, other, self.members, self.where, self.count)

    def update_context(self) -> None:
        """``context`` from the counts (share of the building's nodes, float32)."""
        self.context[:] = self.counts / self.n
