"""Microsoft Project XML schedules (MSPDI, the format ifc4d's ``msp2ifc`` reads) into a :class:`Schedule`.

Each ``Task`` (UID, Name, Start, Finish, OutlineLevel, Summary, PredecessorLink) becomes an activity
whose id is its UID; summary tasks become ``Schedule.phases`` and the tasks nested under them (by
outline level) name them as ``parent``. Only FINISH_START links (``Type`` 1, MSPDI's default) are
predecessors; FF, SF and SS links are logged and skipped, as for IFC work schedules. Times are
seconds from the earliest task start in calendar time (``Schedule.epoch``); ``Duration`` (working
time on the project calendar) is not the elapsed time and is not used.

An MSPDI file does not know the IFC model, so a task is matched to it, first rule that applies:

1. its Name, Notes or a text field contains an element's (or assembly's) GlobalId: that component;
2. its Name equals a storey's name (case and spaces ignored): that storey;
3. its Name equals the name of exactly one component: that component.

Other tasks stay in the schedule as activities without a component, listed in
``Schedule.unmatched`` (and logged), never dropped.
"""

from __future__ import annotations

import logging
import os
import re
import xml.etree.ElementTree as ET
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Iterator, NamedTuple

from bimrobot.core.errors import InputError
from bimrobot.bim import components
from bimrobot.schedule.limits import check_file_size, id_problem
from bimrobot.schedule.task_rows import TaskRow, schedule_from_task_rows

if TYPE_CHECKING:  # pragma: no cover
    from bimrobot.bim.model import BuildingModel
    from bimrobot.schedule.schedule import Schedule

log = logging.getLogger(__name__)

NAMESPACE = "http://schemas.microsoft.com/project"
#: MSPDI PredecessorLink/Type values (0 FF, 1 FS, 2 SF, 3 SS).
LINK_TYPES = {"0": "FINISH_FINISH", "1": "FINISH_START", "2": "START_FINISH", "3": "START_START"}
_GLOBAL_ID = re.compile(r"[0-9A-Za-z_$]{22}")


def _text(task: ET.Element, tag: str) -> str:
    child = task.find(f"{{{NAMESPACE}}}{tag}")
    return (child.text or "").strip() if child is not None else ""


class _Task(NamedTuple):
    """What is read of one MSPDI ``Task`` (texts stripped; "" when absent): kept instead of the element,
    so that a large file costs its texts, not its XML tree."""

    uid: str
    ident: str
    name: str
    level: str
    summary: str
    start: str
    finish: str
    links: tuple[tuple[str, str], ...]  # (PredecessorUID, Type)
    texts: tuple[str, ...]  # Notes and the ExtendedAttribute values: where a GlobalId may be named

    @classmethod
    def of(cls, task: ET.Element) -> _Task:
        links = tuple((_text(link, "PredecessorUID"), _text(link, "Type")) for link in task.findall(_tag("PredecessorLink")))
        texts = (_text(task, "Notes"), *(_text(a, "Value") for a in task.findall(_tag("ExtendedAttribute"))))
        return cls(_text(task, "UID"), _text(task, "ID"), _text(task, "Name"), _text(task, "OutlineLevel"),
                   _text(task, "Summary"), _text(task, "Start"), _text(task, "Finish"), links, tuple(t for t in texts if t))


def _date(task: _Task, tag: str, path: Path) -> str | None:
    text = getattr(task, tag.lower())
    uid = task.uid
    if not text:
        return None
    try:
        return datetime.fromisoformat(text).isoformat()
    except ValueError:
        raise InputError(f"{path}: task UID {uid} has {tag} {text!r}, which is not an ISO date-time") from None


def _tag(name: str) -> str:
    return f"{{{NAMESPACE}}}{name}"


def _events(path: Path) -> Iterator[tuple[str, ET.Element]]:
    """(event, element) of ``path`` read with ``iterparse`` (start and end events): the file is read as a
    stream, never whole; each InputError names the file."""
    try:
        yield from ET.iterparse(path, events=("start", "end"))
    except FileNotFoundError:
        raise InputError(f"the schedule {path} does not exist") from None
    except IsADirectoryError:
        raise InputError(f"the schedule {path} is a folder, not a Microsoft Project XML file") from None
    except PermissionError as exc:
        raise InputError(f"cannot read the schedule {path}: {exc.strerror}") from None
    except ET.ParseError as exc:
        raise InputError(f"{path} is not a well-formed Microsoft Project XML schedule ({exc})") from None


