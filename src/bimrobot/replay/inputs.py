"""What a replay is made of, read from a build's output folder (or a `simulate` + `convert` pair).

Everything is in the model frame of the package's world (metres, z up, seconds from the start of the
build): element meshes from the package's COLLADA visuals, their pick-up poses on the yard from the
package (``convert --layout yard``), their installed poses from the IFC placements (the model file the
package names, read with :func:`bimrobot.bim.load_model`), and the build itself from the simulation's
``schedule.csv`` and ``states.json`` (the thesis' component states with their times).
"""

from __future__ import annotations

import csv
import json
import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bimrobot.core.errors import InputError
from bimrobot.replay.rcan import RcanRun, is_rcan_folder, load_rcan_run

log = logging.getLogger(__name__)

#: The thesis' component states, in the order a component passes through them (chapter 4).
STATES = ("OnYard", "InTransit", "Arrived", "InLocation", "WorkingInPositioning", "PositionFixed",
          "WaitForAssembly", "WorkingInAssembly", "Assembled")
#: The state that counts a component as installed.
INSTALLED = "Assembled"


@dataclass
class Piece:
    """One element of the package: its visual mesh in the local frame and where it stands.

    ``triangles`` (k, 3, 3) metres, local frame; ``colour`` RGBA 0..1 (the package's material colour);
    ``yard_pose`` 4x4 pick-up pose on the yard (None when the package was converted installed);
    ``installed_pose`` 4x4 IFC placement (model frame); ``part_ids`` the elements of a piece that joins an
    assembly's parts (bimrobot.replay.elements.join_units), empty for an element."""

    global_id: str
    ifc_class: str
    name: str
    storey_id: str | None
    triangles: np.ndarray
    colour: np.ndarray
    yard_pose: np.ndarray | None
    installed_pose: np.ndarray
    part_ids: tuple[str, ...] = ()

    def world_bounds(self, pose: np.ndarray) -> np.ndarray:
        """[[xmin, ymin, zmin], [xmax, ymax, zmax]] of the mesh at ``pose`` (metres)."""
        points = self.triangles.reshape(-1, 3) @ pose[:3, :3].T + pose[:3, 3]
        return np.array([points.min(axis=0), points.max(axis=0)])


@dataclass
class Robot:
    """A robot of the fleet: ``home`` (x, y) model frame, metres; ``speed`` m/s."""

    name: str
    kind: str
    home: np.ndarray
    speed: float
    load_time: float = 0.0
    unload_time: float = 0.0


@dataclass
class Node:
    """A connection node ``<relating>:<related>``: ``position`` model frame (m); ``realizing`` the
    bolts, plates or welds of its joint that are in the package."""

    node_id: str
    position: np.ndarray
    realizing: tuple[str, ...] = ()


@dataclass
class BuildRecord:
    """Everything a replay shows (see the module docstring)."""

    title: str
    pieces: dict[str, Piece]
    #: component GlobalId (element or assembly) -> the GlobalIds of its pieces
    parts: dict[str, list[str]]
    #: component GlobalId -> [(time s, state)] in time order
    states: dict[str, list[tuple[float, str]]]
    schedule: list[dict]
    robots: dict[str, Robot]
    nodes: dict[str, Node]
    inputs: list[Path] = field(default_factory=list)
    #: the build's RCAN run (its rcan/ folder), or the RCAN run folder replayed alone; None without one
    rcan: RcanRun | None = None
    #: the site's rule for robots without work: "stay", or "yard" (they drive back to the nearest of
    #: ``yard``, (k, 2) model frame, metres)
    idle_robots: str = "stay"
    yard: np.ndarray | None = None
    #: storey GlobalId -> the storey's name (the entity tree names elements by storey)
    storeys: dict[str, str] = field(default_factory=dict)
    #: component GlobalId of an assembly -> (its IFC class, name, storey GlobalId), as the model has it
    assemblies: dict[str, tuple[str, str, str | None]] = field(default_factory=dict)

    @property
    def makespan(self) -> float:
        """Finish of the last activity (s); 0 for an empty schedule."""
        return max((row["Finish"] for row in self.schedule), default=0.0)


