"""What a package says about itself: report.json (every element's mass, weight source and pose, what was
skipped and why) and README.md (what each folder holds and how to launch it). Metres, kg, seconds."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from bimrobot.bim.model import Element, WeightSource
from bimrobot.bim.unknown_weight import UnknownWeights
from bimrobot.core import io
from bimrobot.core.io import printable
from bimrobot.export.gazebo import layout
from bimrobot.export.gazebo.naming import final_path
from bimrobot.export.gazebo.options import ConvertOptions

if TYPE_CHECKING:  # mass properties need trimesh and SciPy
    from bimrobot.export import inertia as physics

def unknown_weight_report(unknown: UnknownWeights, converted: list, options: ConvertOptions) -> dict:
    """``unknown.as_dict()`` plus the one-line message; elements that had no closed volume for the rule
    get the mass physics gave them (the same density over their convex hull or box)."""
    entry = unknown.as_dict()
    for item in converted:
        if item.element.global_id in entry["elements"] and entry["elements"][item.element.global_id] is None:
            entry["elements"][item.element.global_id] = round(item.mass.mass, 3)
    entry["message"] = unknown.message()
    return entry


def duplicate_keys(converted: list) -> dict[str, list[str]]:
    """GlobalId -> the model names of the elements that share it (keys ``<GlobalId>#<step id>``)."""
    groups: dict[str, list[str]] = {}
    for item in converted:
        groups.setdefault(item.element.global_id.split("#")[0], []).append(item.element.global_id)
    return {gid: keys for gid, keys in groups.items() if len(keys) > 1}


def suspect_weight(item) -> str | None:
    """Why the weight the model gives an element is not plausible (the rule `bimrobot inspect` applies:
    :func:`bimrobot.bim.quantities.weight_check`), or None."""
    from bimrobot.bim.quantities import weight_check

    element = item.element
    return weight_check(element.weight_kg, element.weight_source, element.volume_m3, element.density_kg_m3)


def _entry(item, options: ConvertOptions) -> dict:
    """One converted element's entry in report.json (kg, m, m^3, radians)."""
    element, mass = item.element, item.mass
    x, y, z, roll, pitch, yaw = layout.pose_xyz_rpy(item.pose)
    entry = {
        "global_id": element.global_id,
        "model": item.model,
        "ifc_class": element.ifc_class,
        "name": element.name,
        "storey_id": element.storey_id,
        "material": element.material,
        "mass_kg": round(mass.mass, 6),
        "weight_source": weight_source_words(element, mass, options),
        "bim_weight_kg": element.weight_kg,
        "volume_m3": round(mass.volume, 9),
        "inertia_from": mass.inertia_method,
        "center_of_mass_m": [round(float(v), 6) for v in mass.center_of_mass],
        "visual_triangles": int(len(item.body.faces)),
        "collision_triangles": int(item.collision_triangles),
        "pose_xyz_rpy": [round(v, 9) for v in (x, y, z, roll, pitch, yaw)],
    }
    suspect = suspect_weight(item)
    if suspect:
        entry["weight_suspect"] = suspect
    return entry


def package_report(model, package, world_name, world_files, converted, skipped, maps, yard, options, timings) -> dict:
    """report.json of a package: every element's mass, weight source, pose and triangles, the skipped
    products, the options, the maps, the yard and the timings (s)."""
    entries = [_entry(item, options) for item in converted]
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


def weight_source_words(element: Element, mass: physics.MassProperties, options: ConvertOptions) -> str:
    """Where the model's mass came from, in words (the same words for both ways of assuming it)."""
    if element.weight_source is WeightSource.ASSUMED or mass.mass_assumed:  # the material the rule chose
        assumed = element.weight_assumed_as or f"{options.unknown_weight.density_kg_m3:g} kg/m3"
        return f"assumed: volume x {assumed} (--unknown-weight)"
    return element.weight_source.value


def readme_text(report: dict) -> str:
    """The package's README.md, from its report."""
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


FAR_FROM_ORIGIN_M = 1000.0
"""Beyond this distance from the world origin, single-precision meshes and physics lose millimetres."""


def warnings_of(converted: list, options: ConvertOptions, ground_z: float, extent) -> list[str]:
    """Things a user should know before starting the simulation (also logged); ``extent``: the world's
    extent (m) from its origin."""
    warnings = []
    if not options.is_static:
        below = [item.name for item in converted if item.world_vertices[:, 2].min() < ground_z - 1e-6]
        if below:
            warnings.append(
                f"{len(below)} dynamic model(s) reach below the ground plane at z = {ground_z:g} m (e.g. {below[0]}); "
                "the physics engine will push them up at the start: use --static, --layout yard or --exclude their class"
            )
    suspect = [(item, reason) for item in converted if (reason := suspect_weight(item))]
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
