"""Sub-commands of the world part (registered by bimrobot.cli): ``bimrobot convert``."""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from bimrobot.bim.selection import add_selection_options
from bimrobot.bim.unknown_weight import UnknownWeightRule, add_unknown_weight_option
from bimrobot.core.errors import InputError, require_extra

CONVERT_EXAMPLES = """examples:
  bimrobot convert frame.ifc -o frame_pkg/                       # Gazebo Sim package, installed, static
  bimrobot convert frame.ifc -o yard_pkg/ --layout yard          # components on a yard, dynamic
  bimrobot convert model.ifc -o pkg/ --include "IfcColumn, IfcBeam" --target both
  bimrobot convert model.ifczip -o pkg/ --exclude "IfcFurnishingElement, IfcCovering" --unknown-weight 7850
  bimrobot convert model.ifc -o pkg/ --collision decimated --max-triangles 200 --map-band 0.2 1.8
  bimrobot convert big.ifc -o pkg/ --merge-static --keep-separate "IfcBeam, IfcColumn" --validate
  bimrobot convert frame.ifc -o scene/ --target mujoco --layout yard   # + MJCF scene for MuJoCo

The package holds worlds/, models/<GlobalId>/ (model.sdf, model.config, meshes/), launch/ (ROS 2
gz_sim.launch.py, ROS 1 gazebo_classic.launch), maps/<storey>.pgm+.yaml (Nav2), report.json and a
README. Start it with:  ros2 launch frame_pkg/launch/gz_sim.launch.py
"""


def register(subparsers) -> None:
    """Add this part's sub-commands to the bimrobot parser. Long only because ``convert`` has many options,
    one ``add_argument`` each (issue 37 allows it, said here)."""
    parser = subparsers.add_parser(
        "convert",
        help="convert an IFC model into a Gazebo package (worlds, models, launch files, maps)",
        description="Convert an IFC building model into a Gazebo package: one SDF model per building element "
        "(named by its GlobalId, posed by its placement, mass from the BIM weight, DAE visual and simplified "
        "STL collision), a world, ROS launch files and per-storey occupancy maps. Output is written "
        "atomically: a failed run leaves nothing behind.",
        epilog=CONVERT_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("ifc", type=Path, help="the IFC file (IFC2X3, IFC4, IFC4X3_ADD2; .ifc or .ifczip)")
    parser.add_argument("-o", "--output", type=Path, required=True,
                        help="package folder to write (a new one, or one bimrobot wrote, which is replaced)")
    parser.add_argument("--target", choices=["sim", "classic", "both", "mujoco"], default="sim",
                        help="sim: SDF 1.9 world for Gazebo Sim + ROS 2 launch (default); classic: SDF 1.6 world "
                        "for Gazebo Classic + ROS 1 launch; both; mujoco: the sim package plus an MJCF scene "
                        "(mujoco/scene.xml: one body per element, convex or CoACD collision pieces)")
    static = parser.add_mutually_exclusive_group()
    static.add_argument("--static", dest="static", action="store_const", const=True, default=None,
                        help="models are fixed in the world (default for --layout installed)")
    static.add_argument("--dynamic", dest="static", action="store_const", const=False,
                        help="models fall and can be moved (default for --layout yard)")
    add_selection_options(parser, built=False)
    parser.add_argument("--layout", choices=["installed", "yard"], default="installed",
                        help="installed: every element at its IFC placement (default); yard: laid out at "
                        "pick-up positions on the site's yard (--site)")
    parser.add_argument("--site", type=Path,
                        help="site YAML (yard, construction_area, model_offset; docs/conventions.md) for --layout yard; "
                        "default: fig. 4.11 when the building fits its 7.5 x 6.5 m area, else a site derived from the "
                        "building ('thesis' forces fig. 4.11), as `simulate` and `rcan` use")
    parser.add_argument("--collision", choices=["convex", "decimated"], default="convex",
                        help="collision mesh: convex hull (default) or the body decimated to --max-triangles")
    parser.add_argument("--max-triangles", type=int, default=500, metavar="N",
                        help="triangle budget of each collision mesh (default 500)")
    parser.add_argument("--map-resolution", type=float, default=0.05, metavar="M",
                        help="occupancy map cell size in metres (default 0.05)")
    parser.add_argument("--map-band", type=float, nargs=2, default=(0.1, 1.5), metavar=("LOW", "HIGH"),
                        help="height band above each storey cut for the map, metres (default 0.1 1.5)")
    parser.add_argument("--map-margin", type=float, default=1.0, metavar="M",
                        help="free border around the model in the maps, metres (default 1.0)")
    add_unknown_weight_option(parser)
    parser.add_argument("--default-density", action=_DeprecatedDensity, type=UnknownWeightRule.parse,
                        dest="unknown_weight", help=argparse.SUPPRESS)  # the old name, kept working
    parser.add_argument("--no-maps", action="store_true", help="do not write occupancy maps")
    parser.add_argument("--no-preview", action="store_true",
                        help="do not draw preview.png (a picture of the world; drawing it takes 0.3-1 s)")
    parser.add_argument("--merge-static", action="store_true",
                        help="for large buildings: merge the static elements into one model per storey and IFC "
                        "class (merged_<storey>_<class>; visual, collision and exact combined inertia), except the "
                        "components robots handle, named by --keep-separate, which keep one model per element")
    parser.add_argument("--keep-separate", metavar="CLASSES", type=_class_list, default=(),
                        help="with --merge-static: the components robots handle, as IFC classes (subclasses count), "
                        "e.g. 'IfcBeam, IfcColumn'; they keep one model each (default: none, every element is merged)")
    parser.add_argument("--package-name", help="ROS package name (default: from the output folder name)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    parser.add_argument("--validate", action="store_true",
                        help="check the written package: every model's meshes, mass and inertia, and each world with "
                        "every distinct model it includes through the SDF validator (`ign sdf -k`, when installed; "
                        "in parallel batches, so thousands of models take seconds to a minute); exit 1 if anything fails")
    parser.set_defaults(func=convert_command)


def _class_list(text: str) -> tuple[str, ...]:
    """'IfcBeam, IfcColumn' -> ('IfcBeam', 'IfcColumn'); anything else than IFC class names is refused."""
    names = tuple(part.strip() for part in text.replace(";", ",").split(",") if part.strip())
    bad = [name for name in names if not re.fullmatch(r"Ifc[A-Za-z0-9]+", name)]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"expected IFC class names such as 'IfcBeam, IfcColumn', not {text!r}")
    return names


