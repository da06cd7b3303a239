"""Open a replay in Rerun's web viewer, served on 127.0.0.1, with Rerun's usage analytics off.

The viewer is the ``rerun`` program of the rerun-sdk wheel (the web viewer ships inside it and runs
offline). Rerun's analytics are switched off the documented way, ``rerun analytics disable``, in a
configuration folder of our own (``XDG_CONFIG_HOME``/``XDG_DATA_HOME`` of the started process only),
so the user's own Rerun settings are neither read nor changed; OpenTelemetry export stays off too.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from bimrobot.errors import InputError

URL_PATTERN = re.compile(r"connect at (http://127\.0\.0\.1:\d+\S*)")


def rerun_program() -> str:
    """The ``rerun`` executable beside this Python (the rerun-sdk wheel's), else on PATH."""
    beside = Path(sys.executable).with_name("rerun")
    found = str(beside) if beside.is_file() else shutil.which("rerun")
    if not found:
        raise InputError("the `rerun` program is not installed: pip install rerun-sdk (see scripts/setup.sh)")
    return found


def quiet_environment(home: Path) -> dict[str, str]:
    """The environment for a Rerun process we start: analytics disabled in its own config under ``home``."""
    env = dict(os.environ)
    env["XDG_CONFIG_HOME"] = str(home / "config")
    env["XDG_DATA_HOME"] = str(home / "data")
    env["TELEMETRY_ENABLED"] = "false"  # Rerun's OpenTelemetry export (off by default; kept off)
    env.pop("FORCE_RERUN_ANALYTICS", None)
    config = home / "config" / "rerun" / "analytics.json"
    if not config.is_file():
        subprocess.run([rerun_program(), "analytics", "disable"], env=env, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=60)
    return env


@dataclass
class WebViewer:
    """A running ``rerun --serve-web`` process: ``url`` opens the replay in a browser."""

    process: subprocess.Popen
    url: str
    home: tempfile.TemporaryDirectory

    def stop(self) -> None:
        """Stop the viewer server and remove its private configuration folder."""
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.home.cleanup()

    def __enter__(self) -> "WebViewer":
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


def serve_web(rrd: Path, web_port: int = 0, grpc_port: int = 0, timeout_s: float = 60.0) -> WebViewer:
    """Start Rerun's web viewer for ``rrd`` on 127.0.0.1 (port 0: a free one); return it once it listens."""
    home = tempfile.TemporaryDirectory(prefix="bimrobot-rerun-")
    env = quiet_environment(Path(home.name))
    command = [rerun_program(), "--serve-web", "--bind", "127.0.0.1", "--web-viewer-port", str(web_port),
               "--port", str(grpc_port), str(Path(rrd).resolve())]
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    deadline = time.monotonic() + timeout_s
    seen = []
    while time.monotonic() < deadline:
        line = process.stdout.readline()
        if not line:
            break
        seen.append(line.strip())
        match = URL_PATTERN.search(line)
        if match:
            # Keep reading its output so the viewer never blocks on a full pipe.
            _drain(process)
            return WebViewer(process, _local_url(match.group(1)), home)
    process.kill()
    process.wait()
    home.cleanup()
    raise RuntimeError("rerun --serve-web did not report its address: " + " | ".join(seen[-5:]))


def _local_url(url: str) -> str:
    """Rerun names the data source ``localhost``; point it at 127.0.0.1, where it listens."""
    return url.replace("localhost%3A", "127.0.0.1%3A")


def _drain(process: subprocess.Popen) -> None:
    import threading

    threading.Thread(target=lambda: [None for _ in process.stdout], daemon=True).start()
