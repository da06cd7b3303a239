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
from typing import TYPE_CHECKING

from bimrobot.errors import InputError
from bimrobot.lbd import components

if TYPE_CHECKING:  # pragma: no cover
    from bimrobot.bim.model import BuildingModel
    from bimrobot.lbd.schedule import Schedule

log = logging.getLogger(__name__)

NAMESPACE = "http://schemas.microsoft.com/project"
#: MSPDI PredecessorLink/Type values (0 FF, 1 FS, 2 SF, 3 SS).
LINK_TYPES = {"0": "FINISH_FINISH", "1": "FINISH_START", "2": "START_FINISH", "3": "START_START"}
_GLOBAL_ID = re.compile(r"[0-9A-Za-z_$]{22}")


def _text(task: ET.Element, tag: str) -> str:
    child = task.find(f"{{{NAMESPACE}}}{tag}")
    return (child.text or "").strip() if child is not None else ""


def _date(task: ET.Element, tag: str, path: Path, uid: str) -> str | None:
    text = _text(task, tag)
    if not text:
        return None
    try:
        return datetime.fromisoformat(text).isoformat()
    except ValueError:
        raise InputError(f"{path}: task UID {uid} has {tag} {text!r}, which is not an ISO date-time") from None


def _root(path: Path) -> ET.Element:
    try:
        root = ET.parse(path).getroot()
    except FileNotFoundError:
        raise InputError(f"the schedule {path} does not exist") from None
    except IsADirectoryError:
        raise InputError(f"the schedule {path} is a folder, not a Microsoft Project XML file") from None
    except ET.ParseError as exc:
        raise InputError(f"{path} is not a well-formed Microsoft Project XML schedule ({exc})") from None
    if root.tag != f"{{{NAMESPACE}}}Project":
        raise InputError(f"{path} is XML but not a Microsoft Project schedule (its root is <{root.tag}>, "
                         f"expected <Project xmlns=\"{NAMESPACE}\">)")
    return root


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


def load_schedule_msproject(path: str | os.PathLike, model: BuildingModel | None = None) -> Schedule:
    """Read a Microsoft Project XML (MSPDI) schedule into a :class:`Schedule` (see the module docstring).

    Raises :class:`InputError` in one sentence for a file that is not well-formed XML, not an MSPDI
    project, has no task, a date that is not ISO 8601, a link to an unknown task or a cycle.
    """
    from bimrobot.bim.work_schedule import TaskRow
    from bimrobot.lbd.schedule import schedule_from_task_rows

    path = Path(path)
    root = _root(path)
    tasks = root.findall(f"{{{NAMESPACE}}}Tasks/{{{NAMESPACE}}}Task")
    if not tasks:
        raise InputError(f"{path} is a Microsoft Project file without any task: nothing to schedule")
    resources = {_text(r, "UID"): _text(r, "Name") for r in root.findall(f"{{{NAMESPACE}}}Resources/{{{NAMESPACE}}}Resource")}
    assigned: dict[str, list[str]] = {}
    for assignment in root.findall(f"{{{NAMESPACE}}}Assignments/{{{NAMESPACE}}}Assignment"):
        name = resources.get(_text(assignment, "ResourceUID"))
        if name:
            assigned.setdefault(_text(assignment, "TaskUID"), []).append(name)
    uids = {_text(t, "UID") for t in tasks}
    matcher = _Matcher(model)
    rows, unmatched, outline = [], [], []  # outline: (level, uid) of the open summary tasks
    for task in tasks:
        uid = _text(task, "UID")
        if not uid:
            raise InputError(f"{path}: a task has no UID (every MSPDI task needs one)")
        level = int(_text(task, "OutlineLevel") or 1)
        while outline and outline[-1][0] >= level:
            outline.pop()
        parent = outline[-1][1] if outline else None
        is_summary = _text(task, "Summary") == "1"
        if is_summary:
            outline.append((level, uid))
        predecessors = []
        for link in task.findall(f"{{{NAMESPACE}}}PredecessorLink"):
            before, kind = _text(link, "PredecessorUID"), LINK_TYPES.get(_text(link, "Type") or "1", "unknown")
            if before not in uids:
                raise InputError(f"{path}: task UID {uid} links to predecessor UID {before}, which is not a task of the file")
            if kind == "FINISH_START":
                predecessors.append(before)
            else:
                log.warning("%s: link %s -> %s is %s, not FINISH_START: not used as a predecessor", path, before, uid, kind)
        name = _text(task, "Name")
        texts = [_text(task, "Notes")] + [(_text(a, "Value")) for a in task.findall(f"{{{NAMESPACE}}}ExtendedAttribute")]
        target, rule = (None, "") if is_summary else matcher.match(name, texts)
        if not is_summary and target is None:
            unmatched.append(uid)
        elif rule:
            log.info("%s: task UID %s %r matched to %s by %s", path, uid, name, target, rule)
        storey = target if model is not None and target in {s.global_id for s in model.storeys} else None
        rows.append(TaskRow(
            global_id=uid, name=name or f"task {uid}", identification=_text(task, "ID") or None,
            predefined_type="NOTDEFINED", start=_date(task, "Start", path, uid), finish=_date(task, "Finish", path, uid),
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
