"""One run per state database, foreign databases refused untouched, and goals executed once by id."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time

import pytest

from bimrobot.cli import main
from bimrobot.core.errors import InputError
from bimrobot.rcan.activities import ActivityKind as K, Pose, RcanActivity
from bimrobot.rcan.backends.sim import SimBackend
from bimrobot.rcan.generation import load_capabilities
from bimrobot.rcan.node import RcanNode
from bimrobot.rcan.plans import experiment
from bimrobot.rcan.state_manager import StateStore
from bimrobot.rcan.state_db import APPLICATION_ID
from bimrobot.rcan.system import run_plan

from rcan_helpers import done_count


def owner_pid(db) -> str | None:
    try:
        con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
        row = con.execute("SELECT value FROM meta WHERE key='owner'").fetchone()
        con.close()
    except sqlite3.Error:
        return None
    return row[0].split()[0] if row else None


def test_a_second_run_on_the_same_database_is_refused_naming_the_owner_then_a_dead_owner_is_taken_over(tmp_path, capsys):
    db = tmp_path / "run.sqlite"
    command = [sys.executable, "-m", "bimrobot", "rcan", "run", "--experiment", "2", "-q", "--state-db", str(db),
               "--time-scale", "1"]  # about 15 s of robot time in real time
    first = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while (owner_pid(db) is None or done_count(db) < 1) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert owner_pid(db) == str(first.pid)
        assert main(["rcan", "run", "--experiment", "2", "-q", "--state-db", str(db)]) == 2
        err = capsys.readouterr().err
        assert f"is in use by another RCAN run (process {first.pid})" in err and err.count("\n") == 1
    finally:
        os.kill(first.pid, signal.SIGKILL)
        first.wait(timeout=30)
    # the owner was killed: its lock is stale, the next run takes it over and finishes the build
    assert main(["rcan", "run", "--experiment", "2", "-q", "--state-db", str(db)]) == 0
    assert "6/6 activities done" in capsys.readouterr().out
    assert owner_pid(db) is None  # released at the end


def test_two_runs_in_one_process_are_refused_too(tmp_path):
    db = tmp_path / "run.sqlite"
    holder = StateStore(db)
    holder.lock()
    try:
        with pytest.raises(InputError, match=rf"in use by another RCAN run \(process {os.getpid()}\)"):
            run_plan(experiment(1).activities, load_capabilities(), state_db=str(db))
    finally:
        holder.close()
    assert run_plan(experiment(1).activities, load_capabilities(), state_db=str(db)).status == "completed"


def unchanged_after(path, args, capsys, words):
    before = path.read_bytes()
    assert main(args) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1 and "Traceback" not in err
    assert path.read_bytes() == before
    assert not os.path.exists(f"{path}-wal") and not os.path.exists(f"{path}-shm")


def test_an_unrelated_sqlite_file_stays_byte_identical(tmp_path, capsys):
    user = tmp_path / "user.sqlite"
    con = sqlite3.connect(user)
    con.execute("CREATE TABLE journal (day TEXT, text TEXT)")  # a table name RCAN also uses
    con.commit()
    con.close()
    unchanged_after(user, ["rcan", "run", "--experiment", "1", "-q", "--state-db", str(user)], capsys, "did not write")
    with pytest.raises(InputError, match="not a bimrobot state database"):
        StateStore(user)
    with pytest.raises(InputError, match="not a bimrobot state database"):
        SimBackend(load_capabilities(), db_path=user)


def test_a_bimrobot_marked_database_with_clashing_tables_is_an_input_error(tmp_path, capsys):
    marked = tmp_path / "marked.sqlite"
    con = sqlite3.connect(marked)
    con.execute(f"PRAGMA application_id={APPLICATION_ID}")
    con.execute("CREATE TABLE activity (name TEXT)")  # RCAN's table name, other columns
    con.commit()
    con.close()
    unchanged_after(marked, ["rcan", "run", "--experiment", "1", "-q", "--state-db", str(marked)], capsys,
                    "its table 'activity' has the columns name, not RCAN's")
    other = tmp_path / "other.sqlite"
    con = sqlite3.connect(other)
    con.execute(f"PRAGMA application_id={APPLICATION_ID}")
    con.execute("CREATE TABLE triples (s, p, o)")
    con.commit()
    con.close()
    unchanged_after(other, ["rcan", "run", "--experiment", "1", "-q", "--state-db", str(other)], capsys,
                    "has a table 'triples' RCAN does not write")


def test_the_robot_refuses_a_goal_id_it_has_completed_and_reports_the_earlier_result(tmp_path):
    sim = SimBackend(load_capabilities(), db_path=tmp_path / "site.sqlite")
    goal = RcanNode("rcan/G.1", RcanActivity("G.1", "COL", K.MOVE_TO_COMPONENT, Pose(0, 0, 0), 2.0), "husky_ur5", "sim")
    first = sim.execute(goal, 1)
    again = sim.execute(goal, 2)  # the coordinator lost the result and sent the activity once more
    assert again.success and (again.message, again.started_s, again.finished_s) == (
        first.message, first.started_s, first.finished_s)
    assert again.attempt == 2  # answered as the attempt that asked
    assert sim.site.executions() == [("G.1", 1, True)]  # the robot moved once
    assert sim.site.robot_state("husky_ur5")["clock_s"] == pytest.approx(first.finished_s)
    sim.close()


class _Heard:
    """An observer that records what the state manager tells it."""

    def __init__(self):
        self.lines = []

    def set_activity_state(self, activity_id, state):
        self.lines.append((activity_id, state))

    def set_component_state(self, global_id, state):
        self.lines.append((global_id, state))


def test_a_turn_is_committed_whole_before_anything_of_it_is_seen_and_a_failed_turn_leaves_nothing(tmp_path):
    """The coordinator commits each turn of its loop as one transaction (one disk sync for the result
    it handled and the node it starts next): until the turn commits, another reader of the database
    and the observers (the construction graph) see none of it; a turn that fails leaves no trace."""
    from bimrobot.rcan.backends.info import ActivityResult
    from bimrobot.rcan.state_manager import StateManager

    path = tmp_path / "run.sqlite"
    store, heard = StateStore(path), _Heard()
    manager = StateManager(store, observers=[heard])
    place = RcanActivity("P.1", "COL", K.POSITION_FOR_INSTALLING, Pose(1, 0, 0.3), 2.0)
    store.register([("P.1", "COL", place.kind.value)], ["COL"])
    node = RcanNode("rcan/P.1", place, "husky_ur5", "sim")
    reader = sqlite3.connect(path)
    journal = lambda: reader.execute("SELECT activity_id, event FROM journal ORDER BY seq").fetchall()  # noqa: E731

    with pytest.raises(RuntimeError):
        with store.batch():
            manager.start(node, 1)
            raise RuntimeError("the coordinator dies mid-turn")
    assert journal() == [] and store.component_state("COL") == "OnYard" and heard.lines == []

    with store.batch():
        manager.start(node, 1)
        manager.result(node, ActivityResult("P.1", 1, "husky_ur5", True, "placed", 0.0, 4.0))
        assert journal() == [] and heard.lines == []  # not committed yet: nothing of the turn is out
    assert journal() == [("P.1", "started"), ("P.1", "done")]
    assert store.component_state("COL") == "PositionFixed"
    assert heard.lines == [("P.1", "started"), ("COL", "WorkingInPositioning"), ("P.1", "done"),
                           ("COL", "PositionFixed")]
    reader.close()
    store.close()


def test_a_database_from_before_started_s_resumes_and_the_report_gives_each_activitys_times(tmp_path, capsys):
    """A state database written before RCAN kept start times (no ``activity.started_s``) opens and its
    run resumes; the start of an activity done before is unknown (null), every other done activity
    has its robot, start and finish in report.json, the start not after the finish."""
    db, report_path = tmp_path / "run.sqlite", tmp_path / "report.json"
    command = [sys.executable, "-m", "bimrobot", "rcan", "run", "--experiment", "2", "-q", "--state-db", str(db),
               "--time-scale", "1"]  # about 15 s of robot time in real time: killed after 2 activities
    first = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while done_count(db) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        os.kill(first.pid, signal.SIGKILL)
        first.wait(timeout=30)
    con = sqlite3.connect(db)
    before = dict(con.execute("SELECT activity_id, finished_s FROM activity WHERE status='done'"))
    con.execute("ALTER TABLE activity DROP COLUMN started_s")  # as an older bimrobot wrote it
    con.commit()
    con.close()
    assert 2 <= len(before) < 6

    assert main(["rcan", "run", "--experiment", "2", "-q", "--state-db", str(db), "--report", str(report_path)]) == 0
    assert "6/6 activities done" in capsys.readouterr().out
    report = json.loads(report_path.read_text())
    assert list(report["activities"]) == report["done"] and len(report["done"]) == 6
    for activity_id, entry in report["activities"].items():
        assert entry["result"] == "done" and entry["robot"] == report["robots"][activity_id]
        if activity_id in before:
            assert entry["started_s"] is None and entry["finished_s"] == pytest.approx(before[activity_id])
        else:
            assert 0.0 <= entry["started_s"] <= entry["finished_s"] <= report["makespan_s"]
    with contextlib.closing(StateStore(db)) as store:
        rows = store.activity_rows()
    assert {a for a, row in rows.items() if row["started_s"] is not None} == set(report["done"]) - set(before)
