"""The observation of the dispatching environment rebuilt from nothing (:func:`rebuild_observation`, the
definition its kept-up arrays must equal bit for bit) and the precedence-graph arithmetic both share:
depths and levels, earliest starts level by level (numpy) and in one compiled pass (numba), and the
compiled travel column of a robot.

Units: seconds, metres (site frame x, y; model frame z, z up).
"""

from __future__ import annotations

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
    for robot in robots:
        if robot.task is not None:
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
    where = np.zeros((env.max_robots, 2))
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
