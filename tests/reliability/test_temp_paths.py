"""Folders that bimrobot makes for other programs inside a command's own temporary folder stay usable:
a local Ray instance's Unix sockets fit the 107 bytes a socket's path may have (issue 35: in the
command's temporary folder, one level deeper than /tmp, `rl benchmark --ray local` failed with
"AF_UNIX path length cannot exceed 107 bytes")."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import pytest

from .conftest import tally

pytestmark = pytest.mark.chaos


@pytest.mark.parametrize("deep", [False, True])
def test_a_local_ray_session_folder_leaves_room_for_its_sockets(monkeypatch, tmp_path, deep):
    from bimrobot.core import cores

    room = 66  # what `rl benchmark --ray local` asks for (bimrobot.rl.benchmark.RAY_SOCKET_ROOM)
    # the command's temporary folder: as short as /tmp/bimrobot-<pid>-<8> is, or as deep as a test's
    base = tmp_path / ("x" * 40) if deep else Path(tempfile.mkdtemp(prefix="bimrobot-1234567-", dir="/tmp"))
    base.mkdir(exist_ok=True)
    monkeypatch.setattr(tempfile, "tempdir", str(base))
    folder = Path(cores.socket_folder(room))
    try:
        socket = folder / "session_2026-11-28_07-00-48_568884_4194304" / "sockets" / "plasma_store"
        assert len(os.fsencode(str(socket))) <= cores.UNIX_SOCKET_PATH_MAX
        assert folder.is_dir() and not list(folder.iterdir())
        # inside the command's folder (removed however the command ends) unless there is no room there
        assert (folder.parent == base) is (not deep)
        assert list(base.iterdir()) == ([folder] if not deep else [])
    finally:
        shutil.rmtree(folder, ignore_errors=True)
        if not deep:
            shutil.rmtree(base, ignore_errors=True)
    tally("temporary paths")
