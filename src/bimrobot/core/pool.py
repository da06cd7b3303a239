"""Per-model work on every core: a forked process pool that shares the caller's data without pickling it.

Writing a package is per-model work (convex hulls, mass integrals, COLLADA/STL/SDF text, a few files
per model) in pure Python and numpy, so threads would serialise on the GIL. The pool is forked
(Linux), so the workers inherit the element meshes and bodies the parent already holds: a task is a
list of indices into :data:`shared` and only the small results (mass properties, triangle counts)
travel back. Where ``fork`` is not available, or the job is small, the same function runs in-process.
"""

from __future__ import annotations

import functools
import multiprocessing
import os
from collections.abc import Callable, Iterable, Iterator

from bimrobot.core import written
from bimrobot.core.cores import bind_to_parent, can_fork, cores, frozen_heap

shared: dict = {}
"""What the tasks read: set by the parent before :func:`run` forks; workers see a copy-on-write view."""

MIN_TASKS_FOR_POOL = 2
"""Fewer tasks than this run in-process."""


class Tasks:
    """Run ``function`` over ``tasks`` on ``workers`` forked processes, started at once in the background;
    :meth:`results` yields each task's result in completion order. With one worker, or fewer than
    :data:`MIN_TASKS_FOR_POOL` tasks, or ``parallel=False``, the tasks run in-process when
    :meth:`results` is iterated. The digests of the files a worker's task wrote through
    :mod:`bimrobot.core.written` come back with its result (the output marker then need not read them).
    Use as a context manager: leaving it stops the workers (also when an error leaves it)."""

    def __init__(self, function: Callable, tasks: Iterable, workers: int | None = None, parallel: bool = True):
        self._function = function
        self._tasks = list(tasks)
        workers = min(workers or cores(), len(self._tasks))
        self._pool = None
        self._pending: Iterator | None = None
        if parallel and workers > 1 and len(self._tasks) >= MIN_TASKS_FOR_POOL and can_fork():
            with frozen_heap():  # the workers' collections do not copy every page they inherit
                # the workers die with this process (bimrobot.core.cores.bind_to_parent), however it ends
                self._pool = multiprocessing.get_context("fork").Pool(workers, bind_to_parent, (os.getpid(),))
            self._pending = self._pool.imap_unordered(functools.partial(_with_notes, function), self._tasks)

    @property
    def parallel(self) -> bool:
        return self._pool is not None

    def results(self) -> Iterator:
        if self._pending is not None:
            for result, notes in self._pending:
                written.add_notes(notes)
                yield result
        else:
            yield from map(self._function, self._tasks)

    def __enter__(self) -> "Tasks":
        return self

    def __exit__(self, kind, error, trace) -> None:
        if self._pool is None:
            return
        # Every result has been read (or an error ends the job): stop the workers at once (close()
        # would wait for the pool's housekeeping thread, which wakes only every 0.1 s).
        self._pool.terminate()
        self._pool.join()


def _with_notes(function: Callable, task) -> tuple:
    """In a worker: ``function(task)`` and the notes of the files it wrote (:func:`bimrobot.core.written.take_notes`)."""
    result = function(task)
    return result, written.take_notes()


def balanced_chunks(groups: list[list[int]], costs: list[float], count: int) -> list[list[int]]:
    """Split ``groups`` of indices (kept whole) into about ``count`` chunks of similar total cost,
    largest groups first (so the last chunks to finish are small)."""
    order = sorted(range(len(groups)), key=lambda g: -costs[g])
    chunks: list[list[int]] = [[] for _ in range(max(1, min(count, len(groups))))]
    loads = [0.0] * len(chunks)
    for g in order:
        target = loads.index(min(loads))
        chunks[target].extend(groups[g])
        loads[target] += costs[g]
    return [chunk for chunk in chunks if chunk]
