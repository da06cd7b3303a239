"""The state manager (thesis 5.2.1): robot results -> component states, retries, escalation, journal.

Success advances the component's state machine (:mod:`bimrobot.sco.states`) and notifies observers (the
construction graph of :mod:`bimrobot.lbd` is one: any object with ``set_component_state(global_id,
state)`` and/or ``set_activity_state(activity_id, state)``). A failure is retried up to
``RetryPolicy.max_attempts`` times, then escalated with an :class:`EscalationReport` naming component,
activity and robot, for a technician (the thesis' warning).

Everything is journaled in SQLite (:class:`StateStore`): a ``started`` record before an activity is sent
to its robot and a ``done``/``failed``/``escalated`` record with the component's new state in the same
transaction when its result arrives. A run killed at any moment resumes from the journal: done
activities are not sent again, started-but-unfinished ones are re-sent with the same (activity id,
attempt) so an idempotent robot returns the result it already has instead of working twice. The
database file itself (opening, marking, locking, removal) is :mod:`bimrobot.rcan.state_db`; its names
are importable from here too.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sqlite3
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator

from bimrobot.core.errors import InputError
from bimrobot.rcan.activities import ActivityKind
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.node import RcanNode
from bimrobot.rcan.state_db import SCHEMA, _alive, _process_start, check_plan, connect_state_db, write_lock
from bimrobot.sco.states import Event, State, at_least, next_state

log = logging.getLogger(__name__)

PENDING, STARTED, DONE, ESCALATED = "pending", "started", "done", "escalated"


@dataclass(frozen=True)
class RetryPolicy:
    """Retry a failed activity until ``max_attempts`` attempts were made, then escalate."""

    max_attempts: int = 3


@dataclass(frozen=True)
class EscalationReport:
    """What a technician needs after the retries ran out."""

    component_id: str
    activity_id: str
    activity: str
    robot: str
    attempts: int
    message: str

    def __str__(self) -> str:
        return (
            f"ESCALATED: {self.activity} of component {self.component_id} (activity {self.activity_id}) "
            f"failed {self.attempts} time(s) on robot {self.robot}: {self.message}"
        )


#: The component's path through the thesis' state chart, as (event, state after it).
FORWARD_PATH: tuple[tuple[Event, State], ...] = (
    (Event.START_TRANSPORT, State.IN_TRANSIT),
    (Event.FINISH_TRANSPORT, State.ARRIVED),
    (Event.PUBLISH_POSITIONING, State.IN_LOCATION),
    (Event.START_POSITIONING, State.WORKING_IN_POSITIONING),
    (Event.FINISH_POSITIONING, State.POSITION_FIXED),
    (Event.PUBLISH_ASSEMBLY, State.WAIT_FOR_ASSEMBLY),
    (Event.START_ASSEMBLY, State.WORKING_IN_ASSEMBLY),
)


def _walk(state: State, target: State) -> list[Event]:
    """Events that take ``state`` forward to ``target`` along the chart (none when already there or past).

    A component that skips a task in the plan (a footing already in place is never transported; a column
    within reach is never driven) passes through the skipped states, so the chart stays valid.
    """
    if at_least(state, target):
        return []
    events = []
    for event, after in FORWARD_PATH:
        if at_least(state, after):
            continue
        events.append(event)
        if after is target:
            break
    return events


class StateStore:
    """The SQLite journal and the current activity and component states (``:memory:`` by default).

    The file is a bimrobot state database (:func:`connect_state_db`); another program's SQLite file
    is refused. With ``plan`` (a plan signature), a database that records another plan is refused
    before anything is written to it (:func:`check_plan`).
    """

    def __init__(self, path: str | Path = ":memory:", plan: str | None = None):
        self.path = str(path)
        if plan is not None:
            check_plan(self.path, plan)
        self.db = connect_state_db(self.path, schema=SCHEMA)
        self.write_lock = write_lock(self.path)
        self._owner: str | None = None
        self._batch: list | None = None  # in a batch: what runs once it is committed (see batch())
        self._batch_begun = False

    def lock(self, option: str = "--state-db") -> None:
        """Make this run the only one on the database: the owner (pid and process start time) is
        recorded in the database, in a transaction, so two runs cannot both take it. A lock whose
        process has died (a killed run) is taken over; a live owner gets an InputError naming its pid."""
        if self.path == ":memory:" or self._owner:
            return
        me = f"{os.getpid()} {_process_start(os.getpid())} {id(self)}"
        with self.transaction() as db:
            row = db.execute("SELECT value FROM meta WHERE key='owner'").fetchone()
            if row:
                pid, started = (row[0].split() + ["", ""])[:2]
                if pid.isdigit() and _alive(int(pid), started):
                    raise InputError(f"{option} {self.path} is in use by another RCAN run (process {pid}); "
                                     "wait for it to end or give another --state-db")
                log.info("%s: taking over the lock of process %s, which has ended", self.path, pid)
            db.execute("INSERT OR REPLACE INTO meta VALUES ('owner', ?)", (me,))
        self._owner = me

    def unlock(self) -> None:
        """Give the database up (the next run takes it without a word)."""
        if self._owner:
            self.db.execute("DELETE FROM meta WHERE key='owner' AND value=?", (self._owner,))
            self._owner = None

    def transaction(self):
        """A transaction; inside :meth:`batch`, a savepoint of the batch's transaction."""
        return _Transaction(self)

    @contextlib.contextmanager
    def batch(self) -> Iterator[None]:
        """Commit every transaction made inside as one (group commit): one disk sync per turn of the
        coordinator's loop instead of one per activity started and per result. Nothing a turn sends
        leaves before its batch is committed (the broker sends posted messages with its next receive),
        so a crash loses the turn as a whole, as if its messages had never been received."""
        if self._batch is not None:  # nested: part of the outer batch
            yield
            return
        self._batch, self._batch_begun = [], False
        try:
            yield
        except BaseException:
            if self._batch_begun:
                try:
                    self.db.execute("ROLLBACK")
                finally:
                    self.write_lock.release()
            raise
        else:
            if self._batch_begun:
                try:
                    self.db.execute("COMMIT")
                finally:
                    self.write_lock.release()
            for action in self._batch:
                action()
        finally:
            self._batch, self._batch_begun = None, False

    def after_commit(self, action) -> None:
        """Run ``action()`` once what was written so far is committed (at once outside a batch)."""
        if self._batch is None:
            action()
        else:
            self._batch.append(action)

    def meta(self, key: str) -> str | None:
        row = self.db.execute("SELECT value FROM meta WHERE key=?", (key,)).fetchone()
        return row[0] if row else None

    def set_meta(self, key: str, value: str) -> None:
        self.db.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)", (key, value))

    def register(self, activities: Iterable[tuple[str, str, str]], components: Iterable[str]) -> None:
        """Add (activity id, component id, kind) rows and components (OnYard) not yet known."""
        with self.transaction() as db:
            db.executemany("INSERT OR IGNORE INTO activity (activity_id, component_id, kind, status) VALUES (?, ?, ?, 'pending')",
                           [(a, c, k) for a, c, k in activities])
            db.executemany("INSERT OR IGNORE INTO component VALUES (?, ?)", [(g, State.ON_YARD.value) for g in components])

    def reopen_escalated(self) -> list[str]:
        """Make escalated activities pending again (a technician fixed the cause), each with a fresh
        retry budget; attempt numbers go on counting, so every attempt keeps its own id. Returns their ids."""
        with self.transaction() as db:
            ids = [r[0] for r in db.execute("SELECT activity_id FROM activity WHERE status='escalated' ORDER BY activity_id")]
            db.execute("UPDATE activity SET status='pending', attempt_base=attempts WHERE status='escalated'")
            db.executemany("INSERT INTO journal (activity_id, event, attempt, wall_time) "
                           "SELECT activity_id, 'reopened', attempts, ? FROM activity WHERE activity_id=?",
                           [(time.time(), i) for i in ids])
        return ids

    def activity_rows(self) -> dict[str, dict]:
        rows = self.db.execute("SELECT activity_id, component_id, kind, status, attempts, robot, started_s, finished_s, "
                               "message FROM activity")
        keys = ("activity_id", "component_id", "kind", "status", "attempts", "robot", "started_s", "finished_s", "message")
        return {r[0]: dict(zip(keys, r)) for r in rows}

    def component_state(self, global_id: str) -> str | None:
        """The current state of one component (None before it is registered)."""
        row = self.db.execute("SELECT state FROM component WHERE global_id=?", (global_id,)).fetchone()
        return row[0] if row else None

    def component_states(self) -> dict[str, str]:
        return dict(self.db.execute("SELECT global_id, state FROM component ORDER BY global_id"))

    def journal(self) -> list[tuple[str, str, int, str | None]]:
        """(activity id, event, attempt, robot) in order."""
        return list(self.db.execute("SELECT activity_id, event, attempt, robot FROM journal ORDER BY seq"))

    def close(self) -> None:
        with contextlib.suppress(sqlite3.Error):
            self.unlock()
        self.db.close()


