"""Chaos: a schedule over Redis with 4 executor processes while a driver kills an executor, the
coordinator or redis-server at random and restarts each. At the end every activity was executed exactly
once by the robots (their own execution log, not only the journal) and the final states equal those of
an uninterrupted run. Bounded: about 3 minutes (``RCAN_CHAOS_S`` sets the time the driver kills for)."""

from __future__ import annotations

import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from rcan_helpers import frame_schedule

pytestmark = [pytest.mark.chaos, pytest.mark.redis, pytest.mark.slow]

COMPONENTS = 46  # x 11 RCAN activities = 506
ROBOTS = {f"crane_{c}": [4.0 * i, 0.0, 0.0] for i, c in enumerate("abcd")}


def write_caps(path: Path) -> Path:
    import yaml

    from rcan_helpers import TABLE_5_2

    robot = {"types": ["mobile_base", "manipulator", "gripper"], "payload_kg": 1000, "reach_m": 5.0,
             "speed_m_s": 1.0, "arm_speed_m_s": 0.5, "handling_s": {"pick_up": 10, "install": 20}}
    path.write_text(yaml.safe_dump({"robot_types": TABLE_5_2,
                                    "robots": {name: {**robot, "home": home} for name, home in ROBOTS.items()}}))
    return path


def final_states(journal: Path, site: Path) -> dict:
    with sqlite3.connect(journal) as con:
        states = {"components": con.execute("SELECT global_id, state FROM component ORDER BY 1").fetchall(),
                  "activities": con.execute("SELECT activity_id, status, attempts FROM activity ORDER BY 1").fetchall()}
    with sqlite3.connect(site) as con:
        states["placed"] = con.execute(
            "SELECT global_id, round(x, 6), round(y, 6), round(z, 6), holder FROM sim_component ORDER BY 1").fetchall()
        states["goals"] = sorted(con.execute("SELECT activity_id, attempt, success FROM sim_execution").fetchall())
    return states


class Deployment:
    """redis-server, 4 executor processes and the coordinator, each restartable."""

    def __init__(self, tmp: Path, schedule: Path, caps: Path, port: int):
        self.tmp, self.port = tmp, port
        self.url = f"redis://127.0.0.1:{port}/0"
        faults = ["--failure-probability", "0.05", "--seed", "11"]
        self.executor_cmd = [sys.executable, "-m", "bimrobot", "rcan", "executor", "--redis", self.url,
                             "--capabilities", str(caps), "--state-db", str(tmp / "site.sqlite"),
                             "--time-scale", "0.008", "--claim-idle", "1", "--workers", "2", *faults]
        self.coordinator_cmd = [sys.executable, "-m", "bimrobot", "rcan", "run", "--schedule", str(schedule),
                                "--capabilities", str(caps), "--redis", self.url, "--no-local-executors",
                                "--state-db", str(tmp / "journal.sqlite"), "--max-attempts", "8", "-q",
                                "--claim-idle", "1", *faults]
        self.redis = self.coordinator = None
        self.executors = [None] * 4
        self.kills = {"executor": 0, "coordinator": 0, "redis-server": 0}

    def start_redis(self):
        self.redis = subprocess.Popen([shutil.which("redis-server"), "--bind", "127.0.0.1", "--port", str(self.port),
                                       "--save", "", "--appendonly", "no"],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        import redis

        client = redis.Redis(port=self.port)
        for _ in range(250):
            try:
                client.ping()
                break
            except redis.ConnectionError:
                time.sleep(0.02)
        client.close()

    def start_executor(self, i):
        log = open(self.tmp / f"executor{i}.log", "a")
        self.executors[i] = subprocess.Popen(self.executor_cmd, stdout=log, stderr=subprocess.STDOUT)

    def start_coordinator(self):
        log = open(self.tmp / "coordinator.log", "a")
        self.coordinator = subprocess.Popen(self.coordinator_cmd, stdout=log, stderr=subprocess.STDOUT)

    def keep_alive(self):
        """Restart what died by itself (e.g. a coordinator started while Redis was down exits 2)."""
        for i, process in enumerate(self.executors):
            if process.poll() is not None:
                self.start_executor(i)
        if self.coordinator.poll() not in (None, 0):
            self.start_coordinator()

    def kill(self, rng):
        target = rng.choice(["executor", "coordinator", "redis-server"], p=[0.5, 0.25, 0.25])
        if target == "executor":
            i = int(rng.integers(4))
            process = self.executors[i]
        else:
            process = self.coordinator if target == "coordinator" else self.redis
        if process.poll() is not None:
            return
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=30)
        self.kills[target] += 1
        if target == "executor":
            self.start_executor(i)
        elif target == "coordinator":
            self.start_coordinator()
        else:
            self.start_redis()

    def stop(self):
        for process in [self.coordinator, self.redis, *self.executors]:
            if process is not None and process.poll() is None:
                process.kill()
                process.wait(timeout=30)


def test_chaos_every_activity_executed_exactly_once_and_states_equal_an_uninterrupted_run(tmp_path, free_port):
    if shutil.which("redis-server") is None:
        pytest.skip("redis-server is not installed (Debian package redis-server)")
    pytest.importorskip("redis")

    schedule = frame_schedule(tmp_path / "schedule.csv", components=COMPONENTS)
    caps = write_caps(tmp_path / "caps.yaml")
    reference = tmp_path / "reference"
    reference.mkdir()
    subprocess.run([sys.executable, "-m", "bimrobot", "rcan", "run", "--schedule", str(schedule), "--capabilities",
                    str(caps), "--state-db", str(reference / "journal.sqlite"), "--max-attempts", "8", "-q",
                    "--failure-probability", "0.05", "--seed", "11"], check=True, capture_output=True, timeout=120)
    expected = final_states(reference / "journal.sqlite", reference / "journal.sqlite")
    activities = len(expected["activities"])
    assert activities >= 500 and {s for _, s, _ in expected["activities"]} == {"done"}

    deployment = Deployment(tmp_path, schedule, caps, free_port())
    rng = np.random.default_rng(5)
    chaos_s = float(os.environ.get("RCAN_CHAOS_S", "60"))
    started = time.monotonic()
    try:
        deployment.start_redis()
        for i in range(4):
            deployment.start_executor(i)
        deployment.start_coordinator()
        while deployment.coordinator.poll() != 0 and time.monotonic() - started < chaos_s:
            time.sleep(float(rng.uniform(0.2, 1.5)))
            deployment.kill(rng)
            deployment.keep_alive()
        while deployment.coordinator.poll() != 0 and time.monotonic() - started < chaos_s + 100:
            time.sleep(0.2)
            deployment.keep_alive()
        elapsed = time.monotonic() - started
    finally:
        deployment.stop()
    log = (tmp_path / "coordinator.log").read_text()
    assert deployment.coordinator.returncode == 0, log[-3000:]
    assert f"{activities}/{activities} activities done" in log
    got = final_states(tmp_path / "journal.sqlite", tmp_path / "site.sqlite")
    successes = [a for a, _, ok in got["goals"] if ok]
    assert sorted(successes) == sorted(set(successes)) and len(successes) == activities  # each goal once
    assert got == expected
    print(f"\nchaos: {activities} activities in {elapsed:.1f} s ({activities / elapsed:.1f} tasks/s) with kills "
          f"{deployment.kills}")
