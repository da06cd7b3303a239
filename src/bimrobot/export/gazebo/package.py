"""Convert a BuildingModel into a Gazebo package (the thesis' IFC -> SDF conversion, fig. 3.5).

Layout of the package written by :func:`build_package`::

    <out>/
      models/<safe id>/model.config, model.sdf (1.9) [, model-1_6.sdf], meshes/<safe id>.dae, <safe id>_collision.stl
      worlds/<site>.sdf (SDF 1.9, Gazebo Sim) and/or worlds/<site>.world (SDF 1.6, Gazebo Classic)
      launch/gz_sim.launch.py (ROS 2) and/or launch/gazebo_classic.launch (ROS 1)
      maps/<storey>.pgm + .yaml (Nav2 map_server)
      report.json, README.md, package.xml, CMakeLists.txt

Everything is written into a temporary sibling directory and renamed into place at the end, so a
failed conversion leaves no output behind (:func:`bimrobot.core.io.atomic_output_dir`: a package bimrobot
wrote is replaced, any other non-empty folder is refused). Units: metres, kg, seconds; z up.

Elements whose weight the model does not give follow the one rule of
:mod:`bimrobot.bim.unknown_weight` (``--unknown-weight``): body volume x a density, or refused. Names
from the model (element names, file names) are escaped before they reach XML or the terminal.
"""

from __future__ import annotations

import json
import logging
import re
import time
from collections import Counter
from dataclasses import asdict, dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from bimrobot.core import io
from bimrobot.bim.model import BuildingModel, Element, WeightSource
from bimrobot.bim.unknown_weight import UnknownWeightRule, UnknownWeights, apply_unknown_weight_rule
from bimrobot.core.cores import frozen_heap
from bimrobot.core.errors import InputError
from bimrobot.core.io import printable
from bimrobot.site.site import Site, site_for
from bimrobot.export.gazebo import launch
from bimrobot.export.gazebo import layout
from bimrobot.export.gazebo import merge
from bimrobot.export.gazebo import meshes
from bimrobot.export.gazebo import navmap
from bimrobot.core import pool
from bimrobot.export.gazebo import sdf
from bimrobot.core.names import ros_package_name, safe_name, slug
from bimrobot.export.gazebo.render import PREVIEW_MAX_TRIANGLES, draw_preview, render_preview

if TYPE_CHECKING:  # mass properties need trimesh and SciPy: imported where the bodies are made
    from bimrobot.export import inertia as physics

log = logging.getLogger(__name__)

TARGETS = ("sim", "classic", "both", "mujoco")  # mujoco: the sim package + mujoco/scene.xml
LAYOUTS = ("installed", "yard")
COLLISIONS = ("convex", "decimated")


@dataclass
class ConvertOptions:
    """How to convert. Lengths in metres, densities in kg/m^3.

    ``static``: None means static models for the installed layout and dynamic ones on the yard (where
    robots pick them up). ``merge_static``: merge the static elements into one model per storey and
    IFC class, except the components robots handle: the classes in ``keep_separate`` (IFC class names,
    subclasses count), which keep one model per element. ``workers``: processes for the per-model
    work (default: every core). ``map_band``: (low, high) above each storey's elevation. ``max_triangles``:
    triangle budget of each collision mesh. ``unknown_weight``: the rule for elements without a weight
    in the model (:mod:`bimrobot.bim.unknown_weight`; default: volume x 2400 kg/m3). ``preview``: draw
    ``preview.png``, a picture of the world (:mod:`bimrobot.export.gazebo.render`).
    """

    target: str = "sim"
    static: bool | None = None
    layout: str = "installed"
    collision: str = "convex"
    max_triangles: int = 500
    map_resolution: float = 0.05
    map_band: tuple[float, float] = (0.1, 1.5)
    map_margin: float = 1.0
    package_name: str | None = None
    unknown_weight: UnknownWeightRule = field(default_factory=UnknownWeightRule)
    maps: bool = True
    merge_static: bool = False
    keep_separate: tuple[str, ...] = ()
    workers: int | None = None
    preview: bool = True  # skipped above render.PREVIEW_MAX_TRIANGLES visual triangles
    site: Site | None = None  # where the yard is (--layout yard); None: bimrobot.site.site.site_for decides

    def validate(self) -> None:
        """Raise InputError naming the first option that is out of range."""
        checks = [
            (self.target in TARGETS, f"--target must be one of {', '.join(TARGETS)}, not {self.target!r}"),
            (self.layout in LAYOUTS, f"--layout must be one of {', '.join(LAYOUTS)}, not {self.layout!r}"),
            (self.collision in COLLISIONS, f"--collision must be one of {', '.join(COLLISIONS)}, not {self.collision!r}"),
            (self.max_triangles >= 4, f"--max-triangles must be at least 4 (a tetrahedron), not {self.max_triangles}"),
            (self.map_resolution > 0, f"--map-resolution must be positive, not {self.map_resolution}"),
            (self.map_band[0] < self.map_band[1], f"--map-band must be LOW HIGH with LOW < HIGH, not {self.map_band}"),
            (self.map_margin >= 0, f"--map-margin must not be negative, not {self.map_margin}"),
            (isinstance(self.unknown_weight, UnknownWeightRule),
             f"--unknown-weight must be a density in kg/m3 or 'refuse', not {self.unknown_weight!r}"),
            (not self.merge_static or self.is_static,
             "--merge-static merges static models, but these models are dynamic (--dynamic or --layout yard): "
             "leave out --merge-static or use --static"),
            (not self.keep_separate or self.merge_static, "--keep-separate only applies with --merge-static"),
            (self.workers is None or self.workers >= 1, f"workers must be at least 1, not {self.workers}"),
        ]
        for ok, message in checks:
            if not ok:
                raise InputError(message)

    @property
    def is_static(self) -> bool:
        """Whether the models are static (fixed in the world)."""
        return self.static if self.static is not None else self.layout == "installed"


