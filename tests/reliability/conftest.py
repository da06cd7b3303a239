"""The reliability suite (marker ``chaos``): commands stopped at seeded moments, IFC files mutated.

Each family counts its trials and failures and prints one line at the end of the run, e.g.
``chaos signals: 12 trials, 0 failures``, which docs/reliability.md quotes. The CI form is short;
``BIMROBOT_CHAOS_LONG=1`` runs the long form (more trials, same seeds).
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import pytest

CHAOS_LONG = os.environ.get("BIMROBOT_CHAOS_LONG", "") not in ("", "0")
"""Whether to run the long form of every family (set BIMROBOT_CHAOS_LONG=1)."""

SHARED_IFC = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "ifc"
"""The real IFC files beside the repository (tests skip with the reason when they are absent)."""

_tallies: dict[str, list[int]] = {}


def tally(family: str, trials: int = 1, failures: int = 0) -> None:
    """Count ``trials`` more trials of ``family``, ``failures`` of them failed."""
    counts = _tallies.setdefault(family, [0, 0])
    counts[0] += trials
    counts[1] += failures


def pytest_terminal_summary(terminalreporter) -> None:
    for family, (trials, failures) in _tallies.items():
        terminalreporter.write_line(f"chaos {family}: {trials} trials, {failures} failures")


def _stat_fields(pid: str) -> list[str] | None:
    """The fields of /proc/<pid>/stat after the command name (state first), or None when it is gone."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as stat:
            return stat.read().rsplit(")", 1)[1].split()
    except OSError:
        return None


def session_processes(session: int) -> list[int]:
    """The live processes (not zombies) of session ``session`` (a run started with its own session)."""
    found = []
    for pid in os.listdir("/proc"):
        if pid.isdigit():
            fields = _stat_fields(pid)
            # fields: state, ppid, pgrp, session, ...
            if fields and fields[0] != "Z" and int(fields[3]) == session:
                found.append(int(pid))
    return found


def processes_with_environment(text: str) -> list[int]:
    """The live processes (not zombies) other than this one whose environment holds ``text`` (a run's own
    TMPDIR: found even when they left the run's session)."""
    found = []
    needle = text.encode()
    for pid in os.listdir("/proc"):
        if pid.isdigit() and int(pid) != os.getpid():
            fields = _stat_fields(pid)
            with contextlib.suppress(OSError):
                with open(f"/proc/{pid}/environ", "rb") as environ:
                    if fields and fields[0] != "Z" and needle in environ.read():
                        found.append(int(pid))
    return found


def shm_in_use() -> set[str]:
    """Names of /dev/shm files that a live process has mapped or open."""
    used = set()
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        with contextlib.suppress(OSError):
            with open(f"/proc/{pid}/maps", encoding="utf-8", errors="replace") as maps:
                used.update(line.split("/dev/shm/", 1)[1].strip() for line in maps if "/dev/shm/" in line)
        with contextlib.suppress(OSError):
            for fd in os.listdir(f"/proc/{pid}/fd"):
                with contextlib.suppress(OSError):
                    target = os.readlink(f"/proc/{pid}/fd/{fd}")
                    if target.startswith("/dev/shm/"):
                        used.add(target[len("/dev/shm/"):])
    return {name.removesuffix(" (deleted)") for name in used}


def shm_files() -> set[str]:
    """The names in /dev/shm now."""
    try:
        return set(os.listdir("/dev/shm"))
    except OSError:
        return set()


@pytest.fixture
def chaos_long() -> bool:
    return CHAOS_LONG
