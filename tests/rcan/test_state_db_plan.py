"""Issue 35: a state database of another plan is refused before anything is written to it (it was
refused only after the sim backend had added its robots: robot rows 3 -> 9)."""

from __future__ import annotations

import sqlite3

import pytest

from bimrobot.core.errors import InputError
from bimrobot.rcan.generation import load_capabilities
from bimrobot.rcan.plans import experiment
from bimrobot.rcan.system import run_plan


def _files(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _robot_rows(db) -> int:
    connection = sqlite3.connect(db)
    try:
        return connection.execute("SELECT COUNT(*) FROM sim_robot").fetchone()[0]
    finally:
        connection.close()


def test_a_state_database_of_another_plan_is_refused_byte_for_byte_unchanged(tmp_path):
    db = tmp_path / "state.sqlite"
    report = run_plan(experiment(1).activities, load_capabilities(), state_db=str(db))
    assert report.status == "completed"
    robots = _robot_rows(db)
    before = _files(tmp_path)
    with pytest.raises(InputError, match=r"belongs to a different plan; use a new --state-db \(nothing was changed\)"):
        run_plan(experiment(2).activities, load_capabilities(), state_db=str(db))
    assert _files(tmp_path) == before  # no robot row, no owner, no -wal file
    assert _robot_rows(db) == robots
    again = run_plan(experiment(1).activities, load_capabilities(), state_db=str(db))  # its own plan: resumed
    assert again.status == "completed"