@dataclass
class _Geometry:
    """One distinct IFC geometry (shared by every element that uses it) and its mesh files' content
    (made by :meth:`finish` in the process that writes the models)."""

    body: physics.Body
    collision: tuple[np.ndarray, np.ndarray] | None = None
    stl: bytes = b""
    dae: dict[str, str] = field(default_factory=dict)  # IFC class -> DAE text (colour per class)

    def finish(self, options: "ConvertOptions") -> None:
        """Collision mesh and its STL, once per geometry."""
        if self.collision is None:
            self.collision = meshes.collision_mesh(self.body, options.collision, options.max_triangles)
            self.stl = meshes.stl_bytes(*self.collision)

    def dae_for(self, ifc_class: str) -> str:
        if ifc_class not in self.dae:
            self.dae[ifc_class] = meshes.dae_text(self.body.vertices, self.body.faces, ifc_class,
                                                  meshes.colour_of(ifc_class))
        return self.dae[ifc_class]


@dataclass
class _Converted:
    """One element on its way into the package."""

    element: Element
    name: str
    geometry: _Geometry
    mass: physics.MassProperties | None = None
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))
    model: str = ""  # the model that holds it: its own (``name``) or a merged one
    collision_triangles: int = 0

    @property
    def body(self) -> physics.Body:
        return self.geometry.body

    def finish(self, options: "ConvertOptions") -> None:
        """Collision mesh and mass properties (the latter may already be known, for the yard)."""
        self.geometry.finish(options)
        if self.mass is None:
            self.mass = self.body.mass_properties(self.element.weight_kg, options.unknown_weight.density_kg_m3)
        self.collision_triangles = len(self.geometry.collision[1])

    @cached_property
    def world_vertices(self) -> np.ndarray:
        """The body's vertices at the model's pose (world frame, m)."""
        return self.body.vertices @ self.pose[:3, :3].T + self.pose[:3, 3]


def convert(
    ifc_path: str | Path,
    out_dir: str | Path,
    options: ConvertOptions | None = None,
    include: list[str] | str | None = None,
    exclude: list[str] | str | None = None,
    progress: bool = False,
) -> dict:
    """Read an IFC file (``.ifc`` or ``.ifczip``) and write its Gazebo package to ``out_dir``; return
    the report (also in ``out_dir/report.json``). ``include`` / ``exclude``: IfcOpenShell selectors
    (:mod:`bimrobot.bim.selection`). Bad input raises InputError and leaves no ``out_dir``."""
    from bimrobot.bim.reader import load_model  # imported here: only bim/ touches ifcopenshell

    options = options or ConvertOptions()
    options.validate()
    io.check_output(out_dir, folder=True, inputs=[ifc_path])  # before the long read
    with frozen_heap():  # no full garbage collections through every library object on the way
        started = time.perf_counter()
        # Element.properties is not needed to convert: only what the weights need is read.
        model = load_model(ifc_path, include=include, exclude=exclude, progress=progress, properties=False,
                           unknown_weight=options.unknown_weight)
        load_seconds = time.perf_counter() - started
        return build_package(model, out_dir, options, progress, load_seconds)


def build_package(
    model: BuildingModel,
    out_dir: str | Path,
    options: ConvertOptions | None = None,
    progress: bool = False,
    load_seconds: float | None = None,
) -> dict:
    """Write the Gazebo package of ``model`` to ``out_dir`` atomically; return the report dict.

    Elements of unknown weight get their mass by ``options.unknown_weight`` when the model was read
    (``load_model(unknown_weight=...)``, the refusal listing them by class); a model read without the rule
    (or built in memory) gets it here, in place. ``report["unknown_weight"]`` says what was assumed.

    The steps: check the inputs and the output, lay the elements out (:func:`_lay_out`), write the models,
    maps, worlds, launch files and the picture (:func:`_write_package`), then the report and README.
    """
    options = options or ConvertOptions()
    options.validate()
    # the site (given, fig. 4.11, or derived) and the one placement of the building on it, in report.json
    options = replace(options, site=site_for(options.site, model.elements.values()))
    started = time.perf_counter()
    source = printable(str(model.source)) if model.source else "an in-memory BuildingModel"
    if not model.elements:
        raise InputError(f"{source}: the model has no element with solid geometry to convert")
    inputs = [model.source] if model.source else []
    io.check_output(out_dir, folder=True, inputs=inputs)
    out_dir = Path(out_dir)
    package = options.package_name or ros_package_name(out_dir.name)
    world_name = world_name_of(model)
    timings: dict[str, float] = {"load": load_seconds} if load_seconds is not None else {}
    unknown = model.unknown_weights  # the rule, applied once when the model was read
    if unknown is None or unknown.rule != options.unknown_weight:
        unknown = apply_unknown_weight_rule(model.elements.values(), options.unknown_weight, source)
    _refuse_weightless(model, options, source)
    with io.atomic_output_dir(out_dir, kind="convert", inputs=inputs) as tmp:
        laid = _lay_out(model, options, progress, source, timings)
        world_files, maps, preview = _write_package(tmp, model, laid, package, world_name, source, options, progress,
                                                    timings)
        timings["total"] = time.perf_counter() - started + (load_seconds or 0.0)
        report = _full_report(tmp, model, laid, package, world_name, world_files, maps, unknown, options, timings)
        # preview.png: a picture of the world (None: too large, or not asked for); drawn above from the
        # meshes in memory, or here from the package's files (merged models)
        if laid.in_memory_preview:
            report["preview"] = preview
        else:
            tick = time.perf_counter()
            report["preview"] = render_preview(tmp, laid.triangles) if laid.drawing else None
            timings["preview"] = time.perf_counter() - tick
            timings["total"] += timings["preview"]
        report["timings_s"]["preview"] = round(timings.get("preview", 0.0), 4)
        report["timings_s"]["total"] = round(timings["total"], 4)
        (tmp / "report.json").write_text(json.dumps(report, indent=2), encoding="utf-8")
        (tmp / "README.md").write_text(_readme(report), encoding="utf-8")
    log.info("wrote %s: %d models, %d skipped", out_dir, len(laid.converted), len(laid.skipped))
    return report


