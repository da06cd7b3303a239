"""Long commands stopped at seeded pseudo-random moments by SIGINT (Ctrl-C), SIGTERM, SIGHUP or SIGKILL
leave nothing behind: no process of the run, no /dev/shm file, nothing in the run's temporary folder.

Each run is a ``bimrobot`` subprocess in its own session (so that every process it starts can be found by
its session id, and Ctrl-C reaches its whole process group as a terminal's would), with its own TMPDIR (so
that a process started in a session of its own, as Rerun's web viewer server is, is found by its
environment). SIGTERM, SIGHUP and SIGKILL go to the command's process alone, as ``kill $!`` or ``timeout``
send them. CI runs 18 trials (6 commands, each with 3 of the 4 signals); BIMROBOT_CHAOS_LONG=1 runs 72.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import threading
import time
import weakref
from pathlib import Path

import pytest

from .conftest import CHAOS_LONG, SHARED_IFC, processes_with_environment, session_processes, shm_files, shm_in_use, tally

pytestmark = pytest.mark.chaos

SEED = 35
TRIALS = 72 if CHAOS_LONG else 18
SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP", "SIGKILL")
STOPPED_STATUS = {"SIGINT": 130, "SIGTERM": 143, "SIGHUP": 129, "SIGKILL": -9}


def _commands(work: Path) -> dict[str, tuple[list[str], tuple[float, float]]]:
    """Command name -> (bimrobot arguments, the window in seconds after the start in which to stop it)."""
    return {
        "convert": (["convert", str(SHARED_IFC / "AC20-FZK-Haus.ifc"), "-o", str(work / "pkg")], (0.5, 10.0)),
        "build": (["build", str(work.parent / "frame.ifc"), "-o", str(work / "out")], (0.5, 12.0)),
        "rcan run": (["rcan", "run", "--experiment", "1", "--backend", "sim"], (0.5, 5.0)),
        "simulate": (["simulate", str(work.parent / "frame.ifc"), "--fleet", "fleet2", "-o", str(work / "sim")], (0.5, 6.0)),
        "rl train": (["rl", "train", "--setting", "E3S2", "--algo", "ppo", "--timesteps", "500", "-o", str(work / "runs")],
                     (0.5, 10.0)),
        # starting (about 3 s on an idle machine) or serving: it serves until stopped
        "replay --serve": (["replay", "--serve", str(work.parent / "tiny.rrd")], (0.5, 8.0)),
    }


COMMANDS = ("convert", "build", "rcan run", "rl train", "simulate", "replay --serve")


def _trials() -> list[tuple[str, str, float]]:
    """(command, signal, fraction of its window) per trial: in each round of 6 trials every command
    meets the signal after the one it met in the round before (4 rounds, 24 trials: every pair)."""
    rng = random.Random(SEED)
    n = len(COMMANDS)
    return [(COMMANDS[i % n], SIGNALS[(i % n + i // n) % len(SIGNALS)], rng.random()) for i in range(TRIALS)]


@pytest.fixture(scope="module")
def tiny_rrd(tmp_path_factory) -> Path:
    """A Rerun recording of one point, written with the rerun-sdk (what `replay --serve` serves)."""
    rr = pytest.importorskip("rerun")
    path = tmp_path_factory.mktemp("chaos-rrd") / "tiny.rrd"
    recording = rr.RecordingStream("bimrobot-chaos")
    recording.save(str(path))
    recording.log("point", rr.Points3D([[0.0, 0.0, 0.0]]))
    recording.flush()
    recording.disconnect()
    return path


@pytest.fixture(scope="module")
def frame_ifc(tmp_path_factory) -> Path:
    from bimrobot.bim.examples import steel_frame

    return steel_frame(tmp_path_factory.mktemp("chaos") / "frame.ifc")


def _environment(tmp: Path) -> dict[str, str]:
    # PYTHONFAULTHANDLER: a crash (one SIGSEGV of `simulate` stopped by SIGTERM at 2.0 s, not seen again in
    # 40 tries) shows where it happened in the trial's message
    env = dict(os.environ, TMPDIR=str(tmp), PYTHONUNBUFFERED="1", PYTHONFAULTHANDLER="1")
    env.pop("BIMROBOT_CHAOS_LONG", None)
    return env


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(TRIALS))
def test_a_stopped_command_leaves_nothing_behind(trial, frame_ifc, tmp_path, request):
    command, signame, fraction = _trials()[trial]
    if command == "convert" and not (SHARED_IFC / "AC20-FZK-Haus.ifc").exists():
        pytest.skip(f"{SHARED_IFC}/AC20-FZK-Haus.ifc is absent: the shared test data lives beside the repository")
    work = tmp_path / "work"
    work.mkdir()
    (work.parent / "frame.ifc").write_bytes(frame_ifc.read_bytes())
    if command == "replay --serve":
        (work.parent / "tiny.rrd").write_bytes(request.getfixturevalue("tiny_rrd").read_bytes())
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    arguments, (earliest, latest) = _commands(work)[command]
    delay = earliest + fraction * (latest - earliest)
    shm_before = shm_files()
    run = subprocess.Popen([sys.executable, "-m", "bimrobot", *arguments], cwd=work, env=_environment(tmp),
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    errors: list[str] = []
    reader = threading.Thread(target=lambda: errors.append(run.stderr.read()), daemon=True)
    reader.start()
    failed = True
    try:
        try:
            run.wait(timeout=delay)  # a command that ends first is stopped by nothing: still checked
        except subprocess.TimeoutExpired:
            signum = getattr(signal, signame)
            if signame == "SIGINT":
                os.killpg(run.pid, signum)  # Ctrl-C: the terminal signals the whole foreground group
            else:
                os.kill(run.pid, signum)
        status = run.wait(timeout=180)
        reader.join(timeout=30)
        left = _left_processes(run.pid, tmp)
        shm_left = sorted(name for name in shm_files() - shm_before if name not in shm_in_use())
        tmp_left = sorted(p.name for p in tmp.iterdir())
        stderr = "".join(errors)
        what = f"{command} stopped by {signame} after {delay:.2f} s (exit status {status})"
        assert not left, f"{what}: processes {left} of the run remain"
        assert not shm_left, f"{what}: /dev/shm files {shm_left} remain"
        # 0: it ended first; 128 + n: stopped by bimrobot; -n: stopped before Python's start was over
        assert status in (0, STOPPED_STATUS[signame], -getattr(signal, signame)), f"{what}: stderr {stderr[-2000:]}"
        assert "Traceback" not in stderr, f"{what}: {stderr[-2000:]}"
        if tmp_left == ["torchinductor_root"] and command == "rl train":
            failed = False
            pytest.xfail(f"{what}: rl leaves torchinductor_root in the temporary folder (rl/ is another part's)")
        assert not tmp_left, f"{what}: {tmp_left} remain in its temporary folder"
        failed = False
    finally:
        for pid in session_processes(run.pid) + processes_with_environment(str(tmp)):  # nothing is left to the next test
            with_suppressed_kill(pid)
        tally("signals", 1, int(failed))


def _left_processes(session: int, tmp: Path) -> list[int]:
    """The processes of ``session``, or whose environment names the run's temporary folder ``tmp``, still
    alive after a short grace (the kernel kills orphaned children at once, but a loaded machine may take a
    moment), up to 100 polls."""
    for _ in range(100):
        left = sorted(set(session_processes(session) + processes_with_environment(str(tmp))))
        if not left:
            return []
        time.sleep(0.1)
    return left


def with_suppressed_kill(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
    except OSError:
        pass


def test_an_interrupt_python_discarded_in_a_finalizer_stops_the_command():
    # issue 35: 2 of 20 Ctrl-C let `simulate` finish and exit 0; the interrupt landed in a weakref
    # callback, where Python prints "Exception ignored" and goes on. The CLI delivers it again.
    from bimrobot.core import signals

    class Thing:
        pass

    def landed_here(_):
        raise KeyboardInterrupt  # as the signal handler raises it when Ctrl-C comes during the callback

    stopped = False
    with signals.stop_signals_unwind():
        thing = Thing()
        watch = weakref.ref(thing, landed_here)
        try:
            del thing  # the callback runs, its KeyboardInterrupt is unraisable
            for _ in range(10_000):  # the re-delivered interrupt comes once the hook's thread runs
                time.sleep(0.001)
        except KeyboardInterrupt as stop:
            stopped = True
            stop.seen["by_main"] = True  # taken here, as main takes it: not to be delivered again
    assert stopped and watch() is None
    tally("signals")


def _spin() -> None:
    """Python bytecodes (and sleeps, so that other threads run) for up to 10 s: where a signal lands."""
    for _ in range(10_000):
        time.sleep(0.001)


@pytest.mark.parametrize("signame", ["SIGTERM", "SIGHUP", "SIGINT"])
def test_every_stop_signal_stops_a_command_like_ctrl_c(monkeypatch, signame):
    # in-process: the handler raises Stopped, main returns 128 + the signal's number, and the previous
    # handlers are back afterwards
    from bimrobot import cli
    from bimrobot.core import signals

    signum = getattr(signal, signame)
    before = {s: signal.getsignal(s) for s in signals.STOP_SIGNALS}

    def stopped(args):
        os.kill(os.getpid(), signum)
        _spin()
        return 0

    monkeypatch.setattr("bimrobot.assembly.cli.cmd_optimum", stopped)
    assert cli.main(["assembly", "optimum", "--setting", "E1S1"]) == 128 + signum
    assert {s: signal.getsignal(s) for s in signals.STOP_SIGNALS} == before
    tally("signals")


def test_a_stop_caught_by_a_broad_except_is_delivered_again(monkeypatch):
    # trimesh and others catch BaseException in places: the command must stop all the same
    from bimrobot import cli

    caught = []

    def swallowing(args):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            _spin()
        except BaseException as exc:  # noqa: BLE001 - what the libraries do
            caught.append(type(exc).__name__)
        _spin()
        return 0

    monkeypatch.setattr("bimrobot.assembly.cli.cmd_optimum", swallowing)
    caught_before = caught
    assert cli.main(["assembly", "optimum", "--setting", "E1S1"]) == 143
    assert caught_before == ["Stopped"]
    tally("signals")


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_a_stop_left_set_inside_a_c_extension_stops_the_command(monkeypatch, capsys, signame):
    # issue 35: 1 of 10 Ctrl-C into `simulate MULTICOM-Prefab.ifc` landed while IfcOpenShell's SWIG code
    # called back into Python, and Python raised "SystemError: <built-in function
    # entity_instance__get_inverse> returned a result with an exception set" (the stop as its cause):
    # exit 1 and a traceback. It is the stop: 128 + the signal, no traceback.
    from bimrobot import cli
    from bimrobot.core import signals

    signum = getattr(signal, signame)

    def stopped_in_c(args):
        try:
            os.kill(os.getpid(), signum)
            _spin()
        except signals.Stopped as stop:  # what CPython does when a C function returns with the stop set
            raise SystemError("<built-in function entity_instance__get_inverse> returned a result with an "
                              "exception set") from stop
        return 0

    def a_real_system_error(args):
        raise SystemError("a defect of a C extension, nothing to do with a stop")

    monkeypatch.setattr("bimrobot.assembly.cli.cmd_optimum", stopped_in_c)
    assert cli.main(["assembly", "optimum", "--setting", "E1S1"]) == 128 + signum
    assert "Traceback" not in capsys.readouterr().err
    monkeypatch.setattr("bimrobot.assembly.cli.cmd_optimum", a_real_system_error)
    with pytest.raises(SystemError, match="a defect"):  # anything else is not hidden
        cli.main(["assembly", "optimum", "--setting", "E1S1"])
    tally("signals")


def test_a_stop_during_an_import_waits_for_the_import_to_finish(monkeypatch, tmp_path):
    # trimesh imports SciPy under `except BaseException` for seconds: a stop raised there was lost and
    # left trimesh half imported; it is delivered once the import is over
    import importlib
    import sys as system

    from bimrobot import cli

    (tmp_path / "slow_optional.py").write_text(
        "import os, signal, time\n"
        "try:\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    for _ in range(200):\n"
        "        time.sleep(0.001)\n"
        "    complete = True\n"
        "except BaseException:\n"
        "    complete = False\n",
        encoding="utf-8",
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    imported = []

    def importing(args):
        imported.append(importlib.import_module("slow_optional"))
        _spin()
        return 0

    monkeypatch.setattr("bimrobot.assembly.cli.cmd_optimum", importing)
    try:
        assert cli.main(["assembly", "optimum", "--setting", "E1S1"]) == 143
        assert imported and imported[0].complete  # the import ran to its end, the stop came after it
    finally:
        system.modules.pop("slow_optional", None)
    tally("signals")


@pytest.mark.ros
def test_a_killed_external_robot_node_leaves_no_shared_memory(tmp_path):
    # issue 35: a SIGKILLed `rcan robot-node` left fastrtps_port* files in /dev/shm; it talks UDP only now,
    # and a run on the default transports still reaches it
    from bimrobot.rcan.backends import ros2

    ok, why = ros2.ros2_available()
    if not ok:
        pytest.skip(why)
    env = dict(os.environ, ROS_DOMAIN_ID=str(random.Random(SEED).randint(101, 200)), TMPDIR=str(tmp_path))
    env.pop("FASTDDS_BUILTIN_TRANSPORTS", None)
    before = shm_files()
    node = subprocess.Popen([sys.executable, "-m", "bimrobot", "rcan", "robot-node", "--time-scale", "0"], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        for line in node.stdout:
            if "action servers" in line:
                break
        run = subprocess.run([sys.executable, "-m", "bimrobot", "rcan", "run", "--experiment", "1", "--backend", "ros2",
                              "--robot-node", "external"], env=env, cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert run.returncode == 0 and "5/5 activities done" in run.stdout, run.stdout[-2000:] + run.stderr[-2000:]
        node.kill()
        node.wait(timeout=60)
        left = sorted(name for name in shm_files() - before if "fastrtps" in name or "fastdds" in name)
        assert not [name for name in left if name not in shm_in_use()], f"{left} remain in /dev/shm"
    finally:
        node.kill()
        node.wait()
        node.stdout.close()
    tally("signals")


_HOLDING_A_TEMP_FILE = """
import tempfile, time
from bimrobot.core.cores import private_temp_folder
with private_temp_folder() as folder:
    with open(tempfile.mkstemp()[1], "w") as held:  # a temporary file, open, as a command holds one
        print(folder, flush=True)
        time.sleep(600)
