"""Waiting activities of an RCAN run and the robots that take them (:class:`WaitingActivities`, a part of
:class:`~bimrobot.rcan.system.RcanSystem`).
"""

from __future__ import annotations

import heapq

from bimrobot.core.errors import InputError
from bimrobot.rcan.activities import RcanActivity


class WaitingActivities:
    """Which waiting activity goes to which robot in :class:`~bimrobot.rcan.system.RcanSystem`.

    An activity waits either for the robot committed to its component (``_held``, by component) or,
    when no robot is committed, for any idle capable robot (``_open``: one heap per set of capable
    robots, in plan order). A robot is idle when it neither works nor is committed to a component.
    Each dispatch looks only at what can have changed, so dispatching is linear in the activities.
    """

    def _enqueue(self, activity_id: str, attempt: int) -> None:
        activity = self._plan[activity_id]
        entry = (self._order[activity_id], activity_id, attempt)
        if self.allocator.holder(activity.component_id) is not None:
            self._held.setdefault(activity.component_id, []).append(entry)
            self._recheck.add(activity.component_id)
        else:
            heapq.heappush(self._open_heap(activity), entry)

    def _open_heap(self, activity: RcanActivity) -> list:
        key = self.allocator.requirement(activity)
        assigned = self.allocator.assigned(activity)
        if assigned in self._down:  # the schedule's robot died in this run: any capable robot takes it
            assigned = None
        if assigned is not None:  # the schedule's robot only: the activity waits for it
            key = (key, assigned)
        if key not in self._groups:
            capable = frozenset(r.name for r in self.allocator.capable(activity))
            if assigned is not None:
                if assigned not in capable:
                    raise InputError(f"the schedule assigns '{activity.kind.label}' of component {activity.component_id} "
                                     f"(activity {activity.activity_id}) to robot {assigned}, which cannot take it in "
                                     f"{self.allocator.capabilities.source} (type, payload or gripper)")
                capable = frozenset({assigned})
            self._groups[key] = (capable, [])
        return self._groups[key][1]

    def _released(self, component_id: str) -> None:
        """The robot committed to ``component_id`` lets go: it is idle again unless it works or holds
        another component, and the component's waiting activities may go to any capable robot."""
        robot = self.allocator.release(component_id)
        if robot is not None and robot not in self._in_flight and not self.allocator.is_committed(robot):
            self._set_idle(robot)
        for entry in self._held.pop(component_id, ()):
            heapq.heappush(self._open_heap(self._plan[entry[1]]), entry)

    def _dispatch_waiting(self) -> None:
        """Instantiate RCAN nodes for waiting activities whose robot is free, and send them."""
        for component in self._recheck:  # activities waiting for their component's committed robot
            holder = self.allocator.holder(component)
            entries = self._held.get(component)
            if not entries or holder is None or holder in self._in_flight:
                continue
            for n, (_, activity_id, attempt) in enumerate(entries):
                if self.allocator.continues(self._plan[activity_id]):
                    del entries[n]
                    self._instantiate(self._plan[activity_id], attempt, holder)
                    break
        self._recheck.clear()
        everyone = len(self._robot_order)
        while self._idle:  # activities no robot is committed to, oldest first, to idle capable robots
            best = None
            for capable, heap in self._groups.values():
                if heap and (best is None or heap[0] < best[1][0]) and (
                        len(capable) == everyone or not self._idle.isdisjoint(capable)):
                    best = (capable, heap)
            if best is None:
                return
            capable, heap = best
            entry = heapq.heappop(heap)
            activity = self._plan[entry[1]]
            if self.allocator.holder(activity.component_id) is not None:  # a robot took its component meanwhile
                self._held.setdefault(activity.component_id, []).append(entry)
                continue
            named = activity.robot
            robot = named if named in self._idle and named in capable else self._least_loaded_idle(capable)
            self._instantiate(activity, entry[2], robot)

    def _set_idle(self, robot: str) -> None:
        if robot not in self._idle and robot not in self._down:
            self._idle.add(robot)
            heapq.heappush(self._idle_heap, (self.allocator.load(robot), self._robot_order[robot], robot))

    def _least_loaded_idle(self, capable: frozenset) -> str:
        """The idle robot of ``capable`` that took the fewest activities (ties: file order), from a heap
        of idle robots, so choosing among 20,000 robots does not scan them all."""
        aside, robot = [], None
        while robot is None:
            entry = heapq.heappop(self._idle_heap)
            load, _, name = entry
            if name not in self._idle or load != self.allocator.load(name):
                continue  # stale: the robot took work since
            if name in capable:
                robot = name
            aside.append(entry)
        for entry in aside:
            heapq.heappush(self._idle_heap, entry)
        return robot
