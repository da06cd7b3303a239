"""A run killed with SIGKILL at random points resumes without losing or repeating an activity."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


from rcan_helpers import done_count, write_capabilities


def outcome(db: Path) -> dict:
    """What must match between a resumed and an uninterrupted run."""
    con = sqlite3.connect(db)
    executions = con.execute("SELECT activity_id, attempt, success FROM sim_execution ORDER BY activity_id, attempt").fetchall()
    done = con.execute("SELECT activity_id, COUNT(*) FROM journal WHERE event='done' GROUP BY activity_id").fetchall()
    result = {
        "executions": executions,  # every goal a robot ran, with its attempt: a repeat would show twice
        "done_once": sorted(done),
        "components": con.execute("SELECT global_id, state FROM component ORDER BY global_id").fetchall(),
        "installed_at": con.execute("SELECT global_id, round(x, 6), round(y, 6), round(z, 6), holder FROM sim_component ORDER BY global_id").fetchall(),
        "activities": con.execute("SELECT activity_id, status, attempts FROM activity ORDER BY activity_id").fetchall(),
    }
    con.close()
    return result


def test_sigkill_at_random_points_then_resume_matches_uninterrupted_run(tmp_path, schedule_csv):
    caps_file = write_capabilities(tmp_path / "caps.yaml")
    common = ["--schedule", str(schedule_csv), "--backend", "sim", "--capabilities", str(caps_file),
              "--failure-probability", "0.25", "--seed", "3", "--max-attempts", "6", "-q"]

    reference_db = tmp_path / "reference.sqlite"
    subprocess.run([sys.executable, "-m", "bimrobot", "rcan", "run", *common, "--state-db", str(reference_db)],
                   check=True, capture_output=True, timeout=120)
    reference = outcome(reference_db)
    assert len(reference["done_once"]) == 44 and all(n == 1 for _, n in reference["done_once"])
    assert any(attempt > 1 for _, attempt, _ in reference["executions"]), "seed 3 gives some retries"

    db = tmp_path / "killed.sqlite"
    # time scale: about 2.5 s of robot work in wall time after ~1 s of start-up for the whole run, so the kills land mid-run
    command = [sys.executable, "-m", "bimrobot", "rcan", "run", *common, "--state-db", str(db), "--time-scale", "0.012"]
    rng = np.random.default_rng(2024)
    # kill points spread over the run: once k activities are done, plus a random fraction of a second
    # (mid-activity, mid-transaction or between messages)
    done_after_kill = []
    for k in sorted(rng.choice(np.arange(1, 35), size=6, replace=False)):
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 60
        while done_count(db) < k and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(float(rng.uniform(0.0, 0.1)))
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=30)
        done_after_kill.append(done_count(db))
    assert all(0 < n < 44 for n in done_after_kill), f"done activities after each kill: {done_after_kill}"
    final = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert final.returncode == 0, final.stdout + final.stderr
    assert "44/44 activities done" in final.stdout
    assert outcome(db) == reference