def _read(path: Path) -> tuple[list[_Task], dict[str, str], list[tuple[str, str]]]:
    """The file's tasks (:class:`_Task`), resources (UID -> name) and assignments
    ((task UID, resource UID)), streamed: each element is dropped from the tree once read, so memory
    grows with the tasks kept, not with the file. Refuses a root that is not an MSPDI ``Project`` and
    more tasks than :func:`bimrobot.schedule.csv.limit` ``("rows")``."""
    from bimrobot.schedule.limits import limit, too_many

    tasks: list[_Task] = []
    resources: dict[str, str] = {}
    assignments: list[tuple[str, str]] = []
    most = limit("rows")
    stack: list[ET.Element] = []
    for event, element in _events(path):
        if event == "start":
            if not stack and element.tag != _tag("Project"):
                raise InputError(f"{path} is XML but not a Microsoft Project schedule (its root is <{element.tag}>, "
                                 f"expected <Project xmlns=\"{NAMESPACE}\">)")
            stack.append(element)
            continue
        stack.pop()
        parent = stack[-1].tag if stack else None
        if element.tag == _tag("Task") and parent == _tag("Tasks"):
            if len(tasks) == most:
                raise too_many(str(path), "the file has", "rows", "tasks")
            tasks.append(_Task.of(element))
        elif element.tag == _tag("Resource") and parent == _tag("Resources"):
            resources[_text(element, "UID")] = _text(element, "Name")
        elif element.tag == _tag("Assignment") and parent == _tag("Assignments"):
            assignments.append((_text(element, "TaskUID"), _text(element, "ResourceUID")))
        else:
            continue
        stack[-1].remove(element)  # read: out of the tree
    return tasks, resources, assignments


class _Matcher:
    """Finds the component or storey a task names (rules in the module docstring)."""

    def __init__(self, model: BuildingModel | None):
        self.model = model
        self.storeys: dict[str, str] = {}
        self.names: dict[str, list[str]] = {}
        if model is None:
            return
        self.storeys = {_key(s.name): s.global_id for s in model.storeys if s.name}
        for gid in [*model.elements, *getattr(model, "assemblies", {})]:
            item = model.elements.get(gid) or model.assemblies[gid]
            if item.name:
                self.names.setdefault(_key(item.name), []).append(gid)

    def match(self, name: str, texts: list[str]) -> tuple[str | None, str]:
        """(GlobalId of the component or storey, the rule that matched) or (None, "")."""
        if self.model is None:
            return None, ""
        for text in (name, *texts):
            for token in _GLOBAL_ID.findall(text):
                if components.is_component(self.model, token):
                    return token, "GlobalId in the task"
        if _key(name) in self.storeys:
            return self.storeys[_key(name)], "storey name"
        found = self.names.get(_key(name), [])
        if len(found) == 1:
            return found[0], "element name"
        return None, ""


def _key(name: str) -> str:
    return " ".join(name.lower().split())


def _unique_uids(tasks: list[_Task], path: Path) -> set[str]:
    """The tasks' UIDs; a task without one, or a UID used twice, is refused (each task is an activity)."""
    first: dict[str, int] = {}
    for number, task in enumerate(tasks, 1):
        uid = task.uid
        if not uid:
            raise InputError(f"{path}: task {number} of the file has no UID (every MSPDI task needs one)")
        problem = id_problem(uid, spaces=False)
        if problem:
            raise InputError(f"{path}: task {number} of the file has UID {uid[:40]!r}, which {problem}")
        if uid in first:
            raise InputError(f"{path}: tasks {first[uid]} and {number} of the file have the same UID {uid} "
                             "(each task needs its own)")
        first[uid] = number
    return set(first)


