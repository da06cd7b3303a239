"""The bounds every schedule reader checks (CSV, Microsoft Project XML, IFC): file size, rows, activities
per component, times (seconds) and coordinates (metres), and which ids a schedule file may hold.
"""

from __future__ import annotations

import os
from pathlib import Path

from bimrobot.core.errors import InputError

#: Slack allowed when comparing times (s): CSV floats are printed with limited precision.
TIME_TOLERANCE_S = 1e-6
#: Largest coordinate of a target position (m): georeferenced site coordinates (UTM northings reach
#: 1e7 m) fit, a number beyond any site does not.
MAX_COORDINATE_M = 1e7

#: Limits checked before and while a schedule is read, so that no file makes a command run for hours or
#: take more than 2 GB of memory: (environment variable that raises it, default). Rows: the largest
#: real schedule has 14.5k rows (3 per component of a 4.8k-component model); 200k rows of 110 bytes
#: peak at 0.25 GB while read, 200k rows of 1.2 kB (the 256 MB allowed) at 0.42 GB. Megabytes: 256 MB
#: of CSV is over 1 million rows of the usual 200 bytes each; an MS Project XML file spends 1 to 3 kB on
#: a task (its tags are not kept). Activities per component: a transport, a position and one assemble
#: per connection node; a component joined at 1,000 nodes is no building element.
LIMITS = {
    "rows": ("BIMROBOT_SCHEDULE_MAX_ROWS", 200_000),
    "csv_mb": ("BIMROBOT_SCHEDULE_MAX_MB", 256),
    "xml_mb": ("BIMROBOT_MSPROJECT_MAX_MB", 1024),
    "per_component": ("BIMROBOT_SCHEDULE_MAX_PER_COMPONENT", 1_000),
}


def limit(name: str) -> int:
    """The limit ``name`` of :data:`LIMITS`: its environment variable when set to a positive whole
    number (an InputError otherwise), else the default."""
    variable, default = LIMITS[name]
    text = os.environ.get(variable, "").strip()
    if not text:
        return default
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise InputError(f"environment variable {variable}={text!r} must be a whole number >= 1 (default {default})")
    return value


def check_file_size(path: Path, name: str, what: str) -> None:
    """Refuse ``path`` when it is larger than the limit ``name`` (megabytes) before reading any of it."""
    try:
        size = path.stat().st_size
    except OSError:
        return  # not there or unreadable: the reader says so in its own words
    most = limit(name)
    if size > most * 1_000_000:
        variable = LIMITS[name][0]
        raise InputError(f"the schedule {path} is {size / 1e6:,.0f} MB, more than the {most:,} MB a {what} may have; "
                         f"split it, or raise the limit with the environment variable {variable}")


def too_many(where: str, subject: str, name: str, noun: str = "") -> InputError:
    """The one-sentence error for a schedule over the count limit ``name`` (``rows`` or
    ``per_component``): ``subject`` says what has too many (e.g. ``the schedule has``), ``noun`` what
    they are (rows or activities by default)."""
    variable = LIMITS[name][0]
    noun = noun or ("rows" if name == "rows" else "activities")
    return InputError(f"{where}: {subject} more than {limit(name):,} {noun}, the limit; split the schedule, or "
                      f"raise the limit with the environment variable {variable}")


def id_problem(text: str, *, spaces: bool) -> str | None:
    """What makes ``text`` unusable as an id in a schedule file, or None: control characters (a line
    break, a tab, ...) never; white space only where ``spaces`` is True (names, not ids lists)."""
    if not text.isprintable():
        return "contains a control character"
    if not spaces and any(c.isspace() for c in text):
        return "contains white space"
    return None
