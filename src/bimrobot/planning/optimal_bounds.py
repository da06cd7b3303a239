"""Redundant constraints and cuts of the CP-SAT model (:mod:`bimrobot.planning.optimal`), for its
lower bound: per floor, each robot's work and drives between the gate below and the floor's own gate
(:func:`_floor_loads`, :class:`_Visits`), the fastest split of work two robots share (subset sums) and
the two-stage bound (:func:`_staged_bound`), and on the lowest floor each robot's start after its first
task's lead-in (:func:`_first_lead`). Times in ticks (0.01 s)."""

from __future__ import annotations

import math

import numpy as np

from bimrobot.planning.optimal_graph import SCALE, _Task


def _floor_loads(model, tasks, gates, ancestors, capable, busy_min, assigned, travel, floor_least, first=None,
                 arrival=None) -> int:
    """Redundant, for the bound: on each floor f, the work of floor f that a robot does fits between the
    gate below (or time 0) plus the shortest lead-in before any of it can start, and the floor's own gate
    (everything that closes floors <= f done) less the shortest run-out after it. With the robot literals this
    is linear, so the relaxation balances each floor's work over the robots that can do it. On the lowest
    floor, ``first`` ((robot, task) -> the literal of the robot's first task) adds that task's own lead-in
    (:func:`_first_lead`). ``arrival`` ((task, robot) -> its least drive in as the robot's first task less
    its least drive in at all, ticks), where the problem is one floor from time 0: each robot's own
    earliest start in the two-stage bound (:func:`_staged_bound`). Returns the
    sum over floors of each floor's least duration known before solving (ticks): a lower bound of the
    makespan, since each gate follows the one below."""
    least = 0
    for floor, gate in gates.items():
        known = 0
        below = [f for f in gates if f < floor]
        opening = gates[max(below)] if below else 0
        mine = sorted((t for t in tasks if t.floor == floor), key=lambda t: bin(ancestors[t.key]).count("1"))
        keys = {t.key for t in mine}
        gated = {t.key for t in mine if not below or (t.gate_floor == floor)}
        head: dict[str, int] = {}
        for t in mine:  # ancestors first (fewer ancestors first is a topological order within the floor)
            preds = [p for p in t.predecessors if p in keys]
            if not below or t.key in gated or any(p in gated for p in preds):
                gated.add(t.key)
                head[t.key] = max((head[p] + min(busy_min[p, r.name] for r in capable[p]) for p in preds if p in head), default=0)
        tail = _run_out(mine, head, ancestors, capable, busy_min)
        counted = [t for t in mine if t.key in head and t.key in tail]
        robots = sorted({r.name for t in counted for r in capable[t.key]})  # a fixed order: constraints in the same order in every process
        for name in robots:
            work = [t for t in counted if (t.key, name) in assigned]
            lead = min(head[t.key] for t in work) + min(tail[t.key] for t in work)
            model.Add(sum(assigned[t.key, name] * busy_min[t.key, name] for t in work) <= gate - opening - lead)
            if len(counted) == len(mine):  # the window holds all of the floor's work: count its drives
                model.Add(travel.load(name, work) <= gate - opening - lead)
            if not below and first:
                _first_lead(model, name, work, head, tail, first, travel if len(counted) == len(mine) else None,
                            assigned, busy_min, gate)
        pairs: dict[tuple[str, ...], list[_Task]] = {}
        for t in counted:
            pairs.setdefault(tuple(r.name for r in capable[t.key]), []).append(t)
        for pair, work in pairs.items():
            if len(pair) == 2 and len(work) > 1:
                for run_out, part in _by_run_out(work, tail):
                    known = max(known, min(head[t.key] for t in part) + run_out + _two_robot_bound(part, pair, busy_min))
                if len(counted) == len(mine):  # the drives from the end of any other task: all of the work only
                    lead = min(head[t.key] for t in work) + min(tail[t.key] for t in work)
                    known = max(known, lead + travel.two_robot_bound(work, pair))
        heads, ready, drives_in = head, None, None
        if arrival and len(gates) == 1 and len(counted) == len(tasks):  # one floor, all of it from time 0
            heads = _robot_heads(mine, head, capable, busy_min, _ready(counted, head, capable, arrival))
            ready, drives_in = _ready(counted, heads, capable, arrival), arrival
        known = max(known, _staged_bound(pairs, heads, tail, busy_min, ready, drives_in), floor_least.get(floor, 0))
        if known:
            model.Add(gate - opening >= known)
        least += known
    return least


