"""Priority rules as dispatchers of the one event simulation (issue 38), named ``rule:NAME`` by
:mod:`bimrobot.planning.planners`.

- ``most-successors``, ``longest-path``, ``shortest-handling``: at each allocation round the ready tasks
  are taken in the rule's order (most tasks after it, directly or not; longest remaining path of shortest
  handling times, the critical path; shortest handling time); each goes to the capable idle robot that
  finishes it soonest (travel + handling; ties: robot name).
- ``nearest``: the (ready task, idle robot) pair with the shortest drive first, again and again.
- ``completes-joints``: joints first, then the transport and positioning of the parts in one fixed
  order (:func:`completing_order`: each next part the one that completes the most joints with the parts
  before it), each to the capable idle robot that finishes it soonest. Where the positioning cranes are
  the bottleneck, it keeps them on parts whose joints can then be made; the other rules leave the joints
  of the last parts to the end (ROOT-staal's floor 2).

Deterministic. Times in seconds, positions (x, y) in metres in the site frame.
"""

from __future__ import annotations

import heapq

import numpy as np

from bimrobot.coordination.market import Award, Dispatcher, incapability, propose, handling_time
from bimrobot.core.errors import InputError
from bimrobot.core.tasks import Task

RULES = ("most-successors", "longest-path", "nearest", "shortest-handling", "completes-joints")
#: the cheap deterministic planners played side by side (``portfolio``, CP-SAT's start, the learned
#: search's incumbent): the least-cost market first, quickest-finish, then the rules
PORTFOLIO = ("market", "market:quickest-finish", *(f"rule:{r}" for r in RULES))


def completing_order(parts: dict[str, tuple[int, float]], joints: list[list[str]]) -> list[str]:
    """The parts one after the other (``parts``: part -> (floor, positioning s); ``joints``: each joint's
    parts): each next, the one that completes the most joints with the parts before it, on the lowest
    floor first, parts without joints last, the longer positioning first, then by name (a fixed order).
    A heap whose entries are renewed when a part's count changes: O((parts + joints) log parts)."""
    joints_of: dict[str, list[int]] = {part: [] for part in parts}
    members = [[m for m in dict.fromkeys(joint) if m in parts] for joint in joints]
    missing = [len(ms) for ms in members]
    for j, ms in enumerate(members):
        for m in ms:
            joints_of[m].append(j)
    completes = {part: sum(1 for j in joints_of[part] if missing[j] == 1) for part in parts}

    def entry(part: str) -> tuple:
        floor, seconds = parts[part]
        return (floor, not joints_of[part], -completes[part], -seconds, part)

    heap = [entry(part) for part in parts]
    heapq.heapify(heap)
    order, placed = [], set()
    while heap:
        top = heapq.heappop(heap)
        part = top[-1]
        if part in placed or top != entry(part):
            continue  # placed, or its count has changed since: a newer entry stands in the heap
        order.append(part)
        placed.add(part)
        for j in joints_of[part]:
            missing[j] -= 1
            if missing[j] == 1:  # the joint's last part now completes it
                last = next(m for m in members[j] if m not in placed)
                completes[last] += 1
                heapq.heappush(heap, entry(last))
    return order


def _completing_ranks(sim) -> dict[str, int]:
    """Component -> its rank in :func:`completing_order` over the robot-built parts and the joints to
    build (their robot-built members)."""
    built = [c for c in sim.smart.components.values() if not c.prebuilt]
    seconds = shortest_handling(sim, [sim.request_for(Task.POSITION, c) for c in built])
    parts = {c.id: (c.floor, s) for c, s in zip(built, seconds)}
    joints = [[g for g in joint.component_ids if g in parts] for joint in sim.joints_to_build()]
    return {part: rank for rank, part in enumerate(completing_order(parts, joints))}


def _request_key(sim, request) -> str:
    """The task graph's node of a published request (:func:`bimrobot.planning.dispatch.request_key`)."""
    from bimrobot.planning.dispatch import request_key

    return request_key(sim, request)


def shortest_handling(sim, requests) -> list[float]:
    """Each request's shortest handling time (s) over the robots that can do it; 0 for a gate (None) or a
    task no robot can do."""
    specs = [r.spec for r in sim.build.robots.values()]
    return [0.0 if request is None else
            min((handling_time(s, request) for s in specs if not incapability(s, request)), default=0.0)
            for request in requests]


def remaining_paths(graph, shortest: list[float]) -> list[float]:
    """Each node's longest remaining path through ``graph`` (s): its own and its successors' ``shortest``
    handling times (gates 0, travel left out)."""
    after, tail = graph.successors(), [0.0] * len(graph.keys)
    for i in reversed(graph.topological_order()):
        tail[i] = shortest[i] + max((tail[j] for j in after[i]), default=0.0)
    return tail


def _scores(sim, rule: str) -> dict[str, float]:
    """Each task's priority under ``rule`` (higher first): its number of successors (direct or not), or
    its longest remaining path in seconds (:func:`remaining_paths`), or minus its shortest handling time (s)."""
    from bimrobot.planning.dispatch import task_graph

    graph = task_graph(sim)
    if rule == "shortest-handling":
        return {k: -s for k, s in zip(graph.keys, shortest_handling(sim, graph.requests))}
    if rule == "longest-path":
        return dict(zip(graph.keys, remaining_paths(graph, shortest_handling(sim, graph.requests))))
    after, below = graph.successors(), [0] * len(graph.keys)  # successors as a bit set per task
    for i in reversed(graph.topological_order()):
        bits = 0
        for j in after[i]:
            bits |= below[j] | (1 << j)
        below[i] = bits
    return {k: float(bits.bit_count()) for k, bits in zip(graph.keys, below)}


