"""RCAN over Redis streams: a real redis-server on 127.0.0.1, started and stopped by the test."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time

import pytest

from bimrobot.rcan.broker import RedisBroker
from bimrobot.rcan.generation import load_capabilities
from bimrobot.rcan.plans import COLUMN_ID, experiment
from bimrobot.rcan.system import run_plan

pytestmark = pytest.mark.redis


@pytest.fixture
def redis_url(free_port):
    """A throw-away redis-server (no persistence) on a free loopback port; stopped by PID afterwards."""
    server = shutil.which("redis-server")
    if server is None:
        pytest.skip("redis-server is not installed (Debian package redis-server)")
    pytest.importorskip("redis", reason="the redis Python client is not installed: pip install 'bimrobot[redis]'")
    import redis

    port = free_port()
    process = subprocess.Popen([server, "--bind", "127.0.0.1", "--port", str(port), "--save", "", "--appendonly", "no",
                                "--daemonize", "no"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"redis://127.0.0.1:{port}/0"
    client = redis.Redis.from_url(url)
    for _ in range(200):
        try:
            client.ping()
            break
        except redis.ConnectionError:
            time.sleep(0.02)
    client.close()
    yield url
    process.terminate()
    process.wait(timeout=10)


def test_experiment_over_redis_streams(redis_url):
    lines = []
    report = run_plan(experiment(2).activities, load_capabilities(), redis_url=redis_url, log=lines.append)
    assert report.status == "completed" and report.component_states == {COLUMN_ID: "Assembled"}
    assert len(report.latencies_s) == 6


def test_executor_in_another_process(redis_url, tmp_path):
    site = tmp_path / "site.sqlite"
    executor = subprocess.Popen([sys.executable, "-m", "bimrobot", "rcan", "executor", "--redis", redis_url,
                                 "--backend", "sim", "--state-db", str(site)],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        report = run_plan(experiment(3).activities, load_capabilities(), redis_url=redis_url,
                          spawn_executors=False, timeout_s=60)
    finally:
        executor.terminate()
        output = executor.communicate(timeout=10)[0]
    assert report.status == "completed", output
    import sqlite3

    executed = sqlite3.connect(site).execute("SELECT activity_id FROM sim_execution ORDER BY rowid").fetchall()
    assert [a for (a,) in executed] == [f"E3.{i}" for i in range(1, 7)]  # the other process did the work


def test_unacknowledged_message_is_delivered_again_after_a_crash(redis_url):
    sender = RedisBroker(redis_url, group="executor", consumer="sender")
    sender.send("rcan.robot.husky_ur5", {"activity_id": "E1.1"})
    worker = RedisBroker(redis_url, group="executor", consumer="executor-husky")
    (first,) = worker.receive(["rcan.robot.husky_ur5"], timeout_s=1.0)
    assert first.payload == {"activity_id": "E1.1"}
    worker.close()  # crashed before acknowledging
    restarted = RedisBroker(redis_url, group="executor", consumer="executor-husky")
    (again,) = restarted.receive(["rcan.robot.husky_ur5"], timeout_s=1.0)
    assert again.message_id == first.message_id
    restarted.ack(again)  # sent with its next command, or when it closes
    restarted.close()
    later = RedisBroker(redis_url, group="executor", consumer="executor-husky")
    assert later.receive(["rcan.robot.husky_ur5"], timeout_s=0.2) == []
    for broker in (sender, later):
        broker.close()


def test_coordinator_killed_on_redis_resumes_without_repeating(redis_url, tmp_path, schedule_csv):
    """The coordinator dies (SIGKILL) three times while the executor process keeps working; results it
    never received wait in Redis. The resumed run executes every activity exactly once."""
    import os
    import signal
    import sqlite3

    import numpy as np

    from rcan_helpers import done_count, write_capabilities

    caps = write_capabilities(tmp_path / "caps.yaml")
    site, journal = tmp_path / "site.sqlite", tmp_path / "journal.sqlite"
    executor = subprocess.Popen([sys.executable, "-m", "bimrobot", "rcan", "executor", "--redis", redis_url,
                                 "--capabilities", str(caps), "--state-db", str(site), "--time-scale", "0.01",
                                 "--failure-probability", "0.2", "--seed", "4"],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    command = [sys.executable, "-m", "bimrobot", "rcan", "run", "--schedule", str(schedule_csv), "--capabilities",
               str(caps), "--redis", redis_url, "--no-local-executors", "--state-db", str(journal), "-q",
               "--max-attempts", "8"]
    try:
        executor.stdout.readline()  # serving
        rng = np.random.default_rng(7)
        for k in sorted(rng.choice(np.arange(2, 38), size=3, replace=False)):
            coordinator = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            while done_count(journal) < k and coordinator.poll() is None:
                time.sleep(0.02)
            os.kill(coordinator.pid, signal.SIGKILL)
            coordinator.wait(timeout=30)
        final = subprocess.run(command, capture_output=True, text=True, timeout=120)
    finally:
        executor.terminate()
        executor.communicate(timeout=10)
    assert final.returncode == 0, final.stdout + final.stderr
    assert "44/44 activities done" in final.stdout
    executed = sqlite3.connect(site).execute(
        "SELECT activity_id, attempt, COUNT(*) FROM sim_execution GROUP BY activity_id, attempt").fetchall()
    assert all(n == 1 for _, _, n in executed)  # no goal executed twice
    con = sqlite3.connect(journal)
    done = con.execute("SELECT activity_id, COUNT(*) FROM journal WHERE event='done' GROUP BY activity_id").fetchall()
    assert len(done) == 44 and all(n == 1 for _, n in done)
    final_attempts = dict(con.execute("SELECT activity_id, attempts FROM activity"))
    # the journal's last attempt of each activity is the last attempt a robot executed
    assert {a: max(n for b, n, _ in executed if b == a) for a in final_attempts} == final_attempts
    assert set(con.execute("SELECT state FROM component").fetchall()) == {("Assembled",)}


def test_work_of_a_dead_consumer_is_claimed_and_a_poison_message_goes_to_the_dead_letter_stream(redis_url):
    sender = RedisBroker(redis_url, group="executor", consumer="sender")
    sender.send("rcan.robot.husky_ur5", {"activity_id": "E1.1"})
    dead = RedisBroker(redis_url, group="executor", consumer="executor-dead", claim_idle_s=None)
    (taken,) = dead.receive(["rcan.robot.husky_ur5"], timeout_s=1.0)
    dead.close()  # died without acknowledging; it never comes back under that name
    alive = RedisBroker(redis_url, group="executor", consumer="executor-alive", claim_idle_s=0.2, max_deliveries=3)
    time.sleep(0.3)
    (claimed,) = alive.receive(["rcan.robot.husky_ur5"], timeout_s=0.5)
    assert claimed.message_id == taken.message_id and claimed.payload == {"activity_id": "E1.1"}
    # the message keeps killing whoever takes it: after 3 deliveries it is dead-lettered, not handed out again
    for n in range(3):
        time.sleep(0.3)
        alive._last_claim = 0.0
        messages = RedisBroker(redis_url, group="executor", consumer=f"executor-{n}", claim_idle_s=0.2,
                               max_deliveries=3).receive(["rcan.robot.husky_ur5"], timeout_s=0.3)
        if not messages:
            break
    coordinator = RedisBroker(redis_url, group="rcan", consumer="coordinator")
    (dead_letter,) = coordinator.receive(["rcan.dead"], timeout_s=1.0)
    assert dead_letter.payload["topic"] == "rcan.robot.husky_ur5"
    assert dead_letter.payload["payload"] == {"activity_id": "E1.1"} and dead_letter.payload["deliveries"] > 3
    for broker in (sender, alive, coordinator):
        broker.close()


def test_a_node_nobody_can_execute_is_escalated_through_the_dead_letter_stream(redis_url, monkeypatch):
    """The executor dies on the transport every time it takes it (the worker ends without a result or an
    acknowledgement): after 2 deliveries the node is dead-lettered and its activity escalated."""
    from bimrobot.rcan.backends.sim import SimBackend

    original = SimBackend.execute

    def dying(self, node, attempt=1, ready_at_s=0.0, feedback=None):
        if node.activity_id == "E2.4":
            raise SystemExit  # what a crashing robot driver does to its worker
        return original(self, node, attempt, ready_at_s, feedback)

    monkeypatch.setattr(SimBackend, "execute", dying)
    report = run_plan(experiment(2).activities, load_capabilities(), redis_url=redis_url,
                      redis_options={"claim_idle_s": 0.2, "max_deliveries": 2}, timeout_s=60)
    assert report.status == "escalated" and report.escalated == ["E2.4"]
    assert "dead-letter stream" in report.escalations[0].message
    assert report.done == ["E2.1", "E2.2", "E2.3"] and set(report.blocked_by) == {"E2.5", "E2.6"}


@pytest.mark.parametrize("persistence", [["--appendonly", "yes", "--appendfsync", "always"], ["--appendonly", "no"]],
                         ids=["with persistence", "without persistence"])
def test_a_redis_restart_mid_run_is_survived(tmp_path, persistence, schedule_csv, cranes, free_port):
    """redis-server is killed (SIGKILL) mid-run and started again on the same port: coordinator and
    executors reconnect, groups are recreated, unfinished work is re-sent, every goal runs once."""
    import os
    import signal
    import sqlite3
    import threading

    from bimrobot.schedule.csv import load_schedule_csv
    from bimrobot.rcan.plans import plan_from_schedule

    from rcan_helpers import done_count

    server = shutil.which("redis-server")
    if server is None:
        pytest.skip("redis-server is not installed (Debian package redis-server)")
    pytest.importorskip("redis")
    import redis

    port = free_port()
    command = [server, "--bind", "127.0.0.1", "--port", str(port), "--save", "", "--dir", str(tmp_path), *persistence]

    def start():
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        client = redis.Redis(port=port)
        for _ in range(250):
            try:
                client.ping()
                break
            except (redis.ConnectionError, redis.ResponseError):  # not up, or still loading its file
                time.sleep(0.02)
        client.close()
        return process

    process = start()
    db = tmp_path / "run.sqlite"
    plan = plan_from_schedule(load_schedule_csv(schedule_csv))
    outcome, lines = {}, []
    run = threading.Thread(target=lambda: outcome.update(report=run_plan(
        plan, cranes, redis_url=f"redis://127.0.0.1:{port}/0", state_db=str(db), timeout_s=120,
        backend_options={"time_scale": 0.01}, log=lines.append)))
    run.start()
    try:
        deadline = time.monotonic() + 60
        while done_count(db) < 10 and time.monotonic() < deadline:
            time.sleep(0.02)
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=10)
        time.sleep(0.5)
        process = start()
        run.join(timeout=120)
    finally:
        process.terminate()
        process.wait(timeout=10)
    report = outcome["report"]
    assert report.status == "completed" and len(report.done) == len(plan)
    assert any("broker reconnected: re-sending" in line for line in lines)  # it did go through the restart
    goals = sqlite3.connect(db).execute("SELECT activity_id, COUNT(*) FROM sim_execution GROUP BY 1").fetchall()
    assert len(goals) == len(plan) and all(n == 1 for _, n in goals)  # the robots worked once per activity