def _run_out(mine, head, ancestors, capable, busy_min) -> dict[str, int]:
    """Task -> the shortest chain of work after it (ticks) up to the floor's gate, for the floor's tasks
    ``mine`` that have a lead-in (``head``) and a task that closes the floor after them (one that closes
    it ends by the gate: 0)."""
    keys = {t.key for t in mine}
    tail = {t.key: 0 for t in mine if t.key in head and t.closes}
    successors: dict[str, list[str]] = {}
    for t in mine:
        for p in t.predecessors:
            if p in keys:
                successors.setdefault(p, []).append(t.key)
    for t in sorted(mine, key=lambda t: -bin(ancestors[t.key]).count("1")):  # successors first
        after = [u for u in successors.get(t.key, ()) if u in tail]
        if t.key in head and t.key not in tail and after:
            tail[t.key] = max(min(busy_min[u, r.name] for r in capable[u]) + tail[u] for u in after)
    return tail


def _by_run_out(work: list[_Task], tail: dict[str, int]):
    """(run-out, the tasks of ``work`` with at least that run-out after them) for each run-out among
    them (ticks), longest part first: a bound over a part ends no earlier than its least run-out, so a
    part without the tasks that may end last (e.g. parts without joints, which close the floor
    themselves) can bound more than all of the work (GEELEN: the positionings with a joint after them, and
    480 s of it, against all of them with none)."""
    for run_out in sorted({tail[t.key] for t in work}):
        part = [t for t in work if tail[t.key] >= run_out]
        if len(part) > 1:
            yield run_out, part


def _ready(counted, head, capable, arrival) -> dict[str, int]:
    """Robot -> the earliest end of its first task less that task's least busy time (ticks), where the
    problem is one floor from time 0: a robot cannot begin before its own drive in (``arrival``, on top of
    each task's lead-in ``head``), whichever task it takes first."""
    ready: dict[str, int] = {}
    for t in counted:
        for r in capable[t.key]:
            ready[r.name] = min(ready.get(r.name, 1 << 40), head[t.key] + arrival[t.key, r.name])
    return ready


def _robot_heads(mine, head, capable, busy_min, ready) -> dict[str, int]:
    """Each task's lead-in (ticks) where no robot can end a task before its own ``ready`` plus that
    task's least busy time: a predecessor p on robot r ends no earlier than max(lead-in of p, ready[r]) +
    its least busy time there, on the robot where that is least. ``mine`` in topological order."""
    later: dict[str, int] = {}
    for t in mine:
        if t.key in head:
            ends = [min(max(later[p], ready.get(r.name, 0)) + busy_min[p, r.name] for r in capable[p])
                    for p in t.predecessors if p in later]
            later[t.key] = max([head[t.key]] + ends)
    return later


def _first_lead(model, name, work, head, tail, first, travel, assigned, busy_min, gate) -> None:
    """On the lowest floor (from time 0): robot ``name`` departs for its first task t no earlier than
    t's own lead-in ``head[t]`` (ticks), then does all its work of the floor, one task after the other,
    before the floor's gate less the shortest run-out. Linear in the robot's first-task literals, which
    are all false where its first task is on another floor (then this is the plain window, weaker)."""
    starts = sum(first[name, t.key] * head[t.key] for t in work if (name, t.key) in first)
    load = travel.load(name, work) if travel else sum(assigned[t.key, name] * busy_min[t.key, name] for t in work)
    model.Add(starts + load <= gate - min(tail[t.key] for t in work))


def _fastest(costs: dict[str, list[int]], count: int, offset: dict[str, int] | None = None) -> int:
    """The least time (ticks) one or two robots need for ``count`` of their tasks, whichever: each robot
    takes the cheapest of its own ``costs`` (sorted ascending), for every split of the count; a robot that
    takes any begins ``offset`` ticks late (0 without)."""
    offset = offset or {}
    (name_a, a), *rest = costs.items()
    late_a = offset.get(name_a, 0)
    if not rest:
        return late_a + sum(a[:count]) if 0 < count <= len(a) else (0 if count == 0 else 1 << 40)
    name_b, b = rest[0]
    late_b = offset.get(name_b, 0)
    best = 1 << 40
    for on_a in range(max(0, count - len(b)), min(count, len(a)) + 1):
        on_b = count - on_a
        best = min(best, max(late_a + sum(a[:on_a]) if on_a else 0, late_b + sum(b[:on_b]) if on_b else 0))
    return best


