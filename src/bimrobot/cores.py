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
import signal
import sys
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


def _watch_parent(parent: int) -> None:
    """The fallback of :func:`bind_to_parent`: end this process once ``parent`` is no longer its parent."""
    while os.getppid() == parent:
        threading.Event().wait(PARENT_WATCH_S)
    os._exit(1)
