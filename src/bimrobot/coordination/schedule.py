"""The schedule CSV (docs/conventions.md): one row per construction activity, ifc4d-style columns.

Times are seconds from the start of the build, targets metres in the model's world frame.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from bimrobot.errors import InputError
from bimrobot.io import atomic_output_file

COLUMNS = (
    "Identification", "Name", "PredefinedType", "Activity", "GlobalId", "Robot", "Start", "Finish",
    "Duration", "Predecessors", "TargetX", "TargetY", "TargetZ", "Storey",
)
PREDEFINED_TYPE = {"transport": "LOGISTIC", "position": "INSTALLATION", "assemble": "CONSTRUCTION"}


def schedule_rows(activities) -> list[dict]:
    """CSV rows (dicts keyed by :data:`COLUMNS`) for the completed activities, by start time."""
    rows = []
    for a in sorted((a for a in activities if not a.aborted), key=lambda a: (a.start, a.id)):
        start, finish = round(a.start, 3), round(a.finish, 3)  # Duration = Finish - Start as written
        rows.append({
            "Identification": a.id,
            "Name": a.name,
            "PredefinedType": PREDEFINED_TYPE[a.activity],
            "Activity": a.activity,
            "GlobalId": a.global_id,
            "Robot": a.robot,
            "Start": f"{start:.3f}",
            "Finish": f"{finish:.3f}",
            "Duration": f"{finish - start:.3f}",
            "Predecessors": " ".join(a.predecessors),
            "TargetX": f"{a.target[0]:.4f}",
            "TargetY": f"{a.target[1]:.4f}",
            "TargetZ": f"{a.target[2]:.4f}",
            "Storey": a.storey,
        })
    return rows


def is_schedule_csv(path: str | Path) -> bool:
    """Whether ``path`` is a schedule CSV bimrobot wrote: its first line is exactly the :data:`COLUMNS`
    header. A CSV cannot carry a signature comment every reader skips, so this is the output policy's
    recogniser for :func:`write_schedule_csv`."""
    try:
        with open(path, encoding="utf-8-sig", newline="") as handle:
            first = handle.readline(4096)
    except (OSError, UnicodeDecodeError):
        return False
    return first.rstrip("\r\n") == ",".join(COLUMNS)


def write_schedule_csv(activities, path: str | Path, inputs=(), option: str = "-o") -> Path:
    """Write the schedule atomically under the output policy (:mod:`bimrobot.io`): an existing file
    is replaced only when it is a schedule CSV (:func:`is_schedule_csv`); returns the path."""
    with atomic_output_file(path, inputs=inputs, option=option, recognise=is_schedule_csv) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as handle:
            writer = csv.DictWriter(handle, fieldnames=COLUMNS)
            writer.writeheader()
            writer.writerows(schedule_rows(activities))
    return Path(path)


def load_schedule_csv(path: str | Path) -> list[dict]:
    """Read a schedule CSV back, with numbers as floats and Predecessors as a list; validated.

    Raises InputError naming the file, line and column of the first problem.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"schedule {path} does not exist")
    with open(path, newline="") as handle:
        reader = csv.DictReader(handle)
        missing = [c for c in COLUMNS if c not in (reader.fieldnames or [])]
        if missing:
            raise InputError(f"{path}: missing column '{missing[0]}' (expected {', '.join(COLUMNS)})")
        rows, ids = [], set()
        for line, raw in enumerate(reader, start=2):
            row = dict(raw)
            for column in ("Start", "Finish", "Duration", "TargetX", "TargetY", "TargetZ"):
                try:
                    row[column] = float(raw[column])
                except (TypeError, ValueError):
                    raise InputError(f"{path} line {line}: column {column} must be a number, got {raw[column]!r}") from None
                if not math.isfinite(row[column]):
                    raise InputError(f"{path} line {line}: column {column} must be finite, got {raw[column]!r}")
            if row["Finish"] < row["Start"]:
                raise InputError(f"{path} line {line}: Finish {row['Finish']} is before Start {row['Start']}")
            if raw["Activity"] not in PREDEFINED_TYPE:
                raise InputError(f"{path} line {line}: column Activity must be transport, position or assemble, got {raw['Activity']!r}")
            if raw["Identification"] in ids:
                raise InputError(f"{path} line {line}: Identification {raw['Identification']!r} is used twice")
            ids.add(raw["Identification"])
            row["Predecessors"] = raw["Predecessors"].split() if raw["Predecessors"] else []
            rows.append(row)
    if not rows:
        raise InputError(f"{path}: the schedule has a header but no activity")
    for row in rows:
        unknown = [p for p in row["Predecessors"] if p not in ids]
        if unknown:
            raise InputError(f"{path}: activity {row['Identification']} names unknown predecessor {unknown[0]!r}")
    return rows