"""


def test_the_temporary_folder_of_a_killed_command_is_removed(tmp_path):
    # SIGKILL runs no cleanup in the command: its watcher removes the folder once the command is gone
    run = subprocess.Popen([sys.executable, "-c", _HOLDING_A_TEMP_FILE], stdout=subprocess.PIPE, text=True,
                           env=dict(os.environ, TMPDIR=str(tmp_path)))
    try:
        folder = Path(run.stdout.readline().strip())
        assert folder.parent == tmp_path and len(list(folder.iterdir())) == 1
        run.kill()
        run.wait(timeout=60)
        for _ in range(100):  # the watcher wakes at once; allow 10 s under load
            if not folder.exists():
                break
            time.sleep(0.1)
        assert not folder.exists() and not list(tmp_path.iterdir())
    finally:
        run.kill()
        run.wait()
        run.stdout.close()
    tally("signals")


def test_a_killed_replay_server_leaves_no_viewer_serving(tiny_rrd, tmp_path):
    # issue 35: `replay --serve` stopped with SIGKILL left Rerun's viewer server serving, with parent 1
    # (it runs in a session of its own); it dies with bimrobot now
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    run = subprocess.Popen([sys.executable, "-m", "bimrobot", "replay", "--serve", str(tiny_rrd)], env=_environment(tmp),
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        url = None
        for line in run.stdout:  # the URL, once Rerun's server listens
            if line.startswith("web viewer: "):
                url = line.split(": ", 1)[1].strip()
                break
        assert url, "no URL printed"
        assert len(processes_with_environment(str(tmp))) >= 2  # bimrobot and Rerun's server
        run.kill()
        assert run.wait(timeout=60) == -signal.SIGKILL
        assert _left_processes(run.pid, tmp) == []
        for _ in range(100):  # the watcher removes the temporary folder once the command is gone
            if not list(tmp.iterdir()):
                break
            time.sleep(0.1)
        assert list(tmp.iterdir()) == []
    finally:
        for pid in session_processes(run.pid) + processes_with_environment(str(tmp)):
            with_suppressed_kill(pid)
        run.stdout.close()
    tally("signals")


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_a_stop_during_cp_sats_search_stops_the_command(tmp_path, signame):
    """`simulate --planner cp-sat` stopped while CP-SAT searches (60 s of wall time for a 208-task frame,
    after a few seconds of set-up): it exits with 128 + the signal's number and writes no output. CP-SAT's
    own SIGINT handler used to end the search and let the command finish (exit 0, its output written),
    and a SIGTERM waited for the search's time limit."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    run = subprocess.Popen([sys.executable, "-m", "bimrobot", "simulate", "generated:4x3x2", "--per-joint", "--planner",
                            "cp-sat", "-o", str(tmp_path / "out"), "--no-gantt", "--no-progress"],
                           env=_environment(tmp), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                           start_new_session=True)
    try:
        time.sleep(8.0)  # the portfolio's runs and the model's build take 1-3 s here: CP-SAT searches by now
        assert run.poll() is None, f"it ended before the signal: {run.stderr.read()}"
        signum = getattr(signal, signame)
        os.killpg(run.pid, signum) if signame == "SIGINT" else os.kill(run.pid, signum)
        assert run.wait(timeout=180) == 128 + signum
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert not (tmp_path / "out").exists() and list(tmp.iterdir()) == []
    tally("signals")


