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
attempt) so an idempotent robot returns the result it already has instead of working twice.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sqlite3
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator
from urllib.parse import quote

from bimrobot.core.errors import InputError
from bimrobot.rcan.activities import ActivityKind
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.node import RcanNode
from bimrobot.sco.states import Event, State, at_least, next_state

log = logging.getLogger(__name__)

PENDING, STARTED, DONE, ESCALATED = "pending", "started", "done", "escalated"

#: ``PRAGMA application_id`` of every SQLite database bimrobot writes (the bytes ``BIMR``): how a later
#: run tells its own state database from somebody else's SQLite file (SQLite header, offset 68).
APPLICATION_ID = int.from_bytes(b"BIMR", "big")

_SQLITE_MAGIC = b"SQLite format 3\x00"

SCHEMA = """
CREATE TABLE IF NOT EXISTS journal (
    seq INTEGER PRIMARY KEY AUTOINCREMENT, activity_id TEXT NOT NULL, event TEXT NOT NULL,
    attempt INTEGER NOT NULL, robot TEXT, message TEXT, finished_s REAL, wall_time REAL);
CREATE TABLE IF NOT EXISTS activity (
    activity_id TEXT PRIMARY KEY, component_id TEXT, kind TEXT, status TEXT NOT NULL,
    attempts INTEGER NOT NULL DEFAULT 0, robot TEXT, finished_s REAL, message TEXT,
    attempt_base INTEGER NOT NULL DEFAULT 0, started_s REAL);
CREATE TABLE IF NOT EXISTS component (global_id TEXT PRIMARY KEY, state TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT);
"""

#: Columns added to RCAN's tables after databases without them were written: table -> (column, SQL
#: type), last in the table's schema. A database that lacks them is RCAN's all the same; it gets them
#: (NULL in the rows already there: unknown) when it is opened. ``activity.started_s``: the robot
#: time (s) at which a done activity started, on the clock of its ``finished_s``.
ADDED_COLUMNS = {"activity": (("started_s", "REAL"),)}


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


def is_state_db(path: str | os.PathLike) -> bool:
    """Whether ``path`` is an SQLite database bimrobot wrote: its header (the first 100 bytes) starts
    with the SQLite magic and holds :data:`APPLICATION_ID` at offset 68. The output policy's recogniser
    for ``--state-db``."""
    try:
        with open(path, "rb") as stream:
            header = stream.read(100)
    except OSError:
        return False
    return header.startswith(_SQLITE_MAGIC) and int.from_bytes(header[68:72], "big") == APPLICATION_ID


#: Every table an RCAN state database may hold (the journal's, and the sim backend's world).
RCAN_TABLES = frozenset({"journal", "activity", "component", "meta", "sqlite_sequence",
                         "sim_robot", "sim_component", "sim_execution", "sim_work_point"})


def _check_tables(db: sqlite3.Connection, name: str, schema: str | None, option: str) -> None:
    """Refuse (InputError, nothing written) a database holding tables RCAN does not write, or one of
    RCAN's tables with other columns than ``schema`` gives it."""
    tables = [r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type='table'")]
    foreign = [t for t in tables if t not in RCAN_TABLES]
    if foreign:
        raise InputError(f"{option} {name} is not an RCAN state database (it has a table {foreign[0]!r} RCAN does "
                         "not write); give a new file name (nothing was changed)")
    if not schema:
        return
    expected = sqlite3.connect(":memory:")
    try:
        expected.executescript(schema)
        for table in tables:
            want = [r[1] for r in expected.execute(f"PRAGMA table_info({table})")]
            have = [r[1] for r in db.execute(f"PRAGMA table_info({table})")]
            if want and have != want and not _lacks_only_added(table, have, want):
                raise InputError(f"{option} {name} is not an RCAN state database: its table {table!r} has the "
                                 f"columns {', '.join(have)}, not RCAN's; give a new file name (nothing was changed)")
    finally:
        expected.close()


def _lacks_only_added(table: str, have: list[str], want: list[str]) -> bool:
    """Whether columns ``have`` are ``want`` but for some of the last :data:`ADDED_COLUMNS` (an older database)."""
    added = [column for column, _ in ADDED_COLUMNS.get(table, ())]
    missing = want[len(have):]
    return have == want[:len(have)] and 0 < len(missing) <= len(added) and added[len(added) - len(missing):] == missing


def connect_state_db(path: str | os.PathLike, option: str = "--state-db", schema: str | None = None) -> sqlite3.Connection:
    """Open (or create) a bimrobot state database, marked with :data:`APPLICATION_ID`, in WAL mode,
    with the tables of ``schema`` (SQL, ``CREATE TABLE IF NOT EXISTS``).

    An existing file that is not a bimrobot state database (another program's SQLite file, any other
    file, or one marked as bimrobot's whose tables clash with RCAN's) is refused with an InputError and
    left untouched: no table is ever added to a user's database. An empty file counts as new (another
    process of the same run may have just created it).
    """
    name = str(path)
    if name != ":memory:":
        file = Path(name)
        if file.is_dir():
            raise InputError(f"{option} {name} is a folder; give a file name")
        if file.exists() and file.stat().st_size > 0 and not is_state_db(file):
            raise InputError(
                f"{option} {name} is an existing file that is not a bimrobot state database; "
                "give a new file name (nothing was changed)"
            )
        try:
            file.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"{option} {name}: cannot create its folder ({exc.strerror})") from None
    try:
        # a generous busy timeout: executor processes sharing a simulated site wait for each other
        db = sqlite3.connect(name, isolation_level=None, check_same_thread=False, timeout=60.0)
        try:
            _check_tables(db, name, schema, option)  # before anything is written
        except InputError:
            db.close()
            raise
        if db.execute("PRAGMA application_id").fetchone()[0] == 0:
            # set before WAL mode, so the mark is in the main file's header at once, not in the WAL
            db.execute(f"PRAGMA application_id={APPLICATION_ID}")
        db.execute("PRAGMA journal_mode=WAL")
        db.execute("PRAGMA synchronous=FULL")
        if schema:
            db.executescript(schema)
            _add_columns(db)
    except sqlite3.Error as exc:
        raise InputError(f"{option} {name}: cannot open it as an SQLite database ({exc})") from None
    return db


