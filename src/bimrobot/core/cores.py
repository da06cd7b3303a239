"""How many cores this process may use, whether work can be spread over forked processes, and how a
child process is bound to the command that started it.

Shared by the IFC reader (geometry on every core) and the package writer (models on every core).
"""

from __future__ import annotations

import contextlib
import ctypes
import gc
import multiprocessing
import os
import shutil
import signal
import sys
import tempfile
import threading


def cores() -> int:
    """CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def can_fork() -> bool:
    """Whether forked processes are safe here (Linux; macOS's fork is unsafe with its system libraries)."""
    return sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()


@contextlib.contextmanager
def frozen_heap():
    """Keep the objects that exist now out of the cyclic garbage collector until the block ends.

    Two reasons: a process forked inside the block does not touch (and so copy) every page it inherits
    when it collects; and a job that allocates many objects does not pay for full collections that
    walk every object of the libraries loaded before it (with trimesh, SciPy and Pillow loaded, one
    such collection took 40 ms of a 0.1 s IFC read). Objects made inside the block are collected as
    usual. Blocks nest: an inner one (before a fork, say) freezes what is new since the outer one began,
    and only the outermost one thaws.
    """
    global _frozen_depth
    gc.freeze()
    _frozen_depth += 1
    try:
        yield
    finally:
        _frozen_depth -= 1
        if _frozen_depth == 0:
            gc.unfreeze()


_frozen_depth = 0  # how many frozen_heap blocks are open in this process


def quick_exit() -> None:
    """Let this process end without the cyclic garbage collector's walks over every object it holds.

    Registers :func:`gc.freeze` as an exit handler (:mod:`atexit`; once however often called). At exit
    the interpreter collects while it tears its modules down, and with trimesh, SciPy, networkx and
    IfcOpenShell loaded that took 0.21 s (measured from a process's last line to its end; 0.03 s with
    the objects frozen), 7 % of what a user waits for ``bimrobot convert`` on a 300-element model. The
    other exit handlers still run, the standard streams are flushed and reference counting frees what
    it frees; only objects caught in reference cycles are left to the operating system unfinalized,
    which Python does not promise to finalize at exit anyway. A caller that runs a command in process
    (a test) ends that way too, when it ends.
    """
    import atexit

    atexit.unregister(gc.freeze)
    atexit.register(gc.freeze)


PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
PARENT_WATCH_S = 0.5
"""Where the kernel cannot kill a child with its parent, how often the child checks for its parent (s)."""


def bind_to_parent(parent: int) -> None:
    """Call first thing in a child process: it dies with ``parent`` (a pid) and leaves stopping to it.

    * The kernel sends SIGKILL to this process when its parent dies, however the parent ended (Ctrl-C,
      SIGTERM, SIGKILL, ``timeout``): Linux's ``prctl(PR_SET_PDEATHSIG)``. Where that call is not
      available, a daemon thread checks every :data:`PARENT_WATCH_S` seconds that the parent is still
      there. A parent that died before this call (its pid is no longer ours' parent) ends the child at
      once. Note: Linux counts the *thread* that forked the child; bimrobot's children are forked by a
      thread that waits for them.
    * SIGINT is ignored (Ctrl-C reaches the whole process group; the parent stops its children itself,
      so they print no traceback of their own), and SIGTERM and SIGHUP are back to their default
      action (end at once), whatever handlers the parent had installed.
    """
    with contextlib.suppress(ValueError):  # not Python's main thread (cannot be, after a fork)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        for signum in (signal.SIGTERM, signal.SIGHUP):
            signal.signal(signum, signal.SIG_DFL)
    if not _kill_with_parent():
        threading.Thread(target=_watch_parent, args=(parent,), name="bimrobot-parent-watch", daemon=True).start()
    if os.getppid() != parent:  # the parent died before the kernel was told to watch it
        os._exit(1)


def _kill_with_parent() -> bool:
    """Ask Linux to SIGKILL this process when its parent dies; False where it cannot."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def dies_with_this_process():
    """A ``preexec_fn`` for :class:`subprocess.Popen`: the program started gets SIGKILL from the kernel
    when this process ends, however it ends (SIGKILL included), as :func:`bind_to_parent` does for a
    forked child. For a program that starts no processes of its own. None (nothing bound) off Linux and
    outside the main thread: Linux watches the *thread* that started the program, which may end first."""
    if not sys.platform.startswith("linux") or threading.current_thread() is not threading.main_thread():
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl  # looked up here: the child only calls it
    except (OSError, AttributeError):
        return None
    parent = os.getpid()

    def bind() -> None:
        prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        if os.getppid() != parent:  # this process ended before the kernel was told to watch it
            os._exit(1)

    return bind


def _watch_parent(parent: int) -> None:
    """The fallback of :func:`bind_to_parent`: end this process once ``parent`` is no longer its parent."""
    while os.getppid() == parent:
        threading.Event().wait(PARENT_WATCH_S)
    os._exit(1)


UNIX_SOCKET_PATH_MAX = 107
"""Bytes a Unix socket's path may have (Linux: 108 with the final NUL)."""


def socket_folder(room: int) -> str:
    """A new, empty folder for a program that makes Unix sockets up to ``room`` bytes below it: in the
    temporary folder (the command's own, removed however the command ends) where the paths fit
    :data:`UNIX_SOCKET_PATH_MAX`, else in /tmp (the caller removes it). The caller owns the folder."""
    folder = tempfile.mkdtemp(prefix="r")  # a short name: /tmp/bimrobot-<pid>-<8>/r<8> is 38 bytes
    if len(os.fsencode(folder)) + room <= UNIX_SOCKET_PATH_MAX:
        return folder
    os.rmdir(folder)
    return tempfile.mkdtemp(prefix="bimrobot-", dir="/tmp")


@contextlib.contextmanager
def private_temp_folder():
    """While inside, the temporary files of this process and of every process it starts go into one
    folder of its own, ``bimrobot-<pid>-*`` in the temporary folder (``tempfile``'s, and ``$TMPDIR``
    for the processes it starts), which a small watcher process removes once this process and the
    children it forked have all ended, however they ended: SIGKILL included. Yields the folder.

    The watcher is forked first thing (a few MB, no library loaded), ignores the signals a terminal
    sends, waits for end-of-file on a pipe whose write end only the command and its forked children
    hold, removes the folder and exits. Where fork is unsafe, the folder is removed at the end of the
    block only. Yields None (and changes nothing) where no temporary folder can be made.
    """
    try:
        folder = tempfile.mkdtemp(prefix=f"bimrobot-{os.getpid()}-")
    except OSError:  # no writable temporary folder: the command says so if it needs one
        yield None
        return
    watcher = None
    if can_fork():
        read_end, write_end = os.pipe()
        watcher = os.fork()
        if watcher == 0:
            _remove_when_closed(read_end, folder)  # never returns
        os.close(read_end)
    saved = tempfile.tempdir, os.environ.get("TMPDIR")
    tempfile.tempdir, os.environ["TMPDIR"] = folder, folder
    try:
        yield folder
    finally:
        tempfile.tempdir = saved[0]
        if saved[1] is None:
            os.environ.pop("TMPDIR", None)
        else:
            os.environ["TMPDIR"] = saved[1]
        if watcher is None:
            shutil.rmtree(folder, ignore_errors=True)
        else:
            os.close(write_end)
            os.waitpid(watcher, 0)  # it removes the folder now: every write end is closed


def _remove_when_closed(read_end: int, folder: str) -> None:
    """The watcher of :func:`private_temp_folder` (in the forked process): wait until every write end
    of the pipe is closed, remove ``folder``, exit. Holds no other file of the command."""
    try:
        with contextlib.suppress(ValueError):  # forked by a thread other than the main one
            for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
                signal.signal(signum, signal.SIG_IGN)
        devnull = os.open(os.devnull, os.O_RDWR)
        for fd in (0, 1, 2):
            os.dup2(devnull, fd)
        os.closerange(3, read_end)
        os.closerange(read_end + 1, os.sysconf("SC_OPEN_MAX") if hasattr(os, "sysconf") else 65536)
        while os.read(read_end, 4096):
            pass
        shutil.rmtree(folder, ignore_errors=True)
    finally:
        os._exit(0)
