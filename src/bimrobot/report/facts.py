"""What a build report says, read from a `bimrobot build` output folder (no IFC, no charts).

Sources, each optional (a missing or unreadable one is listed in :attr:`BuildFacts.missing` and its
part of the report says "unknown"): ``build.json``, ``simulation/summary.json``, ``schedule.csv``,
``states.json``, ``package/report.json`` and ``rcan/report.json``. Times are seconds of work from the
start of the build, laid onto the site's working calendar (``work_calendar`` of the build's site file,
default Monday-Friday 07:00-16:00) by :func:`bimrobot.schedule.ifc.working_datetime`, the same
arithmetic as the IFC work schedule's (so the report's dates are the 4D schedule's). The makespan is
the simulation's (``summary.json``), the one number every other output of the build agrees with.
"""

from __future__ import annotations

import datetime as dt
import json
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import networkx as nx

from bimrobot.core.errors import InputError
from bimrobot.site.working_time import WorkCalendar, working_datetime

#: The thesis' component states in the order a component passes through them (chapter 4).
STATES = ("OnYard", "InTransit", "Arrived", "InLocation", "WorkingInPositioning", "PositionFixed",
          "WaitForAssembly", "WorkingInAssembly", "Assembled")
INSTALLED = "Assembled"
#: Slack (s) under which a predecessor's finish counts as driving an activity's start (CSV rounding).
DRIVING_SLACK_S = 0.01


@dataclass
class CriticalPath:
    """The chain of activities that sets the makespan, and the logic-only lower bound.

    ``activities``: ids, first to last; each one starts when the one before it finishes (a predecessor
    in the schedule, or the same robot's previous activity). ``work_s``: their durations added;
    ``waiting_s``: the rest of the makespan (gaps along the chain). ``logic_bound_s``: the longest path
    through the predecessors alone (every robot always free), seconds."""

    activities: list[str]
    work_s: float
    waiting_s: float
    logic_bound_s: float
    logic_edges: int
    robot_edges: int


@dataclass
class BuildFacts:
    """Everything the report and the README's key figures show (see the module docstring)."""

    folder: Path
    model: str
    project: str | None
    fleet: str
    site: str
    start: dt.datetime
    calendar: WorkCalendar
    #: where the calendar comes from, in words (the site file, or the default)
    calendar_source: str
    makespan_s: float | None
    fleet_utilisation: float | None
    schedule: list[dict]
    states: dict[str, list[tuple[float, str]]]
    robots: list[dict]
    #: component GlobalId -> (IFC class, name, storey name)
    components: dict[str, tuple[str, str, str]]
    summary: dict = field(default_factory=dict)
    package: dict = field(default_factory=dict)
    rcan: dict | None = None
    build: dict = field(default_factory=dict)
    critical_path: CriticalPath | None = None
    missing: list[str] = field(default_factory=list)
    #: ``simulation/plan.json`` when the build was planned with ``--planner`` (which planner, and with a
    #: portfolio every member's makespan, ``portfolio_makespans_s``), else None
    plan: dict | None = None
    #: the IFC model of the build (:class:`bimrobot.bim.BuildingModel`), or None with ``model_note`` saying why
    building_model: object | None = None
    model_note: str = ""

    def date(self, seconds: float, finish: bool = False) -> dt.datetime:
        """The calendar date-time after ``seconds`` of work from the start (``finish``: work that ends
        at the end of a working day ends then, not at the start of the next one)."""
        return working_datetime(self.calendar, self.start, seconds, finish=finish)

    @property
    def work_begins(self) -> dt.datetime:
        """The first working moment at or after the start."""
        return self.date(0.0)

    @property
    def finish(self) -> dt.datetime | None:
        return None if self.makespan_s is None else self.date(self.makespan_s, finish=True)

    def final_state(self, component: str) -> str | None:
        history = self.states.get(component) or []
        return history[-1][1] if history else None

    def built(self) -> list[str]:
        """Components whose last state is Assembled."""
        return [c for c in self.states if self.final_state(c) == INSTALLED]

    def count_by(self, index: int) -> dict[str, tuple[int, int]]:
        """Components per IFC class (``index`` 0) or storey (2): name -> (assembled, all), by name."""
        counts: dict[str, list[int]] = {}
        for component in self.states:
            key = self.components.get(component, ("unknown", "", "unknown"))[index] or "unknown"
            entry = counts.setdefault(key, [0, 0])
            entry[1] += 1
            entry[0] += self.final_state(component) == INSTALLED
        return {key: (built, total) for key, (built, total) in sorted(counts.items())}


