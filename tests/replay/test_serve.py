"""`bimrobot replay --serve build.rrd`: an existing recording served as it is, and nothing left running or
lying in the temporary folder when bimrobot is stopped, whichever signal stops it."""

from __future__ import annotations

import importlib.util
import os
import signal
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from bimrobot.cli import main

# found, not imported (tests/conftest.py): rerun costs about 0.5 s of imports at collection otherwise
pytestmark = pytest.mark.skipif(importlib.util.find_spec("rerun") is None,
                                reason="the replay needs rerun-sdk: pip install 'bimrobot[replay]'")


def processes_naming(text: str) -> list[int]:
    """Ids of the running processes whose command line holds ``text``."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if text.encode() in (entry / "cmdline").read_bytes():
                    found.append(int(entry.name))
            except OSError:  # gone meanwhile
                pass
    return found


@pytest.mark.parametrize("argv,message", [
    (["replay", "--serve", "{tmp}/none.rrd"], "none.rrd: no such recording"),
    (["replay", "--serve", "{tmp}/text.rrd"], "text.rrd is not a Rerun recording"),
    (["replay", "{tmp}/text.rrd"], "is a recording already: open it with `rerun"),
    (["replay", "--serve", "{tmp}/text.rrd", "-o", "{tmp}/b.rrd"], "is served as it is; -o names a new recording"),
    (["replay", "{tmp}"], "give the .rrd file to write with -o"),
    (["replay", "--serve", "{tmp}/text.rrd", "--draw", "boxes"], "--draw: {tmp}/text.rrd is served as it was recorded"),
])
def test_serving_a_recording_refuses_what_is_not_one(tmp_path, capsys, argv, message):
    (tmp_path / "text.rrd").write_text("not a recording")
    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 2
    err = capsys.readouterr().err
    assert message.replace("{tmp}", str(tmp_path)) in err and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["text.rrd"]


@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_an_existing_recording_is_served_and_everything_stops_with_bimrobot(frame_pair_replay, tmp_path, stop):
    """The recording is served unchanged; after the signal bimrobot exits with 128 + its number, the
    viewer's page no longer answers, no process of Rerun's server is left and the temporary folder
    holds nothing of it."""
    rrd = tmp_path / "served.rrd"
    rrd.write_bytes(frame_pair_replay[0].read_bytes())
    before = rrd.stat().st_mtime_ns, rrd.read_bytes()
    temp = tmp_path / "tmp"
    temp.mkdir()
    process = subprocess.Popen([sys.executable, "-m", "bimrobot", "replay", "--serve", str(rrd)],
                               env={**os.environ, "TMPDIR": str(temp)}, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)
    try:
        url = None
        for line in process.stdout:  # the URL, once the server listens
            if line.startswith("web viewer: "):
                url = line.split(": ", 1)[1].strip()
                break
        assert url and url.startswith("http://127.0.0.1:"), "no URL printed"
        with urllib.request.urlopen(url, timeout=30) as page:
            assert page.status == 200
        assert processes_naming(str(rrd))  # Rerun's server serves it
        process.send_signal(stop)
        assert process.wait(timeout=60) == 128 + stop
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    with pytest.raises(urllib.error.URLError):
        urllib.request.urlopen(url, timeout=5)
    assert processes_naming(str(rrd)) == []
    assert list(temp.iterdir()) == []
    assert (rrd.stat().st_mtime_ns, rrd.read_bytes()) == before  # served, not written
