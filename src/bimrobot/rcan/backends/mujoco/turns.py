"""Turns of the ``mujoco`` backend: which queued activity acts next in the one physical world.

When the coordinator runs in this process it reports after each of its turns; the next activity is
chosen only once it has handled every result and every node it has sent has arrived, and it is the
one ready first in simulated time (ties: activity id, then attempt). An activity whose way is blocked
gives up its turn and is tried again after another one has finished (see the package docstring).
"""

from __future__ import annotations

import threading
from contextlib import contextmanager

BLOCKED_WAITS = 20  # a robot that finds its way blocked waits for up to this many other activities ...
BLOCKED_WAIT_S = 120.0  # ... each within this many real seconds, before its activity fails
IDLE_WAIT_S = 3.0  # when every activity under way is waiting so, a new one may still be dispatched within
    # this many real seconds (the coordinator reacts to the last result); if none is, nothing can clear the
    # way and the activity fails at once instead of waiting out BLOCKED_WAIT_S


class _Ticket:
    """An activity queued for its turn: ``key`` (ready time s, activity id, attempt) orders turns;
    ``blocked_at``: :attr:`_Turns.finished` when its way was last found blocked; ``tries``: how often;
    ``blocked``: why, the last time."""

    def __init__(self, key: tuple[float, str, int]):
        self.key = key
        self.blocked_at: int | None = None
        self.tries = 0
        self.blocked = ""


class _Turns:
    """Which queued activity acts next in the one physical world (module docstring, Turns)."""

    def __init__(self):
        self._condition = threading.Condition()
        self.coordinated = False  # a coordinator in this process reports when it has settled
        self._handled = 0  # results the coordinator has handled
        self._in_flight: int | None = None  # nodes it waits for (None: it has not reported yet)
        self.finished = 0  # activities finished here, their results given back: what a blocked one waits for
        self._queued: list[_Ticket] = []
        self._acting: _Ticket | None = None
        self._stopped = False

    def attach(self) -> None:
        with self._condition:
            self.coordinated = True

    def settled(self, handled: int, in_flight: int) -> None:
        with self._condition:
            self._handled, self._in_flight = handled, in_flight
            self._condition.notify_all()

    def stop(self) -> None:
        with self._condition:
            self._stopped = True
            self._condition.notify_all()

    @contextmanager
    def queued(self, key: tuple[float, str, int]):
        """Queue an activity for the time it is executed (its result given back at the end)."""
        ticket = _Ticket(key)
        with self._condition:
            self._queued.append(ticket)
            self._condition.notify_all()
        try:
            yield ticket
        finally:
            with self._condition:
                self._queued.remove(ticket)
                self.finished += 1
                self._condition.notify_all()

    def wait_for_turn(self, ticket: _Ticket, max_tries: int) -> bool:
        """Wait until ``ticket`` acts; whether it should give up instead: it was blocked ``max_tries``
        times, or its turn came although nothing finished since it was blocked (nothing can change)."""
        with self._condition:
            self._condition.wait_for(lambda: self._stopped or self._next() is ticket)
            if self._stopped:
                raise RuntimeError("the run is ending; the activity was not executed")
            self._acting = ticket
            return ticket.tries >= max_tries or ticket.blocked_at == self.finished

    def end_turn(self, ticket: _Ticket, blocked: str | None) -> None:
        """``ticket``'s turn is over; ``blocked``: why its way was blocked, or None (it is finished)."""
        with self._condition:
            self._acting = None
            if blocked is not None:
                ticket.blocked_at, ticket.tries, ticket.blocked = self.finished, ticket.tries + 1, blocked
            self._condition.notify_all()

    def _next(self) -> _Ticket | None:
        """The ticket whose turn it is, or None while one acts or the coordinator has not settled (a
        result not yet handled, a node sent that has not arrived). The earliest of those not blocked
        since the last activity finished; when all are, the earliest of all (to give up)."""
        if self._acting is not None or not self._queued or self._in_flight is None:
            return None
        if self._handled < self.finished or len(self._queued) < self._in_flight:
            return None
        free = [t for t in self._queued if t.blocked_at is None or t.blocked_at < self.finished]
        return min(free or self._queued, key=lambda t: t.key)