@dataclass
class _LaidOut:
    """The elements on their way into the package, placed (:func:`_lay_out`), and what follows from them."""

    converted: list[_Converted]
    skipped: list[dict]
    triangles: int  # visual triangles of the converted elements (the preview's, as report["converted"])
    drawing: bool  # whether preview.png is drawn
    ground_z: float  # m, world frame
    yard: layout.Yard | None
    merged: list[merge.MergedModel]
    in_memory_preview: bool  # drawn from the meshes in memory while the models are written


def _lay_out(model: BuildingModel, options: ConvertOptions, progress: bool, source: str,
             timings: dict[str, float]) -> _LaidOut:
    """The elements' bodies, the ground, every element's pose (installed or on the yard) and the merged
    models; ``timings["prepare"]`` (s)."""
    tick = time.perf_counter()
    converted, skipped = _prepare_elements(model, options, progress)
    if not converted:
        raise InputError(f"{source}: none of the {len(model.elements)} elements has a usable solid mesh")
    triangles = sum(len(item.body.faces) for item in converted)
    drawing = options.preview and triangles <= PREVIEW_MAX_TRIANGLES
    if options.layout == "yard":  # the yard lays parts on their centre of mass: needed before placing
        for item in converted:
            item.finish(options)
    ground_z = ground_height(model, [item.element for item in converted])
    yard = _place(converted, ground_z, options)
    merged = _merged_models(model, converted, options) if options.merge_static else []
    # preview.png is drawn from the meshes in memory while the workers write the models, unless
    # merged models (whose DAEs join many elements) are in the picture: those are read back at the end.
    in_memory_preview = drawing and not merged and options.target in ("sim", "both", "mujoco")
    timings["prepare"] = time.perf_counter() - tick
    return _LaidOut(converted, skipped, triangles, drawing, ground_z, yard, merged, in_memory_preview)


def _write_package(tmp: Path, model: BuildingModel, laid: _LaidOut, package: str, world_name: str, source: str,
                   options: ConvertOptions, progress: bool, timings: dict[str, float]):
    """Write the models, maps, worlds and launch files into ``tmp``, and draw preview.png from memory when
    ``laid.in_memory_preview``; return (world files, map report entries, the picture's name or None).

    Models and maps are made by every core (bimrobot.core.pool) while this process writes the worlds
    and launch files and draws preview.png; results come back as the tasks finish. The maps (the
    longest tasks) come first. ``timings["models_and_maps"]``, ``["preview"]`` (s)."""
    converted, merged = laid.converted, laid.merged
    tick = time.perf_counter()
    plan = _plan_maps(model, converted, options, laid.ground_z) if options.maps else _MapPlan([], (0.0, 0.0), (1, 1))
    (tmp / "models").mkdir()
    if plan.levels:
        (tmp / "maps").mkdir()
    pool.shared.update(converted=converted, merged=merged, models_dir=tmp / "models", options=options,
                       source=source, maps_dir=tmp / "maps", map_plan=plan)
    tasks = [("map", level) for level in range(len(plan.levels))] + _model_tasks(converted, merged, options)
    drawn: dict[int, dict] = {}
    preview = None
    try:
        parallel = len(converted) >= POOL_MIN_ELEMENTS or options.workers is not None
        with pool.Tasks(_model_task, tasks, options.workers, parallel) as running:
            world_files = _write_worlds(tmp / "worlds", world_name, converted, merged, options, laid.ground_z)
            _write_launch_and_ros(tmp, package, world_name, world_files, source, options)
            if laid.in_memory_preview:  # this process would wait for the workers: it draws the picture meanwhile
                painting = time.perf_counter()
                preview = draw_preview(tmp, world_name, _preview_models(converted))
                timings["preview"] = time.perf_counter() - painting
            bar = _bar(None, progress, total=len(converted), desc="models", unit="element")
            for results in running.results():
                _apply_results(converted, merged, drawn, results)
                bar.update(len(results[0]))
            bar.close()
    finally:
        pool.shared.clear()
    timings["models_and_maps"] = time.perf_counter() - tick
    return world_files, [drawn[level] for level in sorted(drawn)], preview


def _full_report(tmp: Path, model: BuildingModel, laid: _LaidOut, package: str, world_name: str,
                 world_files: dict[str, str], maps: list[dict], unknown: UnknownWeights, options: ConvertOptions,
                 timings: dict[str, float]) -> dict:
    """The report of the written package (report.json but its preview and final timings); writes the
    MuJoCo scene beside the package for ``--target mujoco``."""
    converted, merged = laid.converted, laid.merged
    report = _report(model, package, world_name, world_files, converted, laid.skipped, maps, laid.yard, options,
                     timings)
    if merged:
        report["merged_models"] = [m.as_report() for m in merged]
    report["counts"]["models"] = len(converted) - sum(len(m.members) for m in merged) + len(merged)
    report["unknown_weight"] = _unknown_weight_report(unknown, converted, options)
    duplicates = _duplicate_keys(converted)
    if duplicates:
        report["duplicate_global_ids"] = duplicates
    report["ground_z_m"] = laid.ground_z
    report["warnings"] = _warnings(converted, options, laid.ground_z)
    if options.target == "mujoco":  # the MJCF scene beside the package (bimrobot.export.mujoco.scene)
        from bimrobot.export.mujoco.scene import write_scene

        report["mujoco"] = write_scene(tmp, converted, options, laid.ground_z, laid.yard)
    for warning in report["warnings"]:
        log.info("%s", warning)  # the CLI prints them in its summary
    return report