def read_build(folder: str | Path, start: str | dt.datetime | None = None,
               calendar: WorkCalendar | None = None, with_model: bool = True,
               model: str | Path | None = None, building=None) -> BuildFacts:
    """Read a build output folder into :class:`BuildFacts`.

    ``start``: date-time of t = 0 s (ISO text or datetime); default the build's (``build.json``'s
    ``start``), else today 08:00. ``calendar``: default the site's (:func:`site_calendar`).
    ``with_model``: read the IFC model the build was made from (when it is still there) for the names,
    classes and storeys of assemblies and the building's picture; ``model``: that file, when it moved
    since the build; ``building``: its BuildingModel, already read (``bimrobot build``). Raises InputError when ``folder`` is not a build output folder or ``model`` is
    not a file."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder} is not a folder; give a `bimrobot build` output folder")
    if not any((folder / name).exists() for name in ("build.json", "simulation", "package")):
        raise InputError(f"{folder} is not a `bimrobot build` output folder (it has no build.json, simulation/ or package/)")
    missing: list[str] = []
    build = _json(folder, "build.json", missing) or {}
    summary = _json(folder, "simulation/summary.json", missing) or {}
    package = _json(folder, "package/report.json", missing) or {}
    rcan = _json(folder, "rcan/report.json", missing)
    plan = _json(folder, "simulation/plan.json", []) if (folder / "simulation" / "plan.json").is_file() else None
    schedule = _schedule(folder, missing)
    states = _states(folder, missing)
    robots = summary.get("robots") or _robots_csv(folder, missing)
    start_time = _start(start if start is not None else build.get("start"))
    calendar_source = "given"
    if calendar is None:  # the site the build placed the building on (out/site.yaml), else the one it was given
        placed = folder / "site.yaml"
        calendar, calendar_source = site_calendar(str(placed) if placed.is_file() else build.get("site"))
        calendar_source = calendar_source.replace(str(placed), "site.yaml of this build")
    model_path = Path(str(model or build.get("model") or summary.get("model") or package.get("source") or "unknown model"))
    if model is not None and not model_path.is_file():
        raise InputError(f"--model {model}: no such file")
    if building is not None:
        building_model, model_note = building, ""
    else:
        building_model, model_note = _building_model(model_path) if with_model else (None, "not read")
    facts = BuildFacts(
        folder=folder, model=model_path.name, project=package.get("project"),
        fleet=str(build.get("fleet") or summary.get("fleet") or "unknown"),
        site=str(build.get("site") or (package.get("options") or {}).get("site", {}).get("source") or "unknown"),
        start=start_time, calendar=calendar, calendar_source=calendar_source,
        makespan_s=_number(summary.get("makespan_s")), fleet_utilisation=_number(summary.get("fleet_utilisation")),
        schedule=schedule, states=states, robots=robots, components=_components(schedule, states, package, building_model),
        summary=summary, package=package, rcan=rcan, plan=plan, build=build, missing=missing, building_model=building_model,
        model_note=model_note,
    )
    facts.critical_path = critical_path(schedule) if schedule else None
    return facts


def default_start(today: dt.date | None = None) -> dt.datetime:
    """The build's start when none is given: ``today`` (default: today) at 08:00, as `build --start`."""
    return dt.datetime.combine(today or dt.date.today(), dt.time(8))


def parse_start(text: str | None) -> dt.datetime:
    """An ISO date-time (``2027-03-01T07:00``) as a naive local date-time (the site's clock); None gives
    :func:`default_start`. Raises ValueError for text that is not one."""
    if not text:
        return default_start()
    moment = dt.datetime.fromisoformat(text)
    return moment.replace(tzinfo=None) if moment.tzinfo else moment


def site_calendar(site: str | None) -> tuple[WorkCalendar, str]:
    """The working calendar of the build's site file (its ``site.yaml``, else ``build.json``'s ``site``) and
    where it comes from; the default calendar when the build used the default site or its file is gone."""
    from bimrobot.site.site import load_site

    if site and Path(site).is_file():
        try:
            return load_site(site).work_calendar, f"the site file {site}"
        except InputError as exc:
            return WorkCalendar(), f"the default (the site file {site} cannot be read: {exc})"
    gone = site and site.endswith((".yaml", ".yml"))
    return WorkCalendar(), "the default" + (f" (the site file {site} is gone)" if gone else "")


