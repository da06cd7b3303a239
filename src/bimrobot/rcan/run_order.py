"""Simulated-time order in an RCAN run: results handled, and the interaction log printed, in the order of
the robots' simulated times (seconds) rather than of the executor threads' real finishing times.

:class:`SimulatedOrder` is a part of :class:`~bimrobot.rcan.system.RcanSystem` (it reads the run's nodes
in flight, held results and send times).
"""

from __future__ import annotations

import heapq
import math
from typing import Callable

from bimrobot.rcan.broker import RESULT_TOPIC, Message


class OrderedLog:
    """The interaction log, printed in the same order every run: robots working at once report in the
    order their threads finish, so lines are held and printed by simulated time (s), then plan order, then
    stage (published, sent, result), then the order they were made in; a line is printed once
    no node in flight can come before it (:meth:`RcanSystem._flush_log`)."""

    def __init__(self, out: Callable[[str], None]):
        self.out, self.at, self._held, self._count = out, (0.0, 0, -1), [], 0

    def __call__(self, line: str) -> None:
        self._count += 1
        heapq.heappush(self._held, (*self.at, self._count, line))

    def flush(self, until_s: float) -> None:
        """Print, in order, every held line about a time before ``until_s`` (inf: all)."""
        while self._held and (self._held[0][0] < until_s or until_s == math.inf):
            self.out(heapq.heappop(self._held)[-1])


class SimulatedOrder:
    """The simulated-time ordering of :class:`~bimrobot.rcan.system.RcanSystem`.

    Executor threads report in whatever order they finish in real time. With a backend that reports
    simulated times, a result is handled only when no robot still working can finish before it in
    simulated time, and results of one simulated time in plan order: which robot gets the next
    activity, and the component states, then follow simulated time, never thread timing.
    """

    def _in_simulated_order(self, messages: list[Message]) -> list[Message]:
        """``messages`` to handle in this turn: everything but results at once; with simulated time,
        results are held and only those of the earliest simulated finish that is safe come out."""
        if not self.simulated_time:
            return messages
        now = []
        for message in messages:
            result = message.payload.get("result", {}) if message.topic == RESULT_TOPIC else {}
            flight = self._in_flight.get(result.get("robot"))
            if not result or flight is None or flight[0].activity_id != result.get("activity_id"):
                now.append(message)  # not a result, or a duplicate: handled (or dropped) at once
                continue
            order = self._order.get(result["activity_id"], -1)
            self._held_count += 1  # a tie-breaker that never compares two messages
            heapq.heappush(self._pending, (float(result.get("finished_s") or 0.0), order, self._held_count, message))
        if self._releasable():
            finish = self._pending[0][0]
            while self._pending and self._pending[0][0] == finish:
                now.append(heapq.heappop(self._pending)[3])
        return now

    def _releasable(self) -> bool:
        """Whether the earliest held result (simulated finish f, s) is final: every robot in flight
        whose result has not come was sent at a simulated time after f, so it finishes after f."""
        if not self._pending:
            return False
        finish = self._pending[0][0]
        reported = {m.payload["result"]["robot"] for _, _, _, m in self._pending}
        return all(self._sent_s.get(robot, 0.0) > finish for robot in self._in_flight if robot not in reported)

    @property
    def simulated_time(self) -> bool:
        """The backend reports simulated times: its results are handled in simulated-time order (see
        ``_releasable``) and the log is printed in that order (:class:`OrderedLog`). A backend on real
        clocks (ros2) keeps a live log: each line is printed when it happens."""
        return self._simulated_time

    @simulated_time.setter
    def simulated_time(self, value: bool) -> None:
        self._simulated_time = value
        if self._given_log is not None:
            self.log = OrderedLog(self._given_log) if value else self._given_log

    def _log_at(self, at_s: float, phase: int, activity_id: str) -> None:
        """The simulated time (s) the next log lines are about and their stage: an activity's publishing
        (0) when it is ready, its dispatch (1) when it is ready and its robot free, its result (2) at its finish."""
        if isinstance(self.log, OrderedLog):
            self.log.at = (at_s, self._order.get(activity_id, -1), phase)

    def _flush_log(self, everything: bool = False) -> None:
        """Print the held log lines that no node in flight can precede: those before the earliest
        simulated time a node in flight was sent at (every line if ``everything``)."""
        if isinstance(self.log, OrderedLog):
            until = math.inf if everything or not self._in_flight else min(self._sent_s.get(r, 0.0) for r in self._in_flight)
            self.log.flush(until)