def _staged_bound(groups: dict[tuple[str, ...], list[_Task]], head, tail, busy_min, ready=None, arrival=None) -> int:
    """A floor's least duration (ticks) from its two stages, e.g. positioning then assembly: every task
    of a later group J waits for some task of an earlier group P (one or two robots each). Before the k-th
    P task can end (E_k: the earliest, over splits of k between P's robots, from P's earliest start), at
    most the k-1 P tasks with the most J successors are done, so the rest of J, at least n - released
    tasks, starts after E_k and needs J's robots for at least their fastest split; then the run-out.
    ``ready`` (robot -> ticks; None: P's earliest start for all): each P robot's earliest end of its first
    task, less that task's least busy time (a robot that starts far from P's work ends its first P task
    later). ``arrival`` ((task, robot) -> ticks, with ``ready``): a J robot that does nothing but J and
    has not begun before E_k pays its first drive in on top; at most as many J tasks as were released
    before E_k can have begun, so with one released, one of the two J robots pays it. With one released,
    all of J is also split between a robot that begins at E_1 and one that begins at E_k (and pays its
    drive in). J is also taken as only its tasks with the longer run-outs after them (:func:`_by_run_out`)."""
    best = 0
    parts = [(robots, run_out, part) for robots, work in groups.items() if len(robots) <= 2
             for run_out, part in _by_run_out(work, tail)]
    for later_robots, run_out, later in parts:
        for earlier_robots, earlier in groups.items():
            if earlier_robots == later_robots or len(earlier_robots) > 2:
                continue
            keys = {t.key for t in earlier}
            feeds = {t.key: 0 for t in earlier}
            if not all(any(p in keys for p in t.predecessors) for t in later):
                continue
            for t in later:
                for p in t.predecessors:
                    if p in keys:
                        feeds[p] += 1
            released = sorted(feeds.values(), reverse=True)
            first = min(head[t.key] for t in earlier)
            cost_p = {r: sorted(busy_min[t.key, r] for t in earlier) for r in earlier_robots}
            cost_j = {r: sorted(busy_min[t.key, r] for t in later) for r in later_robots}
            offset = {r: max(0, (ready or {}).get(r, first) - first) for r in earlier_robots}
            others = {r for robots in groups if robots != later_robots for r in robots}
            solo = {r: min(arrival[t.key, r] for t in later) for r in later_robots if r not in others} if arrival else {}
            for k in range(1, len(earlier) + 1):
                begun = sum(released[:k - 1])
                left = len(later) - begun
                if left <= 0:
                    break
                ended = first + _fastest(cost_p, k, offset)  # E_k
                best = max(best, ended + _later(cost_j, left, solo, begun) + run_out)
                if begun == 1 and len(cost_j) == 2:  # one robot may begin at E_1, the other at E_k
                    opened = first + _fastest(cost_p, 1, offset)
                    best = max(best, opened + min(_fastest(cost_j, len(later), {r: ended - opened + solo.get(r, 0)})
                                                  for r in cost_j) + run_out)
    return best


def _later(cost_j: dict[str, list[int]], left: int, solo: dict[str, int], begun: int) -> int:
    """The least time (ticks) J's robots need for ``left`` tasks after E_k, where ``begun`` J tasks may
    have begun before: a robot of ``solo`` (it does only J work) that has not begun pays its first drive
    in (``solo``) on top; with none begun every such robot does, with one begun all but one of them."""
    if begun == 0:
        return _fastest(cost_j, left, solo)
    if begun == 1 and len(solo) == 2:
        return min(_fastest(cost_j, left, {r: ticks}) for r, ticks in solo.items())
    return _fastest(cost_j, left)