class _DeprecatedDensity(argparse.Action):
    """``--default-density KG_M3``: the old spelling of ``--unknown-weight KG_M3``; says so once."""

    def __call__(self, parser, namespace, values, option_string=None):
        print("bimrobot convert: --default-density is deprecated; use --unknown-weight", file=sys.stderr)
        setattr(namespace, self.dest, values)


def convert_command(args: argparse.Namespace, model=None) -> int:
    """``bimrobot convert``: read the IFC file, write the package, print what it holds. ``model``: the
    BuildingModel of ``args.ifc`` already read with the same selection and unknown-weight rule (``bimrobot
    build`` reads it once for every stage); None reads it here."""
    from bimrobot.core import io
    from bimrobot.core.cores import frozen_heap, quick_exit
    from bimrobot.export.gazebo.conversion import convert
    from bimrobot.export.gazebo.options import ConvertOptions

    quick_exit()  # the libraries this command loads would cost 0.2 s of collection at exit

    io.check_output(args.output, folder=True, inputs=[args.ifc, args.site], kind="convert")  # before the long read and conversion
    if args.target == "mujoco":  # the MJCF scene needs the physics extra: say so before the geometry work
        require_extra("mujoco", "physics")
        from bimrobot.export.mujoco.collision import require_coacd

        require_coacd()  # found, not imported: CoACD loads only in the forked process that decomposes
    if args.site and args.layout != "yard":
        raise InputError("--site places the yard, so it needs --layout yard")
    site = None  # None: derived from the building
    if args.site:  # a bad file is refused now (the site module is imported only then: YAML and its schema)
        from bimrobot.site.site import load_site

        site = load_site(args.site)
    options = ConvertOptions(
        target=args.target,
        static=args.static,
        layout=args.layout,
        collision=args.collision,
        max_triangles=args.max_triangles,
        map_resolution=args.map_resolution,
        map_band=tuple(args.map_band),
        map_margin=args.map_margin,
        package_name=args.package_name,
        unknown_weight=args.unknown_weight,
        maps=not args.no_maps,
        preview=not args.no_preview,
        site=site,
        merge_static=args.merge_static,
        keep_separate=args.keep_separate,
    )
    options.validate()
    progress = not args.no_progress and sys.stderr.isatty()
    if model is None:
        report = convert(args.ifc, args.output, options, include=args.include, exclude=args.exclude, progress=progress)
    else:
        from bimrobot.export.gazebo.package import build_package

        with frozen_heap():  # as convert() does around its own read
            report = build_package(model, args.output, options, progress)
    print(summary(report, args.output))
    return validate_package(args.output, report) if args.validate else 0