def _add_columns(db: sqlite3.Connection) -> None:
    """Give an older database the :data:`ADDED_COLUMNS` it lacks (a no-op for a current one)."""
    for table, columns in ADDED_COLUMNS.items():
        have = {r[1] for r in db.execute(f"PRAGMA table_info({table})")}
        for column, kind in columns:
            if have and column not in have:
                try:
                    db.execute(f"ALTER TABLE {table} ADD COLUMN {column} {kind}")
                except sqlite3.OperationalError as exc:
                    if "duplicate column" not in str(exc):  # another process of the run added it first
                        raise


_WRITE_LOCKS: dict[str, threading.Lock] = {}
_WRITE_LOCKS_GUARD = threading.Lock()


def write_lock(path: str | os.PathLike) -> threading.Lock:
    """The lock that this process's writers of the state database ``path`` (the journal, the sim site's
    executors) hold from ``BEGIN IMMEDIATE`` to ``COMMIT``. A writer that waits for another is woken
    the moment it commits; left to SQLite's busy handler it would sleep 1, 2, 5, 10 ms ... between
    tries, which was most of the dispatch latency with a database file. Writers in other processes
    still meet through SQLite's locking. ``:memory:`` databases are private: each gets its own lock."""
    name = str(path)
    if name == ":memory:":
        return threading.Lock()
    key = os.path.realpath(name)
    with _WRITE_LOCKS_GUARD:
        return _WRITE_LOCKS.setdefault(key, threading.Lock())


def _process_start(pid: int) -> str:
    """The start time of process ``pid`` (clock ticks since boot, from /proc), "" when unknown: with
    the pid it names one process, so a recycled pid is not taken for a lock's dead owner."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as stream:
            return stream.read().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return ""


def _alive(pid: int, started: str) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return not started or not _process_start(pid) or _process_start(pid) == started


def _journal_is_empty(path: str) -> bool:
    """True when the bimrobot state database at ``path`` records no started activity (or no journal)."""
    try:
        # read-write although it only reads: a read-only connection to a WAL database leaves -wal and
        # -shm files behind when it closes; this one checkpoints and removes them
        db = sqlite3.connect(f"file:{quote(path)}?mode=rw", uri=True)
    except sqlite3.Error:
        return False
    try:
        return db.execute("SELECT COUNT(*) FROM journal").fetchone()[0] == 0
    except sqlite3.OperationalError as exc:
        return "no such table" in str(exc)
    finally:
        db.close()


@contextlib.contextmanager
def removed_unless_used(path: str | os.PathLike | None) -> Iterator[None]:
    """Around a run: a state database this run creates is removed again when the run ends before its
    first activity started (a failed start leaves no state file behind). An existing database, one of
    another program, and ``:memory:`` are never touched."""
    name = None if path is None else str(path)
    if name is None or name == ":memory:" or os.path.lexists(name):
        yield
        return
    missing = []  # folders the run may create for the file, deepest first
    folder = Path(name).absolute().parent
    while not folder.exists():
        missing.append(folder)
        folder = folder.parent
    try:
        yield
    finally:
        if os.path.exists(name) and (os.path.getsize(name) == 0 or is_state_db(name)) and _journal_is_empty(name):
            for suffix in ("", "-wal", "-shm", "-journal"):
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(name + suffix)
        if not os.path.exists(name):
            for folder in missing:
                try:
                    folder.rmdir()
                except OSError:  # not empty (something else was put there) or already gone
                    break


def stored_plan(path: str | os.PathLike) -> str | None:
    """The plan signature recorded in the bimrobot state database at ``path`` (None for a new or empty
    file, another program's file or a database without a plan). Read only: nothing is written."""
    name = str(path)
    if name == ":memory:" or not os.path.isfile(name) or os.path.getsize(name) == 0 or not is_state_db(name):
        return None
    try:
        # read-write although it only reads, as in _journal_is_empty: no -wal or -shm file is left behind
        db = sqlite3.connect(f"file:{quote(name)}?mode=rw", uri=True)
    except sqlite3.Error:
        return None
    try:
        row = db.execute("SELECT value FROM meta WHERE key='plan'").fetchone()
    except sqlite3.Error:
        return None
    finally:
        db.close()
    return row[0] if row else None


def check_plan(path: str | os.PathLike, plan: str, option: str = "--state-db") -> None:
    """Refuse (InputError) the state database at ``path`` when it records a plan other than ``plan``
    (a signature, :func:`bimrobot.rcan.system.plan_signature`), before anything opens it for writing."""
    if stored_plan(path) not in (None, plan):
        raise InputError(f"state database {path} belongs to a different plan; use a new {option} "
                         "(nothing was changed)")


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