def final_path(text: str) -> str:
    """``text`` with a resumable command's partial folder (``.NAME.partial``, :func:`bimrobot.core.io.partial_folder`)
    replaced by the folder it becomes when the command finishes (``NAME``): e.g. ``build``'s
    ``out/.b.partial/site.yaml`` is ``out/b/site.yaml`` once the build is renamed into place. Other text
    is returned unchanged."""
    return re.sub(r"(^|/)\.([^/]+)\.partial(?=/|$)", r"\1\2", text)


GENERIC_SITE_NAMES = {"", "site", "default", "default_site", "surface", "topography", "topography_surface",
                      "unnamed", "my_site", "undefined", "none", "null", "unknown", "untitled", "project",
                      "default_project", "building", "default_building", "world"}
"""Slugs of names authoring tools write by default (Revit: "Topography : Surface", "Default"; Tekla:
"Undefined"; IfcOpenShell: "My Site"); they do not name a world, a map or a file."""

GENERIC_STOREY_NAMES = {"", "undefined", "default", "storey", "building_storey", "level", "unnamed", "none",
                        "null", "unknown", "untitled"}
"""Slugs of storey names that say nothing (Tekla exports one storey named "Undefined")."""


def _is_generic(name: str, generic: set[str]) -> bool:
    # "Site #1", "Level 2" keep a number: "site_1" is generic, "level_2" is not (a storey needs its number);
    # "表面:335313" slugs to "335313": a number alone names nothing.
    return name in generic or name.replace("_", "").isdigit() or bool(re.fullmatch(r"(site|default)_\d+", name))


def world_name_of(model: BuildingModel) -> str:
    """The world's name and file stem: the IfcSite's name, unless it is a tool default ("Undefined",
    "Default", "Topography : Surface", ...); then the IFC file's name, then the project's, then "building"."""
    candidates = [model.site_name or "", model.source.stem if model.source else "", model.project_name or ""]
    for candidate in candidates:
        name = slug(candidate, "")
        if not _is_generic(name, GENERIC_SITE_NAMES):
            return name
    return "building"


def _map_name(storey_name: str, index: int) -> str:
    """File stem of a storey's map: its name (``storey_2`` for a storey named "2"), or ``storey_<n>``
    (n from 1, lowest first) for a name that says nothing ("Undefined", "Default", empty)."""
    name = slug(storey_name, "")
    if name.isdigit():
        return f"storey_{name}"
    return f"storey_{index}" if _is_generic(name, GENERIC_STOREY_NAMES) else name


def _refuse_weightless(model: BuildingModel, options: ConvertOptions, source: str) -> None:
    """With ``--unknown-weight refuse``, also refuse elements whose model weight is zero or negative."""
    if options.unknown_weight.density_kg_m3 is not None:
        return
    bad = [e for e in model.elements.values() if e.weight_kg is None or e.weight_kg <= 0]
    if bad:
        classes = ", ".join(f"{n} {c}" for c, n in Counter(e.ifc_class for e in bad).most_common())
        raise InputError(
            f"{source}: {len(bad)} element(s) have a weight of 0 kg or less in the model ({classes}, e.g. "
            f"{printable(bad[0].global_id)}) and --unknown-weight is refuse; give a density such as --unknown-weight 2400"
        )


def _unknown_weight_report(unknown: UnknownWeights, converted: list, options: ConvertOptions) -> dict:
    """``unknown.as_dict()`` plus the one-line message; elements that had no closed volume for the rule
    get the mass physics gave them (the same density over their convex hull or box)."""
    entry = unknown.as_dict()
    for item in converted:
        if item.element.global_id in entry["elements"] and entry["elements"][item.element.global_id] is None:
            entry["elements"][item.element.global_id] = round(item.mass.mass, 3)
    entry["message"] = unknown.message()
    return entry


def _duplicate_keys(converted: list) -> dict[str, list[str]]:
    """GlobalId -> the model names of the elements that share it (keys ``<GlobalId>#<step id>``)."""
    groups: dict[str, list[str]] = {}
    for item in converted:
        groups.setdefault(item.element.global_id.split("#")[0], []).append(item.element.global_id)
    return {gid: keys for gid, keys in groups.items() if len(keys) > 1}


def _bar(iterable, progress: bool, **options):
    """A tqdm progress bar over ``iterable`` (None: updated by hand), shown only with ``progress``;
    tqdm is imported only then."""
    if progress:
        from tqdm import tqdm

        return tqdm(iterable, leave=False, **options)
    return _NoBar(iterable)