def find_folders(folders: list[Path]) -> tuple[Path, Path]:
    """(package, simulation) folders from a build output folder or a `convert` + `simulate` pair."""
    folders = [Path(f) for f in folders]
    for folder in folders:
        if not folder.is_dir():
            raise InputError(f"{folder} is not a folder; give a `bimrobot build` output folder, or a `simulate` and a `convert` folder")
    if len(folders) == 1 and (folders[0] / "package").is_dir() and (folders[0] / "simulation").is_dir():
        return folders[0] / "package", folders[0] / "simulation"
    package = [f for f in folders if (f / "report.json").is_file() and (f / "models").is_dir()]
    simulation = [f for f in folders if (f / "schedule.csv").is_file() and (f / "states.json").is_file()]
    if len(folders) == 2 and len(package) == 1 and len(simulation) == 1:
        return package[0], simulation[0]
    if len(folders) == 1:
        raise InputError(
            f"{folders[0]} is not a `bimrobot build` output folder (it has no package/ and simulation/); "
            "give a build folder, or a `simulate` folder and a `convert --layout yard` folder"
        )
    raise InputError(
        f"{' and '.join(map(str, folders))}: expected one `simulate` output folder (schedule.csv, states.json) "
        "and one `convert` package folder (report.json, models/)"
    )


def read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: cannot read it as JSON ({exc})") from None