SIDE_BY_SIDE = """
from bimrobot.bim.selection import DEFAULT_PREBUILT
from bimrobot.coordination.generate import generated_frame
from bimrobot.planning.optimal import solve_optimal
from bimrobot.sco import build_smart_model
from bimrobot.site.fleet import load_fleet

model = generated_frame(4, 3, 2)
smart = build_smart_model(model, prebuilt_classes=DEFAULT_PREBUILT)
print("solving", flush=True)
solve_optimal(smart, load_fleet("fleet2"), storey_elevations=[s.elevation for s in model.storeys], time_limit_s=600,
              workers=2)
"""


def test_ctrl_c_ends_the_floors_solved_side_by_side_at_once(tmp_path):
    """solve_optimal with two workers solves the floors that differ side by side, in threads (4x3x2: none
    is proved within minutes). Ctrl-C while they search ends them at once; it used to wait for each
    floor's share of the time limit (here up to 360 s)."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    run = subprocess.Popen([sys.executable, "-c", SIDE_BY_SIDE], env=_environment(tmp), stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        assert run.stdout.readline().strip() == "solving"
        time.sleep(8.0)  # the market's run and the floors' models take 1-3 s here: the floors search by now
        assert run.poll() is None, f"it ended before the signal: {run.stderr.read()}"
        os.killpg(run.pid, signal.SIGINT)
        assert run.wait(timeout=30) == -signal.SIGINT  # Python's default: KeyboardInterrupt, then the signal
        assert "KeyboardInterrupt" in run.stderr.read()
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
        run.stdout.close()
        run.stderr.close()
    tally("signals")