def _building_model(path: Path):
    """(BuildingModel, "") of the build's IFC file, or (None, why not)."""
    from bimrobot.bim import load_model

    if not path.is_file():
        return None, f"the model file {str(path)!r} is no longer there"
    try:
        return load_model(path, properties=False), ""
    except (InputError, OSError) as exc:
        return None, f"the model file {str(path)!r} cannot be read ({exc})"


def _start(value) -> dt.datetime:
    if isinstance(value, dt.datetime):
        return value.replace(tzinfo=None)
    try:
        return parse_start(value)
    except ValueError:
        raise InputError(f"the build's start {value!r} is not an ISO date-time such as 2027-03-01T07:00") from None


def _number(value) -> float | None:
    return float(value) if isinstance(value, (int, float)) else None


def _json(folder: Path, name: str, missing: list[str]) -> dict | None:
    """The JSON object in ``folder/name``, or None (noted in ``missing``) when absent or unreadable."""
    path = folder / name
    if not path.is_file():
        missing.append(f"{name} (absent)")
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        missing.append(f"{name} (unreadable: {exc})")
        return None
    if not isinstance(data, dict):
        missing.append(f"{name} (not a JSON object)")
        return None
    return data


def _schedule(folder: Path, missing: list[str]) -> list[dict]:
    """The simulation's schedule rows (:func:`bimrobot.coordination.schedule.load_schedule_csv`)."""
    from bimrobot.coordination.schedule import load_schedule_csv

    path = folder / "simulation" / "schedule.csv"
    if not path.is_file():
        missing.append("simulation/schedule.csv (absent)")
        return []
    try:
        return load_schedule_csv(path)
    except InputError as exc:
        missing.append(f"simulation/schedule.csv (unreadable: {exc})")
        return []


def _states(folder: Path, missing: list[str]) -> dict[str, list[tuple[float, str]]]:
    """states.json: component -> [(time s, state)] in time order; unknown states are kept as written."""
    data = _json(folder, "simulation/states.json", missing)
    if data is None:
        return {}
    out = {}
    try:
        for component, history in data.items():
            out[str(component)] = sorted(((float(t), str(s)) for t, s in history), key=lambda c: c[0])
    except (TypeError, ValueError):
        missing.append("simulation/states.json (not component -> [[time, state], ...])")
        return {}
    return out


def _robots_csv(folder: Path, missing: list[str]) -> list[dict]:
    """robots.csv rows, numbers as floats, for a build without summary.json."""
    import csv

    path = folder / "simulation" / "robots.csv"
    if not path.is_file():
        return []
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            rows = list(csv.DictReader(handle))
        for row in rows:
            for key in ("steps", "busy_time_s", "utilisation"):
                row[key] = float(row[key])
        return rows
    except (OSError, csv.Error, KeyError, ValueError) as exc:
        missing.append(f"simulation/robots.csv (unreadable: {exc})")
        return []


def _components(schedule: list[dict], states: dict, package: dict, model=None) -> dict[str, tuple[str, str, str]]:
    """Component -> (IFC class, name, storey name) from the package's elements and maps, the schedule's
    storeys and, when read, the model; an assembly unit's class is ``IfcElementAssembly (<class of
    its heaviest part>)``, e.g. ``IfcElementAssembly (IfcBeam)`` for a precast beam unit."""
    elements = {e.get("global_id"): e for e in package.get("converted") or [] if isinstance(e, dict)}
    storey_names = {m.get("storey_id"): m.get("storey_name") for m in package.get("maps") or [] if isinstance(m, dict)}
    if model is not None:
        storey_names.update({s.global_id: s.name for s in model.storeys if s.name})
    assemblies = getattr(model, "assemblies", {}) or {}
    storey_of = {row["GlobalId"]: row.get("Storey") or "" for row in schedule}
    out = {}
    for component in list(states) or list(storey_of):
        element = elements.get(component)
        assembly = assemblies.get(component)
        storey = storey_of.get(component) or (element or {}).get("storey_id") or getattr(assembly, "storey_id", "") or ""
        storey_name = storey_names.get(storey) or storey or "unknown"
        if element is not None:
            out[component] = (element.get("ifc_class") or "unknown", element.get("name") or "", storey_name)
        elif assembly is not None:
            parts = [elements[p] for p in assembly.part_ids if p in elements]
            main = max(parts, key=lambda e: e.get("mass_kg") or 0.0).get("ifc_class") if parts else None
            ifc_class = f"IfcElementAssembly ({main})" if main else "IfcElementAssembly"
            out[component] = (ifc_class, assembly.name or "", storey_name)
        else:
            out[component] = ("IfcElementAssembly" if package else "unknown", "", storey_name)
    return out