class _NoBar:
    """What the code uses of a tqdm bar when none is shown: iteration, update and close."""

    def __init__(self, iterable):
        self.iterable = iterable

    def __iter__(self):
        return iter(self.iterable)

    def update(self, count: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


def _prepare_elements(model: BuildingModel, options: ConvertOptions, progress: bool):
    """Each element with its body (duplicate vertices merged, once per distinct IFC geometry); the
    collision meshes and mass properties follow in the processes that write the models."""
    converted: list[_Converted] = []
    skipped = [
        {"global_id": s.global_id, "ifc_class": s.ifc_class, "name": s.name, "reason": s.reason} for s in model.skipped
    ]
    elements = list(model.elements.values())
    geometries: dict[tuple[int, int], _Geometry] = {}  # IFC files share one mesh between many elements
    from bimrobot.export.inertia import Body

    for element in _bar(elements, progress, desc="meshes", unit="element"):
        if len(element.faces) == 0 or len(element.vertices) < 3:
            skipped.append(_skip(element, "its body has no triangles"))
            continue
        key = (id(element.vertices), id(element.faces))
        if key not in geometries:
            geometries[key] = _Geometry(Body(element.vertices, element.faces))
        geometry = geometries[key]
        if len(geometry.body.faces) == 0:
            skipped.append(_skip(element, "its body has only degenerate triangles"))
            continue
        name = safe_name(element.global_id)
        converted.append(_Converted(element, name, geometry, model=name))
    return converted, skipped


def _merged_models(model: BuildingModel, converted: list[_Converted], options: ConvertOptions) -> list[merge.MergedModel]:
    """Group the elements that are not of a ``keep_separate`` class by (storey, IFC class) into merged
    models (bimrobot.export.gazebo.merge); set each member's ``model``. Raises InputError for a class name the
    schema does not have."""
    from bimrobot.bim.reader import class_lineage  # bim/ owns the IFC schema

    keep = set()
    for name in options.keep_separate:
        if class_lineage(model.schema or "IFC4", name) is None:
            present = ", ".join(sorted({item.element.ifc_class for item in converted}))
            raise InputError(f"--keep-separate names '{printable(name)}', which is not an {model.schema} class "
                             f"(this model's element classes: {present})")
        keep.add(name.lower())
    lineage: dict[str, set[str]] = {}
    groups: dict[tuple[str | None, str], list[int]] = {}
    for index, item in enumerate(converted):
        cls = item.element.ifc_class
        if cls not in lineage:
            lineage[cls] = {n.lower() for n in (class_lineage(model.schema or "IFC4", cls) or (cls,))}
        if not lineage[cls] & keep:
            groups.setdefault((item.element.storey_id, cls), []).append(index)
    storeys = {s.global_id: s.name for s in model.storeys}
    ordered = sorted(model.storeys, key=lambda s: s.elevation)
    storey_slugs = {s.global_id: _map_name(s.name, index) for index, s in enumerate(ordered, start=1)}  # as the maps
    taken = {item.name for item in converted}
    merged = []
    for (storey_id, cls), members in groups.items():
        storey_name = storeys.get(storey_id, "") if storey_id else ""
        name = _unique(f"merged_{storey_slugs.get(storey_id, 'no_storey')}_{slug(cls, 'element')}", taken)
        lower = np.min([converted[i].world_vertices.min(axis=0) for i in members], axis=0)
        pose = np.eye(4)
        pose[:3, 3] = np.round(lower, 3)  # a round origin near the group: small mesh coordinates
        for i in members:
            converted[i].model = name
        merged.append(merge.MergedModel(name, storey_id, storey_name, cls, members, pose))
    return merged


def _unique(name: str, taken: set[str]) -> str:
    candidate, number = name, 2
    while candidate in taken:
        candidate, number = f"{name}_{number}", number + 1
    taken.add(candidate)
    return candidate


# ---- per-model work (runs in the pool's processes; see bimrobot.core.pool) --------------------------

POOL_MIN_ELEMENTS = 32
"""Below this many elements the models are written in-process: starting the worker processes (about
40 ms) would cost more than it saves (about 1 ms per element and core)."""

PER_MODEL_COST = 400
"""Cost of one model's files in triangle-equivalents, for balancing the tasks (measured: writing a model's
four files and two folders takes about as long as the hull and mass integrals of a 400-triangle body)."""


def _model_tasks(converted: list[_Converted], merged: list[merge.MergedModel], options: ConvertOptions) -> list:
    """Tasks for :func:`_model_task`: ("models", indices) chunks that keep the elements of one geometry
    together (its DAE and STL are made once), and one ("merged", index) task per merged model."""
    in_merged = {i for m in merged for i in m.members}
    groups: dict[int, list[int]] = {}
    for index, item in enumerate(converted):
        if index not in in_merged:
            groups.setdefault(id(item.geometry), []).append(index)
    chunks = list(groups.values())
    costs = [len(converted[g[0]].body.faces) + PER_MODEL_COST * len(g) for g in chunks]
    count = 4 * (options.workers or pool.cores())  # small enough to balance, large enough to share the work
    tasks: list = [("models", chunk) for chunk in pool.balanced_chunks(chunks, costs, count)]
    tasks += [("merged", index) for index in range(len(merged))]
    return tasks


def _model_task(task) -> tuple[list, dict | None]:
    """Do one task: ("map", level) draws a storey's map, ("models", indices) writes elements' models,
    ("merged", index) a merged model. Returns ([(element index, mass properties, collision triangles)],
    the map's report entry, the merged model's figures, or None)."""
    kind, payload = task
    converted, options = pool.shared["converted"], pool.shared["options"]
    models_dir, source = pool.shared["models_dir"], pool.shared["source"]
    if kind == "map":
        entry = _write_map(pool.shared["maps_dir"], converted, pool.shared["map_plan"], payload, options)
        return [], {"map": payload, "entry": entry}
    if kind == "merged":
        merged = pool.shared["merged"][payload]
        items = [converted[i] for i in merged.members]
        for item in items:
            item.finish(options)
        figures = merge.write_merged_model(models_dir, merged, items, _sdf_versions(options), source)
        return [(i, converted[i].mass, converted[i].collision_triangles) for i in merged.members], figures
    results = []
    for index in payload:
        item = converted[index]
        item.finish(options)
        _write_model(models_dir, item, options, source)
        results.append((index, item.mass, item.collision_triangles))
    return results, None


def _apply_results(converted: list[_Converted], merged: list[merge.MergedModel], maps: dict[int, dict],
                   results: tuple) -> None:
    """Copy what a task computed (possibly in another process) onto this process's elements and maps."""
    rows, figures = results
    for index, mass, triangles in rows:
        converted[index].mass = mass
        converted[index].collision_triangles = triangles
    if figures is not None and "map" in figures:
        maps[figures["map"]] = figures["entry"]
    elif figures is not None:
        next(m for m in merged if m.name == figures["name"]).figures = figures


def _preview_models(converted: list[_Converted]) -> list[tuple[str, str, np.ndarray, np.ndarray, str]]:
    """What preview.png shows of each element's own model: its name, the pose text of its world
    include, the mesh its DAE holds and the DAE's colour text (bimrobot.export.gazebo.render.mesh_triangles)."""
    return [
        (item.name, layout.format_pose(item.pose), item.body.vertices, item.body.faces,
         meshes.colour_text(meshes.colour_of(item.element.ifc_class)))
        for item in converted if item.model == item.name
    ]


def _skip(element: Element, reason: str) -> dict:
    return {"global_id": element.global_id, "ifc_class": element.ifc_class, "name": element.name, "reason": reason}


def ground_height(model: BuildingModel, elements: list[Element]) -> float:
    """World z of the ground plane: the lowest storey's elevation, else the lowest element point (m)."""
    if model.storeys:
        return min(storey.elevation for storey in model.storeys)
    return float(min(e.world_bounds[0][2] for e in elements))


def _place(converted: list[_Converted], ground_z: float, options: ConvertOptions) -> layout.Yard | None:
    elements = [item.element for item in converted]
    if options.layout == "yard":
        centers = {item.element.global_id: item.mass.center_of_mass for item in converted}
        poses, yard = layout.yard_poses(elements, ground_z, centers_of_mass=centers, site=options.site)
    else:
        poses, yard = layout.installed_poses(elements), None
    for item in converted:
        item.pose = poses[item.element.global_id]
    return yard


def _sdf_versions(options: ConvertOptions) -> dict[str, str]:
    """SDF version -> model file name for the target."""
    if options.target in ("sim", "mujoco"):
        return {sdf.SIM_VERSION: "model.sdf"}
    if options.target == "classic":
        return {sdf.CLASSIC_VERSION: "model.sdf"}
    return {sdf.SIM_VERSION: "model.sdf", sdf.CLASSIC_VERSION: "model-1_6.sdf"}


def _write_model(models_dir: Path, item: _Converted, options: ConvertOptions, source: str) -> None:
    """models/<name>/: model.config, model.sdf (and model-1_6.sdf), meshes/<name>.dae and _collision.stl."""
    versions = _sdf_versions(options)
    folder = models_dir / item.name
    folder.mkdir()  # models_dir exists; two calls, not mkdir(parents=True)'s three (a failed one first)
    (folder / "meshes").mkdir()
    visual_file = f"{item.name}.dae"
    collision_file = f"{item.name}_collision.stl"
    element = item.element
    (folder / "meshes" / visual_file).write_text(item.geometry.dae_for(element.ifc_class), encoding="utf-8")
    (folder / "meshes" / collision_file).write_bytes(item.geometry.stl)
    spec = sdf.ModelSpec(
        name=item.name,
        pose=item.pose,
        static=options.is_static,
        mass=item.mass.mass,
        center_of_mass=item.mass.center_of_mass,
        inertia=item.mass.inertia,
        visual_uri=f"model://{item.name}/meshes/{visual_file}",
        collision_uri=f"model://{item.name}/meshes/{collision_file}",
    )
    for version, file_name in versions.items():
        (folder / file_name).write_text(sdf.model_sdf(spec, version), encoding="utf-8")
    description = f'{element.ifc_class} "{printable(element.name)}" (IFC GlobalId {printable(element.global_id)}) from {source}'
    (folder / "model.config").write_text(sdf.model_config(item.name, versions, description), encoding="utf-8")


def _world_extent(converted: list[_Converted]) -> np.ndarray:
    """[[xmin, ymin, zmin], [xmax, ymax, zmax]] of the corners of every model's local bounding box at
    its world pose (m)."""
    lower = np.array([item.body.vertices.min(axis=0) for item in converted])
    upper = np.array([item.body.vertices.max(axis=0) for item in converted])
    pick = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=bool)  # 8 corners
    corners = np.where(pick[None], upper[:, None, :], lower[:, None, :])  # (n, 8, 3)
    poses = np.array([item.pose for item in converted])
    world = np.einsum("nij,nkj->nki", poses[:, :3, :3], corners) + poses[:, None, :3, 3]
    stacked = world.reshape(-1, 3)
    return np.array([stacked.min(axis=0), stacked.max(axis=0)])


