"""``bimrobot plan``: the planning problem as data (``plan export``). Light imports: the work is imported
inside the command function."""

from __future__ import annotations

import argparse
from pathlib import Path

EXPORT_EXAMPLES = """examples:
  bimrobot example steel-frame -o frame.ifc
  bimrobot plan export frame.ifc --fleet fleet2 -o frame_fleet2.json
  bimrobot plan export house.ifc --fleet site-crane --prebuilt IfcFooting,IfcSlab,IfcWall -o house.json

The instance (JSON, version 1, docs/planning.md) is the problem `bimrobot simulate --per-joint` runs:
tasks, precedences and the rule behind each, release rule, robots with capabilities, speeds and handling
times, each task's handling time on each capable robot, the site (model_offset, yard, homes).
"""


def register(subparsers) -> None:
    """Add ``plan`` and its sub-command ``export`` to the bimrobot parser."""
    from bimrobot.bim.selection import add_prebuilt_option, add_selection_options
    from bimrobot.bim.unknown_weight import add_unknown_weight_option
    from bimrobot.coordination.cli import _ranged
    from bimrobot.sco.build import MAX_TOLERANCE_M

    plan = subparsers.add_parser("plan", help="assembly planning: the planning problem as data")
    commands = plan.add_subparsers(dest="plan_command", metavar="PLAN_COMMAND", required=True)
    export = commands.add_parser(
        "export", help="write the planning instance (JSON) of a model, fleet and site",
        epilog=EXPORT_EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    export.add_argument("model", help="IFC file (.ifc, .ifczip), or generated:NXxNYxFLOORS for a generated steel frame")
    export.add_argument("--fleet", default="fleet2", help="fleet1, fleet2, site-crane or a fleet YAML file (default fleet2)")
    export.add_argument("--site", help="site YAML (default as simulate: fig. 4.11 when the building fits, else derived)")
    export.add_argument("-o", "--output", required=True, help="the instance file (.json): a new file, or one bimrobot wrote (replaced atomically)")
    add_prebuilt_option(export)
    export.add_argument(
        "--tolerance", type=_ranged(float, 0.0, MAX_TOLERANCE_M, "m", low_inclusive=False), default=0.01,
        help=f"metres, > 0 and <= {MAX_TOLERANCE_M:g}; bodies this close count as touching (default 0.01)",
    )
    export.add_argument("--by-element", action="store_true", help="build element by element even when the model groups them into assemblies")
    add_selection_options(export, built=True)
    add_unknown_weight_option(export)
    export.set_defaults(func=run_export)


def run_export(args) -> int:
    """``bimrobot plan export``: read model, fleet and site as ``simulate`` does; write the instance."""
    from bimrobot.coordination.cli import _inputs, _prepare
    from bimrobot.io import atomic_output_file
    from bimrobot.planning.problem import build_instance, dumps

    # simulate's own checks and readers: output refused before the long work, fleet, site, model, prebuilt
    _, elevations, fleet, site, _, smart_model = _prepare(args, None, folder=False)
    smart = smart_model()
    instance = build_instance(smart, fleet, site, elevations)
    with atomic_output_file(args.output, inputs=_inputs(args)) as tmp:
        tmp.write_text(dumps(instance), encoding="utf-8")
    print(f"{args.output}: {len(instance['tasks'])} tasks, {len(instance['precedences'])} precedences, "
          f"{len(instance['robots'])} robots (fleet {fleet.name}); the problem of `simulate --per-joint`")
    print(f"output: {Path(args.output).resolve()}")
    return 0