def critical_path(schedule: list[dict]) -> CriticalPath:
    """The chain of activities that ends last, walked back through what each one waited for.

    A directed graph (networkx) holds the schedule's predecessors (FINISH_START) and, per robot, its
    activities in the order it did them. From the activity that finishes last, each step goes back to
    the in-neighbour that finished latest, no later than the activity started: the predecessor or the
    robot's previous job that the activity waited for. ``logic_bound_s`` is the longest path through the
    predecessors alone, with every duration (s), as if robots were always free."""
    rows = {row["Identification"]: row for row in schedule}
    graph = nx.DiGraph()
    graph.add_nodes_from(rows)
    logic = [(p, a) for a, row in rows.items() for p in row["Predecessors"] if p in rows]
    graph.add_edges_from(logic, kind="logic")
    robot_edges = 0
    by_robot: dict[str, list[dict]] = {}
    for row in schedule:
        if row.get("Robot"):
            by_robot.setdefault(row["Robot"], []).append(row)
    for jobs in by_robot.values():
        jobs.sort(key=lambda r: (r["Start"], r["Finish"], r["Identification"]))
        for before, after in zip(jobs, jobs[1:]):
            if not graph.has_edge(before["Identification"], after["Identification"]):
                graph.add_edge(before["Identification"], after["Identification"], kind="robot")
                robot_edges += 1
    last = max(rows.values(), key=lambda r: (r["Finish"], r["Identification"]))
    chain = [last["Identification"]]
    while True:
        row = rows[chain[-1]]
        waited_for = [rows[p] for p in graph.predecessors(chain[-1]) if rows[p]["Finish"] <= row["Start"] + DRIVING_SLACK_S]
        if not waited_for or row["Start"] <= DRIVING_SLACK_S:
            break
        chain.append(max(waited_for, key=lambda r: (r["Finish"], r["Identification"]))["Identification"])
    chain.reverse()
    work = sum(rows[a]["Finish"] - rows[a]["Start"] for a in chain)
    return CriticalPath(activities=chain, work_s=work, waiting_s=max(last["Finish"] - work, 0.0),
                        logic_bound_s=_logic_bound(rows, logic), logic_edges=len(logic), robot_edges=robot_edges)


def _logic_bound(rows: dict[str, dict], logic: list[tuple[str, str]]) -> float:
    """Longest chain of durations through the predecessors alone (s): the earliest finish of the build
    if every activity could start as soon as its predecessors are done."""
    graph = nx.DiGraph(logic)
    graph.add_nodes_from(rows)
    earliest_finish: dict[str, float] = {}
    for node in nx.topological_sort(graph):
        ready = max((earliest_finish[p] for p in graph.predecessors(node)), default=0.0)
        earliest_finish[node] = ready + rows[node]["Finish"] - rows[node]["Start"]
    return max(earliest_finish.values(), default=0.0)


def state_counts(states: dict[str, list[tuple[float, str]]]) -> tuple[list[float], dict[str, list[int]]]:
    """Components per state over time: the times at which any state changed (s, ascending) and, per
    state of :data:`STATES` (then any other state met), how many components were in it from each time."""
    changes = sorted((t, component, state) for component, history in states.items() for t, state in history)
    names = list(STATES) + sorted({s for _, _, s in changes} - set(STATES))
    current: dict[str, str] = {}
    counts = Counter()
    times: list[float] = []
    series: dict[str, list[int]] = {name: [] for name in names}
    index = 0
    while index < len(changes):
        moment = changes[index][0]
        while index < len(changes) and changes[index][0] == moment:
            _, component, state = changes[index]
            if component in current:
                counts[current[component]] -= 1
            current[component] = state
            counts[state] += 1
            index += 1
        times.append(moment)
        for name in names:
            series[name].append(counts[name])
    return times, series