def _write_worlds(
    worlds_dir: Path, world_name: str, converted: list[_Converted], merged: list[merge.MergedModel],
    options: ConvertOptions, ground_z: float,
) -> dict[str, str]:
    """Write the world file(s); return {"sim"|"classic": file name}. Includes: the elements' own models
    in element order, then the merged models."""
    worlds_dir.mkdir(parents=True)
    extent = _world_extent(converted)
    includes = [sdf.Include(item.name, item.pose) for item in converted if item.model == item.name]
    includes += [sdf.Include(m.name, m.pose) for m in merged]
    center = tuple(((extent[0, :2] + extent[1, :2]) / 2).tolist())
    size = tuple((extent[1, :2] - extent[0, :2] + 40.0).tolist())
    files = {}
    if options.target in ("sim", "both", "mujoco"):
        files["sim"] = f"{world_name}.sdf"
        text = sdf.world_sdf(world_name, includes, sdf.SIM_VERSION, ground_z, size, center)
        (worlds_dir / files["sim"]).write_text(text, encoding="utf-8")
    if options.target in ("classic", "both"):
        files["classic"] = f"{world_name}.world"
        text = sdf.world_sdf(world_name, includes, sdf.CLASSIC_VERSION, ground_z, size, center)
        (worlds_dir / files["classic"]).write_text(text, encoding="utf-8")
    return files


def _write_launch_and_ros(tmp: Path, package: str, world_name: str, world_files: dict[str, str], source: str,
                          options: ConvertOptions) -> None:
    launch_dir = tmp / "launch"
    launch_dir.mkdir()
    source_name = Path(source).name
    if "sim" in world_files:
        text = launch.ros2_launch(package, world_name, world_files["sim"], source_name)
        (launch_dir / "gz_sim.launch.py").write_text(text, encoding="utf-8")
    if "classic" in world_files:
        text = launch.ros1_launch(package, world_name, world_files["classic"], source_name)
        (launch_dir / "gazebo_classic.launch").write_text(text, encoding="utf-8")
    (tmp / "package.xml").write_text(launch.package_xml(package, source_name), encoding="utf-8")
    (tmp / "CMakeLists.txt").write_text(launch.cmakelists(package), encoding="utf-8")


