"""One function called in a forked process, its outcome sent back pickled.

Shared by the IFC reader's geometry processes (:mod:`bimrobot.bim.reader`), ``convert``'s read of the
model beside the import of its writer (:mod:`bimrobot.bim.forked_read`) and the MuJoCo scene's convex
decomposition under a CPU budget (:mod:`bimrobot.export.mujoco.collision`). The child inherits what this
process holds (a parsed file, say: nothing is pickled on the way in), dies with this process
(:func:`bimrobot.core.cores.bind_to_parent`), and sends back ("ok", the result) or ("error", the
exception); an exception that cannot be pickled still arrives, as its text. A child that dies without a
word (a crash in a C++ library) is reported by the caller's ``died``.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
from typing import Any, Callable


class Forked:
    """``function(*args)`` running in a forked process. ``others``: the read ends of earlier children's
    pipes, which the child closes (only this process may read them: a child whose parent is gone then
    fails to write instead of blocking forever on a pipe it holds open itself). ``daemon``: False for a
    child that forks processes of its own (multiprocessing forbids it to a daemonic one). Call
    :meth:`stop` when done (a ``finally``), whatever happened."""

    def __init__(self, function: Callable, args: tuple = (), others: tuple = (), daemon: bool = True):
        context = multiprocessing.get_context("fork")
        self.receiving, sending = context.Pipe(duplex=False)
        self.process = context.Process(target=_call_in_child, daemon=daemon,
                                       args=(function, args, sending, os.getpid(), [*others, self.receiving]))
        self.process.start()
        sending.close()

    def outcome(self, died: Callable[[int | None], Exception], timeout_s: float | None = None) -> Any:
        """Wait for the function's result and return it; raise its exception here; raise
        ``died(exit code)`` when the process ended without sending anything, and ``died(None)`` when
        it sent nothing within ``timeout_s`` wall seconds (None: wait as long as it runs)."""
        if timeout_s is not None and not self.receiving.poll(timeout_s):
            raise died(None)
        try:
            status, payload = pickle.loads(self.receiving.recv_bytes())
        except EOFError:
            self.process.join()
            raise died(self.process.exitcode) from None
        if status == "error":
            raise payload
        return payload

    def stop(self) -> None:
        """Close the pipe and end the process if it still runs."""
        self.receiving.close()
        if self.process.is_alive():
            self.process.terminate()
        self.process.join()


def _call_in_child(function: Callable, args: tuple, sending, parent: int, read_ends: list) -> None:
    """The child's side of :class:`Forked`: call, then send the outcome pickled."""
    from bimrobot.core.cores import bind_to_parent

    bind_to_parent(parent)
    for end in read_ends:
        end.close()
    try:
        message = ("ok", function(*args))
    except Exception as exc:  # handed to the parent, which raises it
        message = ("error", exc)
    try:
        try:
            payload = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:  # an unpicklable exception still reaches the parent, as its text
            payload = pickle.dumps(("error", RuntimeError(f"forked process failed: {exc}")))
        sending.send_bytes(payload)
    except OSError:  # the parent is gone (it stopped, or was stopped): nobody is left to tell
        pass
    finally:
        sending.close()
