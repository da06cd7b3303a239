"""Construction schedules: one :class:`Activity` per row, read from the schedule CSV or an IFC work schedule.

Times are seconds from the start of the build (float); target positions are metres in the world frame
(z up). An activity's ``predecessors`` must finish before it starts (FINISH_START). The CSV format is
fixed in ``docs/conventions.md``; :func:`load_schedule_csv` validates it and names the file and line of
the first problem it finds (:class:`bimrobot.core.errors.InputError`).
"""

from __future__ import annotations

import csv
import itertools
import logging
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Iterator

from bimrobot.core.config import MAX_SECONDS
from bimrobot.core.errors import InputError
from bimrobot.core.io import atomic_output_file
from bimrobot.core.tasks import TASKS, Activity, Task
from bimrobot.bim.components import is_component
from bimrobot.schedule.limits import (
    MAX_COORDINATE_M,
    TIME_TOLERANCE_S,
    check_file_size,
    id_problem,
    limit,
    too_many,
)
from bimrobot.schedule.schedule import Schedule, find_cycle
from bimrobot.schedule.task_rows import load_schedule_ifc

if TYPE_CHECKING:  # pragma: no cover
    from bimrobot.bim.model import BuildingModel

log = logging.getLogger(__name__)

#: Column order of the schedule CSV (``docs/conventions.md``). This module is the one reader and writer
#: of that file; ``bimrobot.coordination.schedule`` writes the simulation's activities through it.
COLUMNS = (
    "Identification", "Name", "PredefinedType", "Activity", "GlobalId", "Robot", "Start", "Finish",
    "Duration", "Predecessors", "TargetX", "TargetY", "TargetZ", "Storey",
    "FromX", "FromY", "FromZ", "ToX", "ToY", "ToZ", "Nodes", "Points",
)  # fmt: skip
#: The work columns (optional when reading): where the robot begins the work (``From``: the pick-up on
#: the yard for a transport, the connection node, joint or component it works at otherwise) and where it
#: ends it (``To``: the drop-off of a transport; the work point otherwise), metres, model frame; the
#: connection nodes it positions and the assembly points it makes. They are what the one time model
#: (:mod:`bimrobot.sco.timing`) needs, so that RCAN executes a schedule in the time it was planned in.
WORK_COLUMNS = ("FromX", "FromY", "FromZ", "ToX", "ToY", "ToZ", "Nodes", "Points")
CSV_COLUMNS = COLUMNS
REQUIRED_COLUMNS = ("Identification", "Activity", "GlobalId", "Start", "Finish")

#: The thesis' chapter-4 task decomposition (:class:`bimrobot.core.tasks.Task`), and the IfcTaskTypeEnum value
#: each one is written with (both ways), for callers that look them up by name.
PREDEFINED_TYPE = {task: task.ifc_task_type for task in TASKS}
ACTIVITY_TASK_TYPES = PREDEFINED_TYPE
TASK_TYPE_ACTIVITIES = {task.ifc_task_type: task for task in TASKS}
IFC_TASK_TYPES = frozenset(
    {
        "ATTENDANCE", "CONSTRUCTION", "DEMOLITION", "DISMANTLE", "DISPOSAL", "ELECTRICAL", "INSTALLATION",
        "LOGISTIC", "MAINTENANCE", "MECHANICAL", "MOVE", "OPERATION", "REMOVAL", "RENOVATION", "SAFETY",
        "SHUTDOWN", "STARTUP", "TESTING", "TROUBLESHOOTING", "USERDEFINED", "NOTDEFINED", "ADJUSTMENT",
        "CALIBRATION", "EMERGENCY", "INSPECTION",
    }
)  # fmt: skip


# --------------------------------------------------------------------------------------------- CSV


