"""Open a replay in Rerun's web viewer, served on 127.0.0.1, with Rerun's usage analytics off.

The viewer is the ``rerun`` program of the rerun-sdk wheel (the web viewer ships inside it and runs
offline). Rerun's analytics are switched off the documented way, ``rerun analytics disable``, in a
configuration folder of our own (``XDG_CONFIG_HOME``/``XDG_DATA_HOME`` of the started process only),
so the user's own Rerun settings are neither read nor changed; OpenTelemetry export stays off too.

That setting does not reach the web viewer running in the browser: Rerun 0.41's web viewer posts its
usage events (``$identify``, ``viewer_started``, ``load_data_source``, ``open_recording``) to
``https://tel.rerun.io/api/pog`` whatever the server's setting, and has no URL parameter or setting
to stop it; its page also asks ``api.github.com`` for the latest release, ``app.rerun.io`` for the
examples and Google for a web font. So the page is served through :class:`PolicyServer`, a small
proxy on 127.0.0.1 that adds a Content-Security-Policy header allowing connections to 127.0.0.1 only:
the browser then sends none of those requests (they show as blocked by ``csp`` in its developer tools).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from bimrobot.core.cores import dies_with_this_process
from bimrobot.core.errors import InputError

URL_PATTERN = re.compile(r"connect at (http://127\.0\.0\.1:\d+\S*)")


def rerun_program() -> str:
    """The ``rerun`` executable beside this Python (the rerun-sdk wheel's), else on PATH."""
    beside = Path(sys.executable).with_name("rerun")
    found = str(beside) if beside.is_file() else shutil.which("rerun")
    if not found:
        raise InputError("the `rerun` program is not installed: pip install rerun-sdk (see scripts/setup.sh)")
    return found


def _viewer_binary() -> str:
    """The viewer binary that the rerun-sdk's ``rerun`` launcher (a Python script) runs, so that the
    process bimrobot starts is the server itself; the launcher where the binary is not found."""
    import importlib.util

    spec = importlib.util.find_spec("rerun_cli")
    for folder in (spec.submodule_search_locations or []) if spec else []:
        binary = Path(folder) / ("rerun.exe" if sys.platform.startswith("win") else "rerun")
        if binary.is_file() and os.access(binary, os.X_OK):
            return str(binary)
    return rerun_program()


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


#: What the page of the web viewer may load: its own files and the replay's gRPC proxy, both on
#: 127.0.0.1; no analytics, release checks, example lists, map tiles or web fonts from elsewhere.
CONTENT_SECURITY_POLICY = ("connect-src 'self' http://127.0.0.1:* ws://127.0.0.1:* data: blob:; "
                           "style-src 'self' 'unsafe-inline'; font-src 'self' data:; img-src 'self' data: blob:")
#: Headers that belong to one connection and are not passed on by the proxy (RFC 9110, 7.6.1).
HOP_BY_HOP = {"connection", "keep-alive", "proxy-authenticate", "proxy-authorization", "te", "trailer",
              "transfer-encoding", "upgrade", "content-security-policy"}


class PolicyServer:
    """An HTTP proxy on 127.0.0.1 in front of Rerun's web viewer server that adds
    :data:`CONTENT_SECURITY_POLICY` to every answer (module docstring). ``port``: the port it listens on."""

    def __init__(self, upstream: str, port: int = 0):
        import http.server
        import threading

        self.upstream = upstream.rstrip("/")
        proxy = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self):  # noqa: N802 (http.server's naming)
                proxy.forward(self)

            def do_HEAD(self):  # noqa: N802
                proxy.forward(self, body=False)

            def log_message(self, *args):  # quiet: the viewer's page asks for a few files
                pass

        try:
            self.server = http.server.ThreadingHTTPServer(("127.0.0.1", port), Handler)
        except OSError as exc:
            raise InputError(f"--web-port {port}: cannot listen on 127.0.0.1:{port} ({exc.strerror})") from None
        self.server.daemon_threads = True
        self.port = self.server.server_address[1]
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()

    def forward(self, handler, body: bool = True) -> None:
        """Answer ``handler``'s request with the upstream server's answer and the policy header."""
        import urllib.error
        import urllib.request

        request = urllib.request.Request(self.upstream + handler.path, method=handler.command,
                                         headers={k: v for k, v in handler.headers.items() if k.lower() not in HOP_BY_HOP | {"host"}})
        try:
            answer = urllib.request.urlopen(request, timeout=60)
        except urllib.error.HTTPError as error:
            answer = error
        except (urllib.error.URLError, OSError) as exc:
            handler.send_error(502, f"Rerun's web viewer server did not answer ({exc})")
            return
        with answer:
            handler.send_response(answer.status)
            for key, value in answer.headers.items():
                if key.lower() not in HOP_BY_HOP:
                    handler.send_header(key, value)
            handler.send_header("Content-Security-Policy", CONTENT_SECURITY_POLICY)
            handler.end_headers()
            while body and (chunk := answer.read(1 << 16)):
                handler.wfile.write(chunk)

    def stop(self) -> None:
        self.server.shutdown()
        self.server.server_close()