class _Visits:
    """A robot's drives, for the bound: tasks that begin and end at one point (positioning, assembly)
    share that point with others, so each one's shortest drive in is 0; but a robot that does work at n
    points drives into each of them at least once. ``load(robot, work)`` is the robot's handling of
    ``work`` plus, per point it visits, the shortest drive into that point from the end of any other of
    ``work``'s tasks, less the largest such drive (the first point may be where the robot already stands).
    Ticks (0.01 s)."""

    def __init__(self, model, assigned, handling, busy_min, drive):
        self.model, self.assigned, self.handling, self.busy_min, self.drive = model, assigned, handling, busy_min, drive
        self.visited = {}  # (robot, point) -> literal: the robot does some work there

    @staticmethod
    def _point(xy) -> tuple[int, int]:
        return tuple(int(round(float(c) * 100)) for c in np.asarray(xy, dtype=float)[:2])

    def two_robot_bound(self, work: list[_Task], pair: tuple[str, str]) -> int:
        """The least time (ticks) two robots need for ``work`` that only they can do, with their drives:
        min over splits of the larger load, a split choosing per point how many of its tasks each robot
        takes (the cheapest of them, for a bound), each robot paying the shortest drive into every point
        it works at, less its largest such drive (subset sums in ticks, or in coarser units rounded down
        where the floor is large)."""
        points, moving = self._points(work)
        if moving:
            return 0
        cost = {r: {here: sorted(self.handling[t.key, r] for t in ts) for here, ts in points.items()} for r in pair}
        near = {r: {here: self._nearest(r, here, ts, work) for here, ts in points.items()} for r in pair}
        a, b = pair
        terms = sum(len(ts) + 1 for ts in points.values())
        ticks = sum(sum(c) + near[a][here] for here, c in cost[a].items()) + 1
        unit = max(1, math.ceil(ticks * terms / 4e7))  # coarser than a tick on large floors; sums round down
        size = ticks // unit + 1
        never = np.iinfo(np.int64).max // 4
        best_b = np.full(size, never, dtype=np.int64)  # units on a -> least units on b
        best_b[0] = 0
        for here, ts in points.items():
            merged = np.full(size, never, dtype=np.int64)
            for on_a in range(len(ts) + 1):
                on_b = len(ts) - on_a
                add_a = (sum(cost[a][here][:on_a]) + (near[a][here] if on_a else 0)) // unit
                add_b = (sum(cost[b][here][:on_b]) + (near[b][here] if on_b else 0)) // unit
                shifted = np.full(size, never, dtype=np.int64)
                shifted[add_a:] = best_b[:size - add_a] if add_a else best_b
                merged = np.minimum(merged, shifted + add_b)
            best_b = merged
        slack_a, slack_b = -(-max(near[a].values()) // unit), -(-max(near[b].values()) // unit)
        loads = np.maximum(np.arange(size) - slack_a, best_b - slack_b)
        return max(0, int(loads.min()) * unit)

    def _nearest(self, name: str, here, ts: list[_Task], work: list[_Task]) -> int:
        return min((self.drive(u.request.end, ts[0].request.start, name) for u in work
                    if self._point(u.request.end) != here), default=0)

    def _points(self, work: list[_Task]):
        points: dict[tuple[int, int], list[_Task]] = {}
        moving = []  # tasks that end elsewhere than they begin: their own shortest drive in stands
        for t in work:
            here = self._point(t.request.start)
            (points.setdefault(here, []) if here == self._point(t.request.end) else moving).append(t)
        return points, moving

    def load(self, name: str, work: list[_Task]):
        points: dict[tuple[int, int], list[_Task]] = {}
        moving = []  # tasks that end elsewhere than they begin: their own shortest drive in stands
        for t in work:
            here = self._point(t.request.start)
            (points.setdefault(here, []) if here == self._point(t.request.end) else moving).append(t)
        nearest = {}
        for here, ts in points.items():
            gaps = [self.drive(u.request.end, ts[0].request.start, name) for u in work if self._point(u.request.end) != here]
            nearest[here] = min(gaps, default=0)
        terms = [self.assigned[t.key, name] * self.handling[t.key, name] for ts in points.values() for t in ts]
        for here, ts in points.items():
            key = (name, here, tuple(sorted(t.key for t in ts)))
            if key not in self.visited:
                self.visited[key] = lit = self.model.NewBoolVar(f"visits[{name},{here}]")
                for t in ts:
                    self.model.AddImplication(self.assigned[t.key, name], lit)
            terms.append(self.visited[key] * nearest[here])
        return sum(terms) - max(nearest.values(), default=0) + sum(
            self.assigned[t.key, name] * self.busy_min[t.key, name] for t in moving)


def _two_robot_bound(work: list[_Task], pair: tuple[str, str], busy_min) -> int:
    """The least time (ticks) two robots need for ``work`` that only they can do, each task on one of
    them with its least busy time there: min over splits of the larger load (subset sums, in whole
    seconds rounded down, so never above the true least). The relaxation splits tasks in fractions;
    this cut keeps each task whole."""
    a, b = pair
    cost_a = [busy_min[t.key, a] // SCALE for t in work]
    cost_b = [busy_min[t.key, b] // SCALE for t in work]
    size = sum(cost_a) + 1
    if size * len(work) > 5e7:
        return 0  # too large to enumerate; the linear loads still hold
    best_b = np.full(size, np.iinfo(np.int64).max // 4, dtype=np.int64)  # load on a -> least load on b
    best_b[0] = 0
    for ca, cb in zip(cost_a, cost_b):
        on_b = best_b + cb
        on_a = np.full(size, np.iinfo(np.int64).max // 4, dtype=np.int64)
        on_a[ca:] = best_b[:size - ca] if ca else best_b
        best_b = np.minimum(on_a, on_b)
    loads = np.maximum(np.arange(size), best_b)
    return int(loads.min()) * SCALE