def is_schedule_csv(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a schedule CSV bimrobot wrote: its first line is exactly the :data:`COLUMNS`
    header. A CSV cannot carry a signature comment every reader skips, so this is the output policy's
    recogniser (:mod:`bimrobot.core.io`) for :func:`write_schedule_csv`."""
    try:
        with open(path, encoding="utf-8-sig", newline="") as handle:
            first = handle.readline(4096)
    except (OSError, UnicodeDecodeError):
        return False
    return first.rstrip("\r\n") == ",".join(COLUMNS)


class _Row:
    """One CSV row with its file and line, for error messages."""

    def __init__(self, values: dict, path: Path, line: int):
        self.values, self.path, self.line = values, path, line

    def where(self) -> str:
        return f"{self.path}, line {self.line}"

    def text(self, column: str) -> str:
        return (self.values.get(column) or "").strip()

    def ident(self, column: str, spaces: bool = False) -> str:
        """The column as an id: no control character, no white space inside unless ``spaces``."""
        value = self.text(column)
        problem = id_problem(value, spaces=spaces)
        if problem:
            raise InputError(f"{self.where()}: {column} {_shown(value)} {problem} (ids are single printable words)")
        return value

    def seconds(self, column: str) -> float:
        """The column as seconds: a finite number in [0, MAX_SECONDS] (no NaN, inf or 1e308)."""
        raw = self.text(column)
        try:
            value = float(raw)
        except ValueError:
            raise InputError(f"{self.where()}: {column} {_shown(raw)} is not a number of seconds") from None
        if not (math.isfinite(value) and 0 <= value <= MAX_SECONDS):
            raise InputError(
                f"{self.where()}: {column} {_shown(raw)} must be a finite number of seconds >= 0 and <= {MAX_SECONDS:g}"
            )
        return value

    def count(self, column: str) -> int | None:
        """The column as a whole number in [0, 1e6] (nodes, points), or None when empty or absent."""
        raw = self.text(column)
        if not raw:
            return None
        try:
            value = int(raw)
        except ValueError:
            value = -1
        if not 0 <= value <= 1_000_000:
            raise InputError(f"{self.where()}: {column} {_shown(raw)} must be a whole number from 0 to 1,000,000")
        return value

    def target(self) -> tuple[float, float, float] | None:
        """(TargetX, TargetY, TargetZ) in metres, each finite and within MAX_COORDINATE_M, or None when all empty."""
        return self.xyz(("TargetX", "TargetY", "TargetZ"))

    def xyz(self, columns: tuple[str, str, str]) -> tuple[float, float, float] | None:
        """Three coordinate columns in metres, each finite and within MAX_COORDINATE_M, or None when all empty."""
        raw = [self.text(c) for c in columns]
        if not any(raw):
            return None
        xyz = []
        for column, text in zip(columns, raw):
            try:
                value = float(text)
            except ValueError:
                raise InputError(
                    f"{self.where()}: {column} {_shown(text)} is not a number of metres ({column[:-1]}X/Y/Z: three numbers, or all empty)"
                ) from None
            if not (math.isfinite(value) and abs(value) <= MAX_COORDINATE_M):
                raise InputError(
                    f"{self.where()}: {column} {_shown(text)} must be a finite number of metres within +-{MAX_COORDINATE_M:g}"
                )
            xyz.append(value)
        return tuple(xyz)  # type: ignore[return-value]


def _shown(text: str) -> str:
    """A cell for a message: quoted, control characters escaped, cut at 40 characters."""
    shown = text if len(text) <= 40 else text[:37] + "..."
    return repr(shown)


def _node_id_in(name: str, global_id: str) -> str | None:
    """The connection node id ``<relating>:<related>`` mentioned in an activity name, if any."""
    for token in name.replace(",", " ").split():
        left, sep, right = token.partition(":")
        if sep and left and right and global_id in (left, right):
            return token
    return None


def _activity_from_row(row: _Row) -> Activity:
    activity_id = row.ident("Identification")
    if not activity_id:
        raise InputError(f"{row.where()}: Identification is empty")
    try:
        kind = Task(row.text("Activity").lower())
    except ValueError:
        raise InputError(
            f"{row.where()}: column Activity must be transport, position or assemble, got {row.text('Activity')!r}"
        ) from None
    predefined = row.text("PredefinedType").upper() or kind.ifc_task_type
    if predefined not in IFC_TASK_TYPES:
        raise InputError(f"{row.where()}: PredefinedType {predefined!r} is not an IfcTaskTypeEnum value")
    global_id = row.ident("GlobalId")
    if not global_id:
        raise InputError(f"{row.where()}: GlobalId is empty")
    start, finish = row.seconds("Start"), row.seconds("Finish")
    if finish + TIME_TOLERANCE_S < start:
        raise InputError(f"{row.where()}: Finish {finish} s is before Start {start} s")
    if row.text("Duration"):
        duration = row.seconds("Duration")
        if abs(duration - (finish - start)) > max(1e-3, 1e-6 * finish):
            raise InputError(f"{row.where()}: Duration {duration} s is not Finish - Start = {finish - start} s")
    name = row.text("Name") or activity_id
    return Activity(
        id=activity_id,
        name=name,
        activity=kind,
        global_id=global_id,
        robot=row.ident("Robot", spaces=True) or None,
        start=start,
        finish=max(start, finish),
        predecessors=tuple(row.ident("Predecessors", spaces=True).split()),
        target=row.target(),
        storey=row.ident("Storey") or None,
        predefined_type=predefined,
        node_id=_node_id_in(name, global_id) if kind == Task.ASSEMBLE else None,
        work_from=row.xyz(("FromX", "FromY", "FromZ")),
        work_to=row.xyz(("ToX", "ToY", "ToZ")),
        nodes=row.count("Nodes"),
        points=row.count("Points"),
    )


def _open_schedule(path: Path):
    """The schedule CSV opened for reading (UTF-8, a BOM skipped, line ends kept for the csv module)."""
    try:
        if path.is_dir():
            raise IsADirectoryError
        return open(path, encoding="utf-8-sig", newline="")
    except IsADirectoryError:
        raise InputError(f"the schedule {path} is a folder, not a CSV file") from None
    except OSError as exc:
        raise InputError(f"cannot read the schedule {path}: {exc.strerror}") from None


def _rows(handle, path: Path) -> Iterator[tuple[int, list[str]]]:
    """(line, cells) of every CSV row after the leading ``#`` comment lines (schedule files written by
    bimrobot may open with a ``# written by bimrobot ...`` line), read line by line, never whole."""
    skipped, reader = 0, None
    try:
        first = handle.readline()
        while first and first.lstrip().startswith("#"):
            skipped += 1
            first = handle.readline()
        reader = csv.reader(itertools.chain([first], handle) if first else iter(()))
        begins = 1  # the line a row starts on (a quoted cell may hold line breaks)
        for cells in reader:
            yield begins + skipped, cells
            begins = reader.line_num + 1
    except csv.Error as exc:
        raise InputError(f"{path}, line {reader.line_num + skipped}: not a valid CSV row ({exc})") from None
    except UnicodeDecodeError:
        after = f" (after line {reader.line_num + skipped})" if reader is not None and reader.line_num else ""
        raise InputError(f"the schedule {path} is not a UTF-8 text file{after} (a CSV is expected, see docs/conventions.md)") from None


def load_schedule_csv(path: str | os.PathLike, model: BuildingModel | None = None) -> Schedule:
    """Read and validate a schedule CSV (format: ``docs/conventions.md``).

    With ``model``, every GlobalId (and Storey) must be an element (or an assembly) of it or a storey.
    Raises :class:`InputError` naming the file and line for: a missing or repeated column, a file
    without any activity, a row with more cells than the header, an empty or duplicate Identification,
    an id with a control character (or white space, in Identification and GlobalId), an unknown
    Activity or PredefinedType, a time that is not a finite number of seconds in [0, 1e9], a target
    that is not a finite coordinate, Finish before Start, a Duration that is not Finish - Start, an
    unknown GlobalId/Storey/predecessor, an activity that starts before a predecessor finishes, and a
    cycle in the predecessors. The file is read row by row and refused, before it is read, when
    larger than :func:`limit` ``("csv_mb")`` MB, and as soon as it has more than ``limit("rows")``
    rows or a component has more than ``limit("per_component")`` activities.
    """
    from bimrobot.sco.build import gc_paused

    path = Path(path)
    check_file_size(path, "csv_mb", "schedule CSV")
    with gc_paused():  # tens of thousands of long-lived rows: see Schedule.topological_order
        with _open_schedule(path) as handle:
            return _load_schedule_csv(handle, path, model)


def _header(rows: Iterator[tuple[int, list[str]]], path: Path) -> list[str]:
    """The header row's column names, checked: the required columns, each name once."""
    line, header = next(rows, (1, []))
    header = [name.strip() for name in header]
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise InputError(
            f"{path}, line {line}: missing column(s) {', '.join(missing)} (a bimrobot schedule CSV "
            "is expected, see docs/conventions.md)"
        )
    repeated = sorted({name for name in header if name and header.count(name) > 1})
    if repeated:
        raise InputError(f"{path}, line {line}: column {repeated[0]!r} appears more than once in the header")
    return header


def _load_schedule_csv(handle, path: Path, model: BuildingModel | None) -> Schedule:
    rows = _rows(handle, path)
    header = _header(rows, path)
    most_rows, most_each = limit("rows"), limit("per_component")
    activities: list[Activity] = []
    lines: dict[str, int] = {}  # activity id -> its line in the file
    per_component: dict[str, int] = {}
    for line, cells in rows:
        if not any(cell.strip() for cell in cells):
            continue  # blank line
        if len(cells) > len(header):
            raise InputError(f"{path}, line {line}: {len(cells)} cells, but the header has {len(header)} columns "
                             "(a comma too many, or a cell with a comma that is not quoted)")
        row = _Row(dict(zip(header, cells)), path, line)
        activity = _activity_from_row(row)
        if activity.id in lines:
            raise InputError(f"{row.where()}: Identification {activity.id!r} is already used on line {lines[activity.id]}")
        if len(activities) == most_rows:
            raise too_many(row.where(), "the schedule has", "rows")
        count = per_component[activity.global_id] = per_component.get(activity.global_id, 0) + 1
        if count > most_each:
            raise too_many(row.where(), f"component {activity.global_id!r} has", "per_component")
        lines[activity.id] = row.line
        activities.append(activity)
    if not activities:
        raise InputError(f"the schedule {path} has a header but no activity: nothing to build")
    schedule = Schedule(activities, source=path)
    _check_references(schedule, lines, model)
    _check_sequence(schedule, lines)
    return schedule


def _check_references(schedule: Schedule, lines: dict[str, int], model: BuildingModel | None) -> None:
    known_storeys = {s.global_id for s in model.storeys} if model is not None else None
    for activity in schedule.activities:
        where = f"{schedule.source}, line {lines[activity.id]}"
        if model is not None and not is_component(model, activity.global_id):
            raise InputError(f"{where}: GlobalId {activity.global_id!r} is not an element of {model.source or 'the model'}"
                             " (or it was left out by --include/--exclude)")
        if known_storeys is not None and activity.storey and activity.storey not in known_storeys:
            raise InputError(f"{where}: Storey {activity.storey!r} is not a storey of {model.source or 'the model'}")
        for predecessor in activity.predecessors:
            if predecessor not in schedule:
                raise InputError(f"{where}: predecessor {predecessor!r} of {activity.id} is not an activity in the file")
            before = schedule[predecessor]
            if predecessor == activity.id:
                raise InputError(f"{where}: activity {activity.id} lists itself as a predecessor")
            if before.finish > activity.start + TIME_TOLERANCE_S:
                raise InputError(
                    f"{where}: {activity.id} starts at {activity.start} s, before its predecessor "
                    f"{predecessor} finishes at {before.finish} s"
                )


def _check_sequence(schedule: Schedule, lines: dict[str, int]) -> None:
    cycle = find_cycle({a.id: a.predecessors for a in schedule.activities})
    if cycle:
        raise InputError(
            f"{schedule.source}, line {lines[cycle[0]]}: the predecessors form a cycle {' -> '.join(cycle)}"
        )


def load_schedule(path: str | os.PathLike, model: BuildingModel | None = None) -> Schedule:
    """A schedule by its file type: the schedule CSV (``.csv``), a Microsoft Project XML file
    (``.xml``, :mod:`bimrobot.schedule.msproject`) or the IfcWorkSchedule of an IFC file (``.ifc``, ``.ifczip``)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".xml":
        from bimrobot.schedule.msproject import load_schedule_msproject

        return load_schedule_msproject(path, model)
    if suffix in (".ifc", ".ifczip"):
        return load_schedule_ifc(path, model)
    return load_schedule_csv(path, model)


def write_schedule_csv(
    schedule: Schedule | Iterable[Activity], path: str | os.PathLike, inputs: Iterable = (), option: str = "-o"
) -> Path:
    """Write activities as a schedule CSV (``docs/conventions.md``), atomically; returns the path.

    The output policy applies (:mod:`bimrobot.core.io`): an existing file is replaced only when it is a
    schedule CSV (:func:`is_schedule_csv`)."""
    path = Path(path)
    with atomic_output_file(path, inputs=inputs, option=option, recognise=is_schedule_csv) as tmp:
        with tmp.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.DictWriter(handle, fieldnames=CSV_COLUMNS)
            writer.writeheader()
            for a in schedule:
                _check_writable(a)
                x, y, z = a.target if a.target else ("", "", "")
                fx, fy, fz = a.work_from if a.work_from else ("", "", "")
                tx, ty, tz = a.work_to if a.work_to else ("", "", "")
                writer.writerow(
                    {
                        "Identification": a.id,
                        "Name": a.name,
                        "PredefinedType": a.predefined_type or ACTIVITY_TASK_TYPES.get(a.activity, "NOTDEFINED"),
                        "Activity": a.activity,
                        "GlobalId": a.global_id or "",
                        "Robot": a.robot or "",
                        "Start": repr(float(a.start)),
                        "Finish": repr(float(a.finish)),
                        "Duration": repr(float(a.duration)),
                        "Predecessors": " ".join(a.predecessors),
                        "TargetX": x,
                        "TargetY": y,
                        "TargetZ": z,
                        "Storey": a.storey or "",
                        "FromX": fx,
                        "FromY": fy,
                        "FromZ": fz,
                        "ToX": tx,
                        "ToY": ty,
                        "ToZ": tz,
                        "Nodes": "" if a.nodes is None else a.nodes,
                        "Points": "" if a.points is None else a.points,
                    }
                )
    return path


def _check_writable(a: Activity) -> None:
    """Refuse (InputError) to write an activity :func:`load_schedule_csv` would refuse to read back:
    an id with a control character or white space, a time outside [0, 1e9] s, a target beyond 1e7 m."""
    texts = {"Identification": (a.id, False), "GlobalId": (a.global_id or "", False), "Robot": (a.robot or "", True),
             "Storey": (a.storey or "", False), **{"Predecessors": (p, False) for p in a.predecessors}}
    for column, (text, spaces) in texts.items():
        problem = id_problem(text, spaces=spaces)
        if problem:
            raise InputError(f"activity {_shown(a.id)}: its {column} {_shown(text)} {problem}, so it cannot be written "
                             "to a schedule CSV (ids are single printable words)")
    for column, value in (("Start", a.start), ("Finish", a.finish)):
        if not (math.isfinite(value) and 0 <= value <= MAX_SECONDS):
            raise InputError(f"activity {_shown(a.id)}: {column} {value:g} s is not within 0 to {MAX_SECONDS:g} s "
                             "(31 years), so it cannot be written to a schedule CSV")
    if a.target is not None and not all(math.isfinite(v) and abs(v) <= MAX_COORDINATE_M for v in a.target):
        raise InputError(f"activity {_shown(a.id)}: its target {a.target} is not within +-{MAX_COORDINATE_M:g} m, "
                         "so it cannot be written to a schedule CSV")