class _Transaction:
    """``BEGIN IMMEDIATE`` ... ``COMMIT`` (``ROLLBACK`` on an exception); in a batch, a savepoint: the
    batch's transaction begins with its first write and commits at the batch's end."""

    def __init__(self, store: StateStore):
        self.store, self.db = store, store.db

    def __enter__(self) -> sqlite3.Connection:
        store = self.store
        if store._batch is None or not store._batch_begun:
            store.write_lock.acquire()
            try:
                self.db.execute("BEGIN IMMEDIATE")
            except BaseException:
                store.write_lock.release()
                raise
        if store._batch is not None:
            store._batch_begun = True
            self.db.execute("SAVEPOINT step")
        return self.db

    def __exit__(self, exc_type, exc, tb) -> None:
        if self.store._batch is None:
            try:
                self.db.execute("COMMIT" if exc_type is None else "ROLLBACK")
            finally:
                self.store.write_lock.release()
        else:
            if exc_type is not None:
                self.db.execute("ROLLBACK TO step")
            self.db.execute("RELEASE step")


@dataclass(frozen=True)
class Decision:
    """The state manager's verdict on a result: ``done``, ``retry`` (with the next attempt) or ``escalated``."""

    verdict: str
    component_state: str
    next_attempt: int = 0
    report: EscalationReport | None = None