class RuleDispatcher(Dispatcher):
    """A priority rule (module docstring) as the simulation's dispatcher; ``rule`` one of :data:`RULES`."""

    def __init__(self, rule: str):
        if rule not in RULES:
            raise InputError(f"unknown rule {rule!r}: choose one of {', '.join(RULES)}")
        self.rule, self.name = rule, f"rule:{rule}"
        self._scores: dict[str, float] | None = None
        self._sim = None
        self._key: dict[str, float] = {}  # request id -> its score under the rule
        self._ranks: dict[str, int] = {}  # completes-joints: component -> its rank
        self._capable: dict[tuple[str, str], bool] = {}  # nearest: (robot, request id) -> it may take it

    def awards(self, sim) -> list[Award]:
        if self._sim is not sim:
            self._sim, self._scores = sim, (None if self.rule in ("nearest", "completes-joints") else _scores(sim, self.rule))
            self._ranks = _completing_ranks(sim) if self.rule == "completes-joints" else {}
            self._key, self._capable = {}, {}
        now = sim.build.env.now
        idle = {a: set(names) for a, names in sim.build.idle.items()}
        pending = [r for pool in sim.build.pending.values() for r in pool]
        chosen: list[Award] = []
        if self.rule == "nearest":
            return self._nearest(sim, pending, idle, now)
        # only work some idle robot may take can be awarded: the rest is neither scored nor sorted
        pending = [r for r in pending if idle.get(r.activity)]
        for r in pending:
            if r.id not in self._key:
                self._key[r.id] = self._score(sim, r)
        # the rule's order (priorities are unique), taken lazily: a round awards a few of some 1,000 tasks
        order = [(-self._key[r.id], r.priority, i) for i, r in enumerate(pending)]
        heapq.heapify(order)
        where = {}  # robot name -> where it bids from (site frame, m), asked once per round
        live = {r.activity for r in pending}  # activities with work left here and an idle robot
        while order and live:
            request = pending[heapq.heappop(order)[2]]
            if request.activity not in live:
                continue
            names = [n for n in sorted(idle[request.activity]) if not incapability(sim.build.robots[n].spec, request)]
            for n in names:
                if n not in where:
                    where[n] = sim.position_now(sim.build.robots[n])
            proposals = [propose(sim.build.robots[n].spec, where[n], now, True, request) for n in names]
            if proposals:
                best = min(proposals, key=lambda p: (p.cost, p.robot))
                chosen.append(Award(request, best.robot, best, len(proposals)))
                for names in idle.values():
                    names.discard(best.robot)
                live = {a for a in live if idle[a]}
        return chosen

    def _score(self, sim, request) -> float:
        """The request's priority under the rule (higher first)."""
        if self.rule != "completes-joints":
            return self._scores.get(_request_key(sim, request), 0.0)
        if request.activity == Task.ASSEMBLE:
            return float(len(self._ranks))  # above every part
        return -float(self._ranks.get(request.component_id, len(self._ranks)))

    def _nearest(self, sim, pending, idle, now) -> list[Award]:
        """The shortest drive first: of all (task, idle robot) pairs, the nearest, again and again (ties: task
        priority, robot name). The same choice as sorting every pair, at one array of drives per robot:
        at 10,000 components some 1,000 tasks wait at each round."""
        where = {name: sim.position_now(sim.build.robots[name]) for names in idle.values() for name in names}
        mine: dict[str, list[int]] = {name: [] for name in where}  # robot -> the tasks it may take (indices)
        bidders = [0] * len(pending)
        for i, request in enumerate(pending):
            for name in idle[request.activity]:
                if self._can(sim, name, request):
                    mine[name].append(i)
                    bidders[i] += 1
        starts = np.array([r.start for r in pending], dtype=float).reshape(-1, 2)
        drives = {}  # robot -> (task indices, their drives in m: propose()'s distance, as np.hypot gives it)
        for name, tasks in mine.items():
            if tasks:
                at = starts[tasks] - where[name]
                drives[name] = (np.array(tasks), np.hypot(at[:, 0], at[:, 1]))
        chosen, taken = [], np.zeros(len(pending), dtype=bool)
        while drives:
            best = None
            for name, (tasks, drive) in drives.items():
                free = ~taken[tasks]
                if not free.any():
                    continue
                shortest = drive[free].min()
                i = min(tasks[free & (drive == shortest)], key=lambda k: pending[k].priority)
                if best is None or (shortest, pending[i].priority, name) < best[:3]:
                    best = (shortest, pending[i].priority, name, i)
            if best is None:
                break
            _, _, name, i = best
            chosen.append(Award(pending[i], name, propose(sim.build.robots[name].spec, where[name], now, True, pending[i]),
                                bidders[i]))
            taken[i] = True
            del drives[name]
        return chosen

    def _can(self, sim, name: str, request) -> bool:
        """Whether robot ``name`` can do ``request`` (:func:`incapability`, asked once per pair: neither changes)."""
        key = (name, request.id)
        if key not in self._capable:
            self._capable[key] = incapability(sim.build.robots[name].spec, request) is None
        return self._capable[key]
