"""Stopping CP-SAT's searches with the command (:mod:`bimrobot.planning.optimal`): every solve passes
:func:`solve_stoppably`, so that Ctrl-C and SIGTERM end it at once, in the main thread or in the
threads that solve floors side by side."""

from __future__ import annotations

import threading

#: the CP-SAT solvers searching outside the main thread (the floors solved side by side,
#: :func:`bimrobot.planning.optimal._solve_apart`), so that a stop ends them too; ``_SIDE_STOP`` set:
#: a stop came, and a solve not yet begun ends at once
_SIDE_SOLVERS: set = set()
_SIDE_STOP = threading.Event()
_SIDE_LOCK = threading.Lock()


def stop_side_solves() -> None:
    """End every search running outside the main thread, and those about to begin."""
    with _SIDE_LOCK:
        _SIDE_STOP.set()
        for solver in _SIDE_SOLVERS:
            solver.StopSearch()


def solve_stoppably(solver, model) -> int:
    """``solver.Solve(model)``, stopped by the command's stop signals. CP-SAT's own SIGINT handler is
    off: it ended the search and let the command finish, exit 0, with its output, on Ctrl-C. In the main
    thread the solve runs in a helper thread, so that Python's handlers run at once (a SIGTERM waited up to
    the time limit for the solve, 39 s on GEELEN): the stop they raise here stops the search, waits for
    it, and goes on up. Elsewhere (the floors solved side by side) it is registered, so that a stop in
    the main thread ends it too (:func:`stop_side_solves`)."""
    solver.parameters.catch_sigint_signal = False
    if threading.current_thread() is not threading.main_thread():
        with _SIDE_LOCK:
            if _SIDE_STOP.is_set():  # stopped before this solve began
                solver.parameters.max_time_in_seconds = 0.0
            _SIDE_SOLVERS.add(solver)
        try:
            return solver.Solve(model)
        finally:
            with _SIDE_LOCK:
                _SIDE_SOLVERS.discard(solver)
    answer: list[int] = []
    worker = threading.Thread(target=lambda: answer.append(solver.Solve(model)), name="cp-sat", daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.05)  # Python runs its signal handlers between these waits
    finally:
        if worker.is_alive():  # a stop was raised: end the search before going on up
            solver.StopSearch()
            worker.join()
    return answer[0]


def allow_side_solves() -> None:
    """Let solves outside the main thread run again (before a new round of them)."""
    _SIDE_STOP.clear()