def read_schedule(path: Path) -> list[dict]:
    """The schedule CSV (docs/conventions.md) with Start/Finish/Target* as floats."""
    try:
        rows = list(csv.DictReader(path.open(newline="")))
    except (OSError, csv.Error, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the schedule ({exc})") from None
    needed = {"Identification", "Name", "Activity", "GlobalId", "Robot", "Start", "Finish", "TargetX", "TargetY", "TargetZ"}
    missing = needed - set(rows[0] if rows else needed)
    if missing:
        raise InputError(f"{path}: not a bimrobot schedule (no column {sorted(missing)[0]})")
    out = []
    for line, row in enumerate(rows, start=2):
        try:
            for key in ("Start", "Finish", "TargetX", "TargetY", "TargetZ"):
                row[key] = float(row[key])
        except ValueError:
            raise InputError(f"{path}, line {line}: {key} is not a number ({row[key]!r})") from None
        out.append(row)
    return sorted(out, key=lambda r: (r["Start"], r["Identification"]))


def read_states(path: Path) -> dict[str, list[tuple[float, str]]]:
    """states.json: component -> [(time s, state)], checked against the thesis' states."""
    data = read_json(path)
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a mapping of component GlobalId -> [[time, state], ...]")
    out = {}
    for component, history in data.items():
        try:
            changes = [(float(t), str(s)) for t, s in history]
        except (TypeError, ValueError):
            raise InputError(f"{path}: the history of {component} is not a list of [time, state] pairs") from None
        unknown = [s for _, s in changes if s not in STATES]
        if unknown:
            raise InputError(f"{path}: component {component} has state {unknown[0]!r}, not one of the thesis' states")
        out[component] = sorted(changes, key=lambda c: c[0])
    return out


def load_build(folders: list[Path], model_path: Path | None = None, building=None) -> BuildRecord:
    """Read a build output folder (or a package + simulation pair) into a :class:`BuildRecord`.

    ``model_path``: the IFC file, when it is no longer where the package's report says it was.
    ``building``: that file's BuildingModel, already read (``bimrobot build``); None reads it here."""
    from bimrobot.bim import load_model
    from bimrobot.site.site import site_from_dict

    package, simulation = find_folders(folders)
    report = read_json(package / "report.json")
    if "converted" not in report:
        raise InputError(f"{package / 'report.json'}: not a `bimrobot convert` report (no 'converted' list)")
    model_path = Path(model_path or report.get("source") or "")
    if not model_path.is_file():
        raise InputError(
            f"the IFC model {str(model_path)!r} named in {package / 'report.json'} does not exist; give it with --model "
            "(the replay takes the installed positions from it)"
        )
    schedule = read_schedule(simulation / "schedule.csv")
    states = read_states(simulation / "states.json")
    summary = read_json(simulation / "summary.json") if (simulation / "summary.json").is_file() else {}
    model = building if building is not None else load_model(model_path)
    layout_yard = report.get("options", {}).get("layout") == "yard"
    site_data = dict(report.get("options", {}).get("site") or {})
    site_source = site_data.pop("source", "the package's site")
    site_data = {key: value for key, value in site_data.items() if value is not None}
    site = site_from_dict(site_data, site_source)
    pieces = _pieces(package, report, model, layout_yard)
    parts = _component_parts(states, pieces, model)
    offset = _model_offset(pieces, site)
    robots = _robots(schedule, summary, site, offset, simulation / "schedule.csv")
    nodes = _nodes(schedule, pieces, model)
    rcan_folder = Path(folders[0]) / "rcan"
    rcan = load_rcan_run(rcan_folder) if len(folders) == 1 and is_rcan_folder(rcan_folder) else None
    return BuildRecord(
        title=f"{report.get('project') or model_path.stem} ({model_path.name})",
        pieces=pieces, parts=parts, states=states, schedule=schedule, robots=robots, nodes=nodes,
        inputs=[package, simulation, model_path], rcan=rcan,
        idle_robots=site.idle_robots, yard=site.to_model(np.asarray(site.yard, float).reshape(-1, 2), offset),
        storeys=storey_names(model), assemblies=assembly_names(model, parts),
    )


def load_rcan_alone(folder: Path, model_path: Path | None) -> BuildRecord:
    """An `rcan run` output folder (report.json, state database, trajectory CSV) with the IFC model
    ``model_path`` for the meshes (every element of the model, in its own frame)."""
    from bimrobot.bim import load_model
    from bimrobot.export.gazebo.layout import rigid

    if model_path is None or not Path(model_path).is_file():
        raise InputError(f"{folder} is an `rcan run` output folder: give the IFC model with --model "
                         "(the replay draws its elements; for an experiment: bimrobot example rcan-experiment-N)")
    run = load_rcan_run(folder)
    model = load_model(Path(model_path))
    pieces = {
        gid: Piece(global_id=gid, ifc_class=e.ifc_class, name=e.name or "", storey_id=e.storey_id,
                   triangles=np.asarray(e.vertices, float)[np.asarray(e.faces)], colour=np.array([0.6, 0.6, 0.6, 1.0]),
                   yard_pose=None, installed_pose=rigid(e.placement))
        for gid, e in model.elements.items() if len(e.faces)
    }
    if not pieces:
        raise InputError(f"{model_path}: the model has no element with a body to replay")
    components = {a.component_id for a in run.activities} | set(run.component_states)
    parts = {c: [p for p in model.assemblies[c].part_ids if p in pieces] for c in components if c in model.assemblies}
    return BuildRecord(title=f"RCAN run {folder.name} ({Path(model_path).name})", pieces=pieces, parts=parts,
                       states={}, schedule=[], robots={}, nodes={}, inputs=[folder, Path(model_path)], rcan=run,
                       storeys=storey_names(model), assemblies=assembly_names(model, parts))


def assembly_names(model, components) -> dict[str, tuple[str, str, str | None]]:
    """Component GlobalId -> (IFC class, name, storey GlobalId) of each of ``components`` that is an
    assembly of the model."""
    return {c: (model.assemblies[c].ifc_class, model.assemblies[c].name or "", model.assemblies[c].storey_id)
            for c in components if c in model.assemblies}


def storey_names(model) -> dict[str, str]:
    """Storey GlobalId -> its name (its GlobalId when unnamed; two storeys of one name get their elevation)."""
    names = [s.name.strip() or s.global_id for s in model.storeys]
    return {s.global_id: name if names.count(name) == 1 else f"{name} ({s.elevation:+.2f} m)"
            for s, name in zip(model.storeys, names)}


def _pieces(package: Path, report: dict, model, layout_yard: bool) -> dict[str, Piece]:
    from bimrobot.export.gazebo.layout import rigid
    from bimrobot.export.gazebo.render import dae_triangles, pose_matrix

    pieces = {}
    for entry in report["converted"]:
        gid = entry["global_id"]
        dae = package / "models" / entry["model"] / "meshes" / f"{entry['model']}.dae"
        element = model.elements.get(gid)
        if element is None or not dae.is_file():
            # merged static models (--merge-static) and elements the model no longer has are not replayed
            log.info("replay: %s has no model of its own in %s or is not in the IFC model; left out", gid, package)
            continue
        triangles, colour = dae_triangles(dae)
        pose = pose_matrix(*entry["pose_xyz_rpy"])
        pieces[gid] = Piece(
            global_id=gid, ifc_class=entry["ifc_class"], name=entry.get("name") or "", storey_id=entry.get("storey_id"),
            triangles=triangles, colour=colour, yard_pose=pose if layout_yard else None,
            installed_pose=rigid(element.placement),
        )
    if not pieces:
        raise InputError(f"{package}: the package has no element models to replay")
    return pieces


def _component_parts(states: dict, pieces: dict[str, Piece], model) -> dict[str, list[str]]:
    """Component -> its pieces: itself, or the parts of an IfcElementAssembly."""
    parts = {}
    for component in states:
        if component in pieces:
            parts[component] = [component]
        elif component in model.assemblies:
            parts[component] = [p for p in model.assemblies[component].part_ids if p in pieces]
        else:
            parts[component] = []
        if not parts[component]:
            log.warning("replay: component %s has no element in the package; it is counted but not drawn", component)
    return parts


def _model_offset(pieces: dict[str, Piece], site) -> np.ndarray:
    """Model -> site translation (x, y), as `convert` placed the model (centres of the elements)."""
    centres = [piece.world_bounds(piece.installed_pose).mean(axis=0)[:2] for piece in pieces.values()]
    return site.offset_for_points(centres)


def _robots(schedule: list[dict], summary: dict, site, offset: np.ndarray, schedule_path: Path) -> dict[str, Robot]:
    """The robots that work in the schedule, in the fleet's order, with homes as `simulate` gives them
    (their own home, else the site's homes in turn) and their speeds from the fleet file: the one
    `simulate` wrote beside the schedule (``fleet.yaml``), else the fleet its summary names."""
    from bimrobot.site.fleet import load_fleet, schedule_fleet

    names = [r["robot"] for r in summary.get("robots", [])]
    kinds = {r["robot"]: r.get("kind", "") for r in summary.get("robots", [])}
    names += sorted({row["Robot"] for row in schedule} - set(names))
    specs, fleet = {}, None
    fleet_name = summary.get("fleet")
    if fleet_name:
        try:
            fleet = schedule_fleet(schedule_path) or load_fleet(fleet_name)
            specs = fleet.by_name
        except InputError as exc:  # the fleet file moved: robots drive at an assumed 1 m/s
            log.warning("replay: fleet %s not readable (%s); robots drive at 1 m/s in the replay", fleet_name, exc)
    robots = {}
    for index, name in enumerate(names):
        spec = specs.get(name)
        home_site = site.robot_start(index, fleet.home_on_site(spec, offset) if spec is not None else None)
        robots[name] = Robot(
            name=name, kind=kinds.get(name) or (spec.kind if spec else ""),
            home=site.to_model(np.asarray(home_site, float), offset),
            speed=spec.speed_m_s if spec is not None else 1.0,
            load_time=spec.load_s if spec is not None else 0.0,
            unload_time=spec.unload_s if spec is not None else 0.0,
        )
    return robots


def node_id_of(row: dict) -> str | None:
    """The connection node of an ``assemble`` row (``<relating>:<related>`` in its Name), or None."""
    words = row["Name"].split()
    return words[-1] if row["Activity"] == "assemble" and words and ":" in words[-1] else None


def _nodes(schedule: list[dict], pieces: dict[str, Piece], model) -> dict[str, Node]:
    """The connection nodes the schedule assembles, placed at their realizing parts (bolts, plates)
    or, without any, where the two elements' installed boxes meet."""
    nodes = {}
    for row in schedule:
        node_id = node_id_of(row)
        if node_id is None or node_id in nodes:
            continue
        relating, related = node_id.split(":", 1)
        realizing = tuple(
            r for c in model.connections if {c.relating_id, c.related_id} == {relating, related}
            for r in c.realizing_ids if r in pieces
        )
        nodes[node_id] = Node(node_id, _node_position(relating, related, realizing, pieces, row), realizing)
    return nodes


def _node_position(relating, related, realizing, pieces, row) -> np.ndarray:
    if realizing:
        boxes = [pieces[r].world_bounds(pieces[r].installed_pose) for r in realizing]
        return np.mean([b.mean(axis=0) for b in boxes], axis=0)
    if relating in pieces and related in pieces:
        a = pieces[relating].world_bounds(pieces[relating].installed_pose)
        b = pieces[related].world_bounds(pieces[related].installed_pose)
        low, high = np.maximum(a[0], b[0]), np.minimum(a[1], b[1])
        if np.all(high >= low - 0.05):
            return (low + high) / 2
        return (a.mean(axis=0) + b.mean(axis=0)) / 2
    return np.array([row["TargetX"], row["TargetY"], row["TargetZ"]])