def _outline_level(task: _Task, path: Path) -> int:
    """The task's OutlineLevel (1 when absent), a whole number from 0 (the project summary) to 100."""
    uid, text = task.uid, task.level or "1"
    try:
        level = int(text)
    except ValueError:
        level = -1
    if not 0 <= level <= 100:
        raise InputError(f"{path}: task UID {uid} has OutlineLevel {text[:40]!r}, which is not a whole number from 0 to 100")
    return level


def _assigned(resources: dict[str, str], assignments: list[tuple[str, str]]) -> dict[str, list[str]]:
    """Task UID -> the names of the resources assigned to it (assignments to unnamed resources dropped)."""
    assigned: dict[str, list[str]] = {}
    for task_uid, resource_uid in assignments:
        name = resources.get(resource_uid)
        if name:
            assigned.setdefault(task_uid, []).append(name)
    return assigned


def _predecessors(task: _Task, uids: set[str], path: Path) -> list[str]:
    """The task's FINISH_START predecessors (UIDs); other link types are logged and left out. InputError
    for a link to a UID that is not a task of the file."""
    uid, predecessors = task.uid, []
    for before, link_type in task.links:
        kind = LINK_TYPES.get(link_type or "1", "unknown")
        if before not in uids:
            raise InputError(f"{path}: task UID {uid} links to predecessor UID {before}, which is not a task of the file")
        if kind == "FINISH_START":
            predecessors.append(before)
        else:
            log.warning("%s: link %s -> %s is %s, not FINISH_START: not used as a predecessor", path, before, uid, kind)
    return predecessors


def load_schedule_msproject(path: str | os.PathLike, model: BuildingModel | None = None) -> Schedule:
    """Read a Microsoft Project XML (MSPDI) schedule into a :class:`Schedule` (see the module docstring).

    Raises :class:`InputError` in one sentence for a file that is not well-formed XML, not an MSPDI
    project, has no task, a task without a UID or two with the same UID, a date that is not ISO 8601,
    a link to an unknown task or a cycle; and, before it is read, for a file over the size limit, or as
    soon as it has more tasks than allowed (:data:`bimrobot.schedule.limits.LIMITS`). The file is streamed.
    """
    path = Path(path)
    check_file_size(path, "xml_mb", "Microsoft Project XML file")
    tasks, resources, assignments = _read(path)
    if not tasks:
        raise InputError(f"{path} is a Microsoft Project file without any task: nothing to schedule")
    assigned = _assigned(resources, assignments)
    uids = _unique_uids(tasks, path)
    matcher = _Matcher(model)
    storeys = {s.global_id for s in model.storeys} if model is not None else set()
    rows, unmatched, outline = [], [], []  # outline: (level, uid) of the open summary tasks
    for task in tasks:
        uid = task.uid
        level = _outline_level(task, path)
        while outline and outline[-1][0] >= level:
            outline.pop()
        parent = outline[-1][1] if outline else None
        is_summary = task.summary == "1"
        if is_summary:
            outline.append((level, uid))
        predecessors = _predecessors(task, uids, path)
        name = task.name
        target, rule = (None, "") if is_summary else matcher.match(name, list(task.texts))
        if not is_summary and target is None:
            unmatched.append(uid)
        elif rule:
            log.info("%s: task UID %s %r matched to %s by %s", path, uid, name, target, rule)
        storey = target if target in storeys else None
        rows.append(TaskRow(
            global_id=uid, name=name or f"task {uid}", identification=task.ident or None,
            predefined_type="NOTDEFINED", start=_date(task, "Start", path), finish=_date(task, "Finish", path),
            predecessors=tuple(predecessors), outputs=(target,) if target else (), inputs=(),
            resources=tuple(sorted(assigned.get(uid, ()))), parent=parent, is_summary=is_summary,
            storey=storey, work_schedule=None,
        ))  # fmt: skip
    schedule = schedule_from_task_rows(rows, path, model)
    schedule.unmatched = unmatched
    if model is not None and unmatched:
        example = next(r.name for r in rows if r.global_id == unmatched[0])
        log.warning("%s: %d of %d tasks name no element or storey of the model (e.g. UID %s %r): kept as "
                    "activities without a component", path, len(unmatched), len(rows), unmatched[0], example)
    return schedule
