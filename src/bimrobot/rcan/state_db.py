"""The RCAN state database as a file (thesis 5.2.1's journal): an SQLite file marked as bimrobot's
(:data:`APPLICATION_ID`), opened only when it is one (:func:`connect_state_db`, never a user's database),
its tables (:data:`SCHEMA`, older files given the :data:`ADDED_COLUMNS`), the per-process write lock,
the run's lock owner (a process id with its start time), the removal of a database a failed start
left unused, and the plan it records.

What is journaled and how results move the component states is :mod:`bimrobot.rcan.state_manager`.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
import threading
from pathlib import Path
from typing import Iterator
from urllib.parse import quote

from bimrobot.core.errors import InputError

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