@dataclass
class WebViewer:
    """A running ``rerun --serve-web`` process behind a :class:`PolicyServer`: ``url`` opens the replay
    in a browser."""

    process: subprocess.Popen
    url: str
    home: tempfile.TemporaryDirectory
    policy: PolicyServer | None = None

    def stop(self) -> None:
        """Stop the proxy and the viewer server and remove its private configuration folder."""
        if self.policy is not None:
            self.policy.stop()
            self.policy = None
        _stop_group(self.process)
        self.home.cleanup()

    def __enter__(self) -> "WebViewer":
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


#: The first bytes of a Rerun recording (an .rrd file of the rerun-sdk's format).
RRD_MAGIC = b"RRF2"
def check_recording(rrd: Path) -> None:
    """Refuse, in one sentence, a path that is not a readable Rerun recording."""
    try:
        with open(rrd, "rb") as handle:
            head = handle.read(len(RRD_MAGIC))
    except FileNotFoundError:
        raise InputError(f"{rrd}: no such recording") from None
    except IsADirectoryError:
        raise InputError(f"{rrd} is a folder, not a Rerun recording (.rrd)") from None
    except OSError as exc:
        raise InputError(f"{rrd}: cannot read it ({exc.strerror})") from None
    if head != RRD_MAGIC:
        raise InputError(f"{rrd} is not a Rerun recording (it does not start as an .rrd file does)")


def serve_until_stopped(rrd: Path, port: int, announce) -> int:
    """Serve ``rrd`` in the web viewer (:func:`serve_web`), call ``announce(url)`` and wait until the
    viewer server ends or bimrobot is stopped; either way stop Rerun's server (its whole process group)
    and remove its temporary folder before returning. Ctrl-C (SIGINT), SIGTERM and SIGHUP all unwind
    through here (bimrobot.cli turns the latter two into :class:`bimrobot.core.signals.Stopped`, a
    KeyboardInterrupt, for the command's duration; here too when called outside it), and a second
    signal during the clean-up does not cut it short. Returns 1 when the server ended by itself."""
    from bimrobot.core.signals import stop_signals_unwind

    with stop_signals_unwind():
        viewer = serve_web(rrd, web_port=port)
        try:
            announce(viewer.url)
            code = viewer.process.wait()
            print(f"Rerun's web viewer server stopped by itself (exit status {code})", file=sys.stderr)
            return 1
        finally:
            with _stop_signals_ignored():
                viewer.stop()


@contextlib.contextmanager
def _stop_signals_ignored():
    """SIGINT, SIGTERM and SIGHUP ignored for a while (in the main thread, where signals are delivered)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.signal(signum, signal.SIG_IGN) for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def serve_web(rrd: Path, web_port: int = 0, grpc_port: int = 0, timeout_s: float = 60.0) -> WebViewer:
    """Start Rerun's web viewer for ``rrd`` on 127.0.0.1 behind the policy proxy, which listens on
    ``web_port`` (0: a free one); return it once it listens."""
    policy = PolicyServer("http://127.0.0.1", web_port)  # its port first: a taken --web-port fails before rerun starts
    viewer = None
    try:
        viewer = _start_rerun(rrd, grpc_port, timeout_s)
        upstream = re.match(r"http://127\.0\.0\.1:\d+", viewer.url).group(0)
        policy.upstream = upstream
        viewer.policy = policy
        viewer.url = viewer.url.replace(upstream, f"http://127.0.0.1:{policy.port}", 1)
        return viewer
    except BaseException:
        policy.stop()
        if viewer is not None:
            viewer.policy = None
            viewer.stop()
        raise


def _start_rerun(rrd: Path, grpc_port: int, timeout_s: float) -> WebViewer:
    """``rerun --serve-web`` for ``rrd`` on 127.0.0.1 (free ports unless ``grpc_port`` is given)."""
    home = tempfile.TemporaryDirectory(prefix="bimrobot-rerun-")
    process = None
    try:
        env = quiet_environment(Path(home.name))
        command = [_viewer_binary(), "--serve-web", "--bind", "127.0.0.1", "--web-viewer-port", "0",
                   "--port", str(grpc_port), str(Path(rrd).resolve())]
        # Its own process group, stopped as one (the `rerun` launcher, where the binary is not found, starts it
        # as a child); the binary itself dies with bimrobot even when bimrobot is SIGKILLed (issue 35: it was
        # left serving, with parent 1).
        process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                   start_new_session=True, preexec_fn=dies_with_this_process())
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
        raise RuntimeError("rerun --serve-web did not report its address: " + " | ".join(seen[-5:]))
    except BaseException:  # a failure, Ctrl-C or a stop signal while it starts: nothing is left behind
        if process is not None:
            _stop_group(process)
        home.cleanup()
        raise


def _stop_group(process: subprocess.Popen, wait_s: float = 5.0) -> None:
    """Stop ``process`` and every process of its group (the launcher and the viewer binary it started):
    SIGTERM, then SIGKILL for what is left after ``wait_s``; returns once none is left."""
    import signal

    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:  # the whole group is gone already
            return
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline:
            process.poll()  # reap the launcher (its child, once orphaned, is reaped by init)
            try:
                os.killpg(process.pid, 0)
            except ProcessLookupError:
                return
            time.sleep(0.05)


def _local_url(url: str) -> str:
    """Rerun names the data source ``localhost``; point it at 127.0.0.1, where it listens."""
    return url.replace("localhost%3A", "127.0.0.1%3A")


def _drain(process: subprocess.Popen) -> None:
    import threading

    threading.Thread(target=lambda: [None for _ in process.stdout], daemon=True).start()