@dataclass
class _MapPlan:
    """The maps to draw: one level per storey (name, storey id and name, elevation, band) in one grid frame."""

    levels: list[tuple[str, str | None, str, float, tuple[float, float]]]
    origin: tuple[float, float]
    shape: tuple[int, int]


def _plan_maps(model: BuildingModel, converted: list[_Converted], options: ConvertOptions, ground_z: float) -> _MapPlan:
    extent = _world_extent(converted)
    origin, shape = navmap.grid_frame(extent[:, :2], options.map_margin, options.map_resolution)
    storeys = sorted(model.storeys, key=lambda s: s.elevation)
    levels = [(s.global_id, s.name, s.elevation) for s in storeys] or [(None, "site", ground_z)]
    used: set[str] = set()
    planned = []
    for index, (storey_id, storey_name, elevation) in enumerate(levels, start=1):
        name = _map_name(storey_name, index) if storey_id else "site"
        if name in used:
            name = f"{name}_{safe_name(storey_id) if storey_id else len(used)}"
        used.add(name)
        band = (elevation + options.map_band[0], elevation + options.map_band[1])
        planned.append((name, storey_id, storey_name, elevation, band))
    return _MapPlan(planned, origin, shape)


def _write_map(maps_dir: Path, converted: list[_Converted], plan: _MapPlan, level: int, options: ConvertOptions) -> dict:
    """Draw and write one storey's map; return its report entry."""
    name, storey_id, storey_name, elevation, band = plan.levels[level]
    bodies = [(item.world_vertices, item.body.faces) for item in converted]
    occupied = navmap.occupancy(bodies, band, plan.origin, plan.shape, options.map_resolution)
    grid = navmap.OccupancyGrid(name, storey_id, storey_name, elevation, band, options.map_resolution, plan.origin, occupied)
    pgm, yaml_file = navmap.write_map(grid, maps_dir)
    return {
        "image": f"maps/{pgm.name}",
        "yaml": f"maps/{yaml_file.name}",
        "storey_id": storey_id,
        "storey_name": storey_name,
        "elevation_m": elevation,
        "band_z_m": list(band),
        "resolution_m": options.map_resolution,
        "origin_m": list(plan.origin),
        "size_px": [plan.shape[1], plan.shape[0]],
        "occupied_cells": int(occupied.sum()),
    }


FAR_FROM_ORIGIN_M = 1000.0
"""Beyond this distance from the world origin, single-precision meshes and physics lose millimetres."""


def _warnings(converted: list[_Converted], options: ConvertOptions, ground_z: float) -> list[str]:
    """Things a user should know before starting the simulation (also logged)."""
    warnings = []
    extent = _world_extent(converted)
    if not options.is_static:
        below = [item.name for item in converted if item.world_vertices[:, 2].min() < ground_z - 1e-6]
        if below:
            warnings.append(
                f"{len(below)} dynamic model(s) reach below the ground plane at z = {ground_z:g} m (e.g. {below[0]}); "
                "the physics engine will push them up at the start: use --static, --layout yard or --exclude their class"
            )
    suspect = [(item, reason) for item in converted if (reason := _suspect_weight(item))]
    if suspect:
        item, reason = suspect[0]
        warnings.append(
            f"{len(suspect)} model(s) have a weight from the model that is not plausible, e.g. {item.element.ifc_class} "
            f"{printable(item.element.name)!r} ({item.element.global_id}): {reason}; their masses are as the model "
            "says (report.json: weight_suspect; correct the model's weights, or --exclude them)"
        )
    # say what is far out: the building itself (its IFC coordinates), or only the yard the site puts it on
    installed = max(float(np.abs(item.element.world_bounds).max()) for item in converted)
    distance = float(np.abs(extent).max())
    if installed > FAR_FROM_ORIGIN_M:
        warnings.append(
            f"the model lies up to {installed:.0f} m from the world origin; Gazebo's single-precision meshes and "
            "physics lose accuracy that far out: move the IFC project origin near the building"
        )
    elif distance > FAR_FROM_ORIGIN_M:
        source = options.site.source if options.site is not None else "the site"
        warnings.append(
            f"the yard lies up to {distance:.0f} m from the world origin while the building stands within "
            f"{installed:.0f} m of it; Gazebo's single-precision meshes and physics lose accuracy that far out: "
            f"give a --site whose yard is near the building ({source})"
        )
    return warnings


def _suspect_weight(item: _Converted) -> str | None:
    """Why the weight the model gives an element is not plausible (the rule `bimrobot inspect` applies:
    :func:`bimrobot.bim.quantities.weight_check`), or None."""
    from bimrobot.bim.quantities import weight_check

    element = item.element
    return weight_check(element.weight_kg, element.weight_source, element.volume_m3, element.density_kg_m3)


