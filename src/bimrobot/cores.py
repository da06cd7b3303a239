"""How many cores this process may use, and whether work can be spread over forked processes.

Shared by the IFC reader (geometry on every core) and the package writer (models on every core).
"""

from __future__ import annotations

import contextlib
import gc
import multiprocessing
import os
import sys


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
