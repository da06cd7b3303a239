"""Progress bars for long work (graph building), on stderr, through tqdm.

A bar is shown only when stderr is a terminal and the work has lasted longer than :data:`DELAY_S`:
short runs, pipes, log files and the test suite see nothing.
"""

from __future__ import annotations

import sys

from tqdm import tqdm

#: Seconds of work before a bar appears (short work stays silent).
DELAY_S = 1.0


def progress_bar(total: int | None, desc: str, unit: str = "item") -> tqdm:
    """A tqdm bar on stderr counting ``total`` units of ``desc`` (``bar.update(n)``; use as a context
    manager). Disabled when stderr is not a terminal; appears after :data:`DELAY_S` seconds."""
    stream = sys.stderr
    interactive = bool(getattr(stream, "isatty", lambda: False)())
    return tqdm(total=total, desc=desc, unit=unit, file=stream, delay=DELAY_S, disable=not interactive,
                mininterval=0.5, leave=False, dynamic_ncols=True)
