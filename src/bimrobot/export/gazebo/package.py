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
import time
from collections import Counter
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from bimrobot.core import io
from bimrobot.bim.model import BuildingModel, Element
from bimrobot.bim.unknown_weight import UnknownWeights, apply_unknown_weight_rule
from bimrobot.core.errors import InputError
from bimrobot.core.io import printable
from bimrobot.site.site import site_for
from bimrobot.export.gazebo import launch
from bimrobot.export.gazebo import layout
from bimrobot.export.gazebo.bodies import Geometries, Geometry
from bimrobot.export.gazebo import meshes
from bimrobot.core import pool, written
from bimrobot.export.gazebo import sdf
from bimrobot.core.names import ros_package_name, safe_name, slug
from bimrobot.export.gazebo.render import PREVIEW_MAX_TRIANGLES, draw_preview, render_preview
from bimrobot.export.gazebo.naming import map_name, world_name_of
from bimrobot.export.gazebo.storey_maps import MapPlan, plan_maps, write_map
from bimrobot.export.gazebo.options import ConvertOptions
from bimrobot.export.gazebo.package_report import (duplicate_keys, package_report, readme_text, unknown_weight_report,
                                                   warnings_of)

if TYPE_CHECKING:  # mass properties need trimesh and SciPy: imported where the bodies are made
    from bimrobot.export import inertia as physics
    from bimrobot.export.gazebo import merge  # --merge-static only: imported by the work that needs it

log = logging.getLogger(__name__)

@dataclass
class _Converted:
    """One element on its way into the package."""

    element: Element
    name: str
    geometry: Geometry
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
        (tmp / "README.md").write_text(readme_text(report), encoding="utf-8")
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
    plan = plan_maps(model, _world_extent(converted), options, laid.ground_z) if options.maps else MapPlan([], (0.0, 0.0), (1, 1))
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
    report = package_report(model, package, world_name, world_files, converted, laid.skipped, maps, laid.yard, options,
                     timings)
    if merged:
        report["merged_models"] = [m.as_report() for m in merged]
    report["counts"]["models"] = len(converted) - sum(len(m.members) for m in merged) + len(merged)
    report["unknown_weight"] = unknown_weight_report(unknown, converted, options)
    duplicates = duplicate_keys(converted)
    if duplicates:
        report["duplicate_global_ids"] = duplicates
    report["ground_z_m"] = laid.ground_z
    report["warnings"] = warnings_of(converted, options, laid.ground_z, _world_extent(converted))
    if options.target == "mujoco":  # the MJCF scene beside the package (bimrobot.export.mujoco.scene)
        from bimrobot.export.mujoco.scene import write_scene

        report["mujoco"] = write_scene(tmp, converted, options, laid.ground_z, laid.yard)
    for warning in report["warnings"]:
        log.info("%s", warning)  # the CLI prints them in its summary
    return report


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
    geometries = Geometries()
    for element in _bar(elements, progress, desc="meshes", unit="element"):
        if len(element.faces) == 0 or len(element.vertices) < 3:
            skipped.append(_skip(element, "its body has no triangles"))
            continue
        geometry = geometries.of(element)
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
    from bimrobot.export.gazebo import merge

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
    storey_slugs = {s.global_id: map_name(s.name, index) for index, s in enumerate(ordered, start=1)}  # as the maps
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
        entry = write_map(pool.shared["maps_dir"], converted, pool.shared["map_plan"], payload, options)
        return [], {"map": payload, "entry": entry}
    if kind == "merged":
        from bimrobot.export.gazebo import merge

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
    # written.*: the output marker takes these files' digests from the bytes written (bimrobot.core.written)
    written.write_text(folder / "meshes" / visual_file, item.geometry.dae_for(element.ifc_class))
    written.write_bytes(folder / "meshes" / collision_file, item.geometry.stl)
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
        written.write_text(folder / file_name, sdf.model_sdf(spec, version))
    description = f'{element.ifc_class} "{printable(element.name)}" (IFC GlobalId {printable(element.global_id)}) from {source}'
    written.write_text(folder / "model.config", sdf.model_config(item.name, versions, description))


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