def _report(model, package, world_name, world_files, converted, skipped, maps, yard, options, timings) -> dict:
    entries = []
    for item in converted:
        element, mass = item.element, item.mass
        x, y, z, roll, pitch, yaw = layout.pose_xyz_rpy(item.pose)
        entries.append({
            "global_id": element.global_id,
            "model": item.model,
            "ifc_class": element.ifc_class,
            "name": element.name,
            "storey_id": element.storey_id,
            "material": element.material,
            "mass_kg": round(mass.mass, 6),
            "weight_source": _weight_source(element, mass, options),
            "bim_weight_kg": element.weight_kg,
            "volume_m3": round(mass.volume, 9),
            "inertia_from": mass.inertia_method,
            "center_of_mass_m": [round(float(v), 6) for v in mass.center_of_mass],
            "visual_triangles": int(len(item.body.faces)),
            "collision_triangles": int(item.collision_triangles),
            "pose_xyz_rpy": [round(v, 9) for v in (x, y, z, roll, pitch, yaw)],
        })
        suspect = _suspect_weight(item)
        if suspect:
            entries[-1]["weight_suspect"] = suspect
    counts_by_source: dict[str, int] = {}
    for entry in entries:
        counts_by_source[entry["weight_source"]] = counts_by_source.get(entry["weight_source"], 0) + 1
    by_class: dict[str, int] = {}
    for entry in entries:
        by_class[entry["ifc_class"]] = by_class.get(entry["ifc_class"], 0) + 1
    options_dict = json.loads(json.dumps(asdict(options), default=str))  # a work calendar's times as "07:00:00"
    options_dict["static"] = options.is_static
    if options_dict.get("site"):  # a site file in a build's partial folder: where it is once the build is done
        options_dict["site"]["source"] = final_path(options_dict["site"]["source"])
    return {
        "generator": io.signature("convert"),
        "source": str(model.source) if model.source else None,
        "schema": model.schema,
        "project": model.project_name,
        "site": model.site_name,
        "units": model.units,
        "package": package,
        "world": world_name,
        "world_files": {key: f"worlds/{value}" for key, value in world_files.items()},
        "options": options_dict,
        "counts": {
            "converted": len(entries),
            "skipped": len(skipped),
            "by_class": dict(sorted(by_class.items())),
            "weight_sources": dict(sorted(counts_by_source.items())),
            "storeys": len(model.storeys),
            "connections": len(model.connections),
            "maps": len(maps),
            "total_mass_kg": round(sum(e["mass_kg"] for e in entries), 3),
        },
        "converted": entries,
        "skipped": skipped,
        "maps": maps,
        "yard": None if yard is None else {"bounds_xy_m": yard.bounds.round(6).tolist(), "ground_z_m": yard.ground_z},
        "timings_s": {key: round(value, 4) for key, value in timings.items()},
    }


def _weight_source(element: Element, mass: physics.MassProperties, options: ConvertOptions) -> str:
    """Where the model's mass came from, in words (the same words for both ways of assuming it)."""
    if element.weight_source is WeightSource.ASSUMED or mass.mass_assumed:  # the material the rule chose
        assumed = element.weight_assumed_as or f"{options.unknown_weight.density_kg_m3:g} kg/m3"
        return f"assumed: volume x {assumed} (--unknown-weight)"
    return element.weight_source.value


def _readme(report: dict) -> str:
    counts = report["counts"]
    worlds = ", ".join(f"`{path}`" for path in report["world_files"].values())
    assumed = sum(1 for e in report["converted"] if e["weight_source"].startswith("assumed"))
    lines = [
        f"# {report['package']}: Gazebo package of {printable(Path(report['source'] or 'model').name)}",
        "",
        f"{report['generator'][:1].upper()}{report['generator'][1:]}: {counts['converted']} building elements as Gazebo models "
        f"(total {counts['total_mass_kg']} kg), {counts['skipped']} products skipped (see `report.json`).",
        "",
        f"- `worlds/`: {worlds} (ground, sun, physics, every element at its "
        f"{'yard pick-up' if report['options']['layout'] == 'yard' else 'installed'} pose)",
        "- `models/<id>/`: one model per element, named by its IFC GlobalId made file-safe (`$` -> `-`); "
        "visual `meshes/<id>.dae` (metres, Z up), collision `meshes/<id>_collision.stl` "
        f"({report['options']['collision']}, <= {report['options']['max_triangles']} triangles), "
        f"{'static' if report['options']['static'] else 'dynamic'}",
        *([f"- `models/merged_<storey>_<class>/`: {sum(m['elements'] for m in report['merged_models'])} static "
           f"elements merged into {len(report['merged_models'])} models, one per storey and IFC class "
           "(`--merge-static`; report.json names each element's model)"] if report.get("merged_models") else []),
        "- `maps/<storey>.pgm/.yaml`: occupancy grids per storey for Nav2 map_server "
        f"(band {report['options']['map_band'][0]}..{report['options']['map_band'][1]} m above the storey)",
        "- `report.json`: every element's mass and weight source, the skipped products and why, timings",
        "",
    ]
    if assumed:
        lines += [
            f"{assumed} element(s) had no weight in the BIM: their mass is volume x "
            f"{report['options']['unknown_weight']['density_kg_m3']:g} kg/m3 (`--unknown-weight`; see "
            "`weight_source` and `unknown_weight` in report.json).",
            "",
        ]
    lines += [
        "## Gazebo Sim with ROS 2 (Jazzy / Harmonic)",
        "",
        "```bash",
        "# as a ROS package",
        "cp -r . ~/ros2_ws/src/" + report["package"] + " && cd ~/ros2_ws && colcon build && source install/setup.bash",
        f"ros2 launch {report['package']} gz_sim.launch.py",
        "# or straight from this folder",
        "ros2 launch launch/gz_sim.launch.py",
        "# or Gazebo alone",
        "GZ_SIM_RESOURCE_PATH=$PWD/models gz sim -r worlds/" + report["world"] + ".sdf",
        "```",
        "",
        "The world lists no `<plugin>`, so Gazebo Sim loads its default systems; if you add a plugin, "
        "add the Physics, UserCommands and SceneBroadcaster systems too.",
        "",
        "A map for Nav2: `ros2 run nav2_map_server map_server --ros-args -p yaml_filename:=maps/<storey>.yaml`.",
        "",
        "## Gazebo Classic with ROS 1 (end of life)",
        "",
        "Convert with `--target classic` (or `both`), then `roslaunch launch/gazebo_classic.launch`, or "
        "`GAZEBO_MODEL_PATH=$PWD/models gazebo worlds/" + report["world"] + ".world`.",
        "",
    ]
    return "\n".join(lines)