def validate_package(output: Path, report: dict) -> int:
    """Print the package checks; 0 when everything passes, 1 otherwise.

    Every model's meshes, mass and inertia are checked here; the worlds and every distinct model they
    include go through the SDF validator in parallel batches (:func:`bimrobot.export.gazebo.check.validate_world`).
    """
    import time

    from bimrobot.core.io import printable
    from bimrobot.export.gazebo.check import problems, sdf_validator, validate_world

    found = problems(output)
    models = len(list((output / "models").iterdir()))
    expected = report["counts"].get("models", report["counts"]["converted"])
    if models != expected:
        found.append(f"{models} model folders for {expected} models in the world")
    print(f"  check:    {models} models: meshes present, masses and inertia physical" if not found
          else "  check:    FAILED\n" + "\n".join(f"    {printable(problem)}" for problem in found))
    failed = bool(found)
    if sdf_validator() is None:
        print("  check:    `ign sdf` not installed (apt-get install ignition-tools libsdformat-dev): SDF not validated")
        return 1 if failed else 0
    for world in report["world_files"].values():
        started = time.perf_counter()
        result = validate_world(output / world, output / "models")
        seconds = time.perf_counter() - started
        print(f"  check:    ign sdf -k {world}: {'Valid' if result.valid else 'INVALID'} ({result.includes} includes, "
              f"{result.distinct} distinct models in {result.batches} batches, {seconds:.1f} s)")
        if not result.valid:
            print("\n".join(f"    {printable(line)}" for line in result.errors[:20]))
            failed = True
    return 1 if failed else 0


def summary(report: dict, output: Path) -> str:
    """A few lines saying where the package is and what it holds."""
    from bimrobot.core.io import printable

    counts = report["counts"]
    shown = printable(str(output))
    classes = ", ".join(f"{n} {c}" for c, n in counts["by_class"].items())
    sources = ", ".join(f"{n} {s}" for s, n in counts["weight_sources"].items())
    lines = [
        f"wrote {shown}/ (ROS package {report['package']!r}) in {report['timings_s']['total']:.2f} s",
        f"  models:   {counts['converted']} ({classes}), total {counts['total_mass_kg']} kg, "
        f"{'static' if report['options']['static'] else 'dynamic'}, {report['options']['layout']} layout",
        f"  weights:  {sources}",
    ]
    merged = report.get("merged_models") or []
    if merged:
        held = sum(m["elements"] for m in merged)
        lines.insert(2, f"  merged:   {held} static elements into {len(merged)} models (one per storey and class); "
                        f"{counts['models']} models in the world")
    unknown = report.get("unknown_weight") or {}
    if unknown.get("message"):
        lines.append(f"  unknown:  {unknown['message']}")
    duplicates = report.get("duplicate_global_ids") or {}
    if duplicates:
        example = next(iter(duplicates.values()))
        lines.append(
            f"  warning:  {len(duplicates)} GlobalId(s) are shared by several elements; each became its own model "
            f"({printable(', '.join(example))}; all in report.json)"
        )
    lines += [
        f"  worlds:   {', '.join(report['world_files'].values())}",
        f"  maps:     {', '.join(m['yaml'] for m in report['maps']) or 'none'}",
        f"  skipped:  {counts['skipped']} (reasons in report.json)",
    ]
    lines += [f"  warning:  {printable(warning)}" for warning in report.get("warnings", [])]
    if "sim" in report["world_files"]:
        lines.append(f"  run:      ros2 launch {shown}/launch/gz_sim.launch.py")
    if "classic" in report["world_files"]:
        lines.append(f"  run:      roslaunch {shown}/launch/gazebo_classic.launch")
    if "mujoco" in report:
        methods = ", ".join(f"{n} {m}" for m, n in report["mujoco"]["collision_methods"].items())
        lines.append(f"  mujoco:   {shown}/{report['mujoco']['scene']} (collision: {methods}); "
                     f"view: python -m mujoco.viewer --mjcf={shown}/{report['mujoco']['scene']}")
    return "\n".join(lines)