class StateManager:
    """Turns robot results into component states; retries, escalates, journals and notifies observers.

    ``installs``: component -> ids of its install activities; the component becomes Assembled when the
    last of them is done (a component with several connection nodes stays WorkingInAssembly until then).
    """

    def __init__(self, store: StateStore, policy: RetryPolicy = RetryPolicy(), observers: Iterable = (),
                 installs: dict[str, set[str]] | None = None):
        self.store = store
        self.policy = policy
        self.observers = list(observers)
        self.installs = dict(installs or {})

    # --- state machine -----------------------------------------------------------------------------
    def _component_state(self, db, component_id: str) -> State:
        row = db.execute("SELECT state FROM component WHERE global_id=?", (component_id,)).fetchone()
        return State(row[0]) if row else State.ON_YARD

    def _events_on_start(self, kind: ActivityKind, state: State) -> list[Event]:
        if kind is ActivityKind.POSITION_FOR_INSTALLING:
            return _walk(state, State.WORKING_IN_POSITIONING)
        if kind is ActivityKind.INSTALL:
            return _walk(state, State.WORKING_IN_ASSEMBLY)
        return []

    def _events_on_done(self, kind: ActivityKind, state: State) -> list[Event]:
        targets = {ActivityKind.PICK_UP: State.IN_TRANSIT, ActivityKind.TRANSPORT: State.ARRIVED,
                   ActivityKind.POSITION_FOR_INSTALLING: State.POSITION_FIXED}
        if kind in targets:
            return _walk(state, targets[kind])
        if kind is ActivityKind.INSTALL:
            return _walk(state, State.WORKING_IN_ASSEMBLY) + [Event.FINISH_ASSEMBLY]
        return []

    def _advance(self, db, node: RcanNode, events: list[Event], state: State) -> State:
        """Apply ``events`` to the component, now in ``state``; written only when something happens."""
        for event in events:
            state = next_state("component", node.component_id, state, event)
        if Event.FINISH_ASSEMBLY in events and self._all_installed(db, node):
            state = State.ASSEMBLED  # guarded transition: the component's last connection is fixed
        if events:
            db.execute("INSERT OR REPLACE INTO component VALUES (?, ?)", (node.component_id, state.value))
        return state

    def _all_installed(self, db, node: RcanNode) -> bool:
        others = self.installs.get(node.component_id, {node.activity_id}) - {node.activity_id}
        if not others:
            return True
        marks = ",".join("?" * len(others))
        done = db.execute(f"SELECT COUNT(*) FROM activity WHERE status='done' AND activity_id IN ({marks})",
                          tuple(others)).fetchone()[0]
        return done == len(others)

    #: the activity's status, attempts and retry base, and its component's state, in one query
    _ROW = ("SELECT a.status, a.attempts, a.attempt_base, c.state FROM activity a "
            "LEFT JOIN component c ON c.global_id = a.component_id WHERE a.activity_id=?")

    def _row(self, db, node: RcanNode) -> tuple[str | None, int, int, State]:
        row = db.execute(self._ROW, (node.activity_id,)).fetchone()
        if row is None:  # an activity the store does not know (a node run outside a plan)
            return None, 0, 0, self._component_state(db, node.component_id)
        return row[0], row[1], row[2], State(row[3]) if row[3] else State.ON_YARD

    # --- journal -----------------------------------------------------------------------------------
    def started(self, node: RcanNode, attempt: int) -> State:
        """Record that ``node`` is being sent to its robot (attempt ``attempt``); returns the component state."""
        return self.start(node, attempt)[1]

    def start(self, node: RcanNode, attempt: int) -> tuple[State, State]:
        """As :meth:`started`; returns the component's state before and after."""
        with self.store.transaction() as db:
            status, attempts, _, before = self._row(db, node)
            if status == STARTED and attempts == attempt:
                return before, before  # re-sent after a resume
            state = self._advance(db, node, self._events_on_start(node.kind, before), before)
            db.execute("INSERT INTO journal (activity_id, event, attempt, robot, wall_time) VALUES (?, 'started', ?, ?, ?)",
                       (node.activity_id, attempt, node.robot, time.time()))
            db.execute("UPDATE activity SET status='started', attempts=?, robot=? WHERE activity_id=?",
                       (attempt, node.robot, node.activity_id))
        self._notify(node, state, STARTED)
        return before, state

    def result(self, node: RcanNode, result: ActivityResult, escalate: bool = False) -> Decision:
        """Handle a robot's result: advance on success, retry or escalate on failure (``escalate``: a
        failure that no retry can mend, e.g. a node the broker gave up delivering)."""
        with self.store.transaction() as db:
            status, attempts, base, state = self._row(db, node)
            if status is not None and (status != STARTED or attempts != result.attempt):
                return Decision("duplicate", state.value)
            if result.success:
                state = self._advance(db, node, self._events_on_done(node.kind, state), state)
                self._journal(db, node, result, "done")
                db.execute("UPDATE activity SET status='done', started_s=?, finished_s=?, message=? WHERE activity_id=?",
                           (result.started_s, result.finished_s, result.message, node.activity_id))
                decision = Decision(DONE, state.value)
            elif not escalate and result.attempt - base < self.policy.max_attempts:
                self._journal(db, node, result, "failed")
                db.execute("UPDATE activity SET status='pending', message=? WHERE activity_id=?",
                           (result.message, node.activity_id))
                decision = Decision("retry", state.value, result.attempt + 1)
            else:
                if state is State.WORKING_IN_POSITIONING:
                    state = self._advance(db, node, [Event.ABORT], state)
                self._journal(db, node, result, "escalated")
                db.execute("UPDATE activity SET status='escalated', message=? WHERE activity_id=?",
                           (result.message, node.activity_id))
                report = EscalationReport(node.component_id, node.activity_id, node.kind.label, node.robot,
                                          result.attempt - base, result.message)
                log.warning("%s", report)
                decision = Decision(ESCALATED, state.value, report=report)
        self._notify(node, State(decision.component_state), decision.verdict)
        return decision

    def _journal(self, db, node: RcanNode, result: ActivityResult, event: str) -> None:
        db.execute(
            "INSERT INTO journal (activity_id, event, attempt, robot, message, finished_s, wall_time) VALUES (?, ?, ?, ?, ?, ?, ?)",
            (node.activity_id, event, result.attempt, result.robot, result.message, result.finished_s, time.time()),
        )

    def _notify(self, node: RcanNode, state: State, activity_state: str) -> None:
        """Tell the observers, once the change is committed (a graph never shows what a crash undid)."""
        if self.observers:
            self.store.after_commit(lambda: self._tell(node, state, activity_state))

    def _tell(self, node: RcanNode, state: State, activity_state: str) -> None:
        for observer in self.observers:  # the activity's outcome first, then the state it led to
            if hasattr(observer, "set_activity_state"):
                observer.set_activity_state(node.activity_id, activity_state)
            if hasattr(observer, "set_component_state"):
                observer.set_component_state(node.component_id, state.value)
