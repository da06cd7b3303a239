"""Stopping a benchmark with SIGTERM (what a scheduler or `kill` sends) stops its training workers too."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import importlib.util

import pytest

# found, not imported: sb3-contrib pulls in torch (about 2.5 s) at collection otherwise (tests/conftest.py)
pytestmark = pytest.mark.skipif(importlib.util.find_spec("sb3_contrib") is None,
                                reason="the rl benchmark needs sb3-contrib: pip install 'bimrobot[rl]'")


def _children(pid: int) -> list[int]:
    children = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(child) for child in children.read_text().split()] if children.exists() else []


def _alive(pid: int) -> bool:
    status = Path(f"/proc/{pid}/status")
    if not status.exists():
        return False
    return "State:\tZ" not in status.read_text()


def _wait_for(condition, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.2)
    return False


@pytest.mark.skipif(not Path(f"/proc/{os.getpid()}/task/{os.getpid()}/children").exists(),
                    reason="needs Linux /proc/<pid>/task/<pid>/children to find the workers")
def test_sigterm_stops_the_workers_and_leaves_no_half_written_run(tmp_path):
    out = tmp_path / "grid"
    command = [sys.executable, "-m", "bimrobot.cli", "rl", "benchmark", "--settings", "E1S1", "--algos", "a2c",
               "--seeds", "0", "--timesteps", "1e7", "--workers", "1", "--threads", "1", "-o", str(out)]
    master = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        training = lambda: any((out / "runs").glob(".E1S1-a2c-s0.*.tmp/episodes.csv"))  # noqa: E731
        assert _wait_for(training, 120), "the worker never started training"
        workers = _children(master.pid)
        assert workers, "the benchmark has no worker processes"
        master.send_signal(signal.SIGTERM)
        master.wait(timeout=60)
        assert master.returncode != 0
        assert _wait_for(lambda: not any(_alive(pid) for pid in workers), 30), "a worker kept training"
        # no run had finished: neither a half-written run dir nor the empty benchmark folder is left
        assert not out.exists(), "an unfinished run dir or an empty benchmark folder was left behind"
    finally:
        if master.poll() is None:
            os.kill(master.pid, signal.SIGKILL)
            master.wait()
