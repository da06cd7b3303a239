"""How a command stops: SIGINT (Ctrl-C), SIGTERM and SIGHUP unwind it as Ctrl-C's KeyboardInterrupt does.

While :func:`stop_signals_unwind` holds, the three signals raise :class:`Stopped`, so every ``finally``
and context manager runs (children stopped, temporary files removed, resumable work kept) however a
command is stopped. ``bimrobot.cli.main`` holds it for every command; long-lived servers (``replay
--serve``) hold it too when called outside a command. The exit status of a stopped command is
128 + the signal's number (:func:`stopped_status`).
"""

from __future__ import annotations

import _thread
import contextlib
import functools
import signal
import sys
import threading
import weakref


class Stopped(KeyboardInterrupt):
    """SIGINT (Ctrl-C), SIGTERM or SIGHUP, raised as Ctrl-C's KeyboardInterrupt is, so that a command
    stopped by a terminal, ``kill`` or ``timeout`` unwinds the same way: every ``finally`` and context
    manager runs (children stopped, temporary files removed, resumable work kept) before it exits."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = int(signum)
        self.seen = {"by_main": False}  # set once main (or the unraisable hook) has taken it


STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
"""Signals that stop a command (:class:`Stopped`); exit status 128 + the signal's number."""

IMPORT_RETRY_S = 0.05
"""A stop that comes while a module is being imported is delivered again this much later (s)."""


def _stop(signum: int, frame) -> None:
    """The handler of :data:`STOP_SIGNALS` while a command runs: raise :class:`Stopped`, so that it
    cannot be lost (issue 35: Ctrl-C and SIGTERM were ignored a few times in 20):

    * not inside an import: several libraries import their optional parts under ``except
      BaseException`` (trimesh imports SciPy so, for seconds), which would discard it and leave the
      module half made; the signal is delivered again once the import is over;
    * should other code still discard it (a broad ``except``, a finalizer), it is delivered again as
      soon as Python frees it (:func:`_again_if_discarded`).
    """
    if _importing(frame):
        retry = threading.Timer(IMPORT_RETRY_S, _thread.interrupt_main, (signum,))
        retry.daemon = True
        retry.start()
        return
    stop = Stopped(signum)
    weakref.finalize(stop, _again_if_discarded, signum, stop.seen).atexit = False
    try:
        raise stop
    finally:
        del stop  # this frame is in its traceback: no cycle, so a discarded stop is freed at once


def _importing(frame) -> bool:
    """Whether ``frame`` runs inside an import (a frame of importlib's bootstrap is below it)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


def _again_if_discarded(signum: int, seen: dict) -> None:
    """A :class:`Stopped` was freed before main saw it: some code caught it and went on. Deliver the
    signal again, from another thread (this runs wherever Python freed it, where raising is lost)."""
    if not seen["by_main"]:
        _thread.start_new_thread(_thread.interrupt_main, (signum,))


@contextlib.contextmanager
def stop_signals_unwind():
    """While a command runs, SIGINT, SIGTERM and SIGHUP raise :class:`Stopped` (:func:`_stop`; in the
    main thread only, where Python delivers signals). A signal the caller ignores (``nohup``, a
    background job's SIGINT) stays ignored; the previous handlers are back afterwards (main may be
    called in-process, by a test)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}
    for signum, handler in previous.items():
        if handler is not signal.SIG_IGN:
            signal.signal(signum, _stop)
    hook = sys.unraisablehook
    sys.unraisablehook = functools.partial(_redeliver, hook)
    try:
        yield
    finally:
        sys.unraisablehook = hook
        for signum, handler in previous.items():
            signal.signal(signum, handler if handler is not None else signal.SIG_DFL)


def _redeliver(hook, unraisable) -> None:
    """``sys.unraisablehook`` while a command runs: a stop raised inside a finalizer or a weakref
    callback cannot propagate (Python only prints "Exception ignored in ..." and goes on; issue 35:
    a Ctrl-C landed in a ``WeakKeyDictionary`` callback and ``simulate`` finished, exit 0). The signal
    is delivered again, from another thread once this hook has returned (raised in the hook it would be
    discarded again). Anything else goes to the previous hook."""
    stop = unraisable.exc_value
    if isinstance(stop, KeyboardInterrupt):
        if isinstance(stop, Stopped):
            stop.seen["by_main"] = True  # delivered again here, not by its finalizer as well
        _thread.start_new_thread(_thread.interrupt_main, (getattr(stop, "signum", signal.SIGINT),))
    else:
        hook(unraisable)


def stopped_status(stop: KeyboardInterrupt, command: str | None) -> int:
    """Main's exit status for a command stopped by ``stop`` (128 + the signal's number), said in one line
    unless it was Ctrl-C (the user knows)."""
    signum = getattr(stop, "signum", signal.SIGINT)
    if isinstance(stop, Stopped):
        stop.seen["by_main"] = True
    if signum != signal.SIGINT:
        print(f"bimrobot{f' {command}' if command else ''}: stopped by {signal.Signals(signum).name}", file=sys.stderr)
    return 128 + signum


def stop_behind(error: BaseException) -> KeyboardInterrupt | None:
    """The stop that caused ``error``, or None. Issue 35: a Ctrl-C that lands while IfcOpenShell's SWIG
    code calls back into Python leaves it set there, and Python reports "SystemError: <built-in function
    entity_instance__get_inverse> returned a result with an exception set", the stop as its cause (1 of
    10 Ctrl-C into `simulate MULTICOM-Prefab.ifc`: exit 1 and a traceback)."""
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, KeyboardInterrupt):
            return error
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return None
