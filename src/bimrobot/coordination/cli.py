"""Sub-commands of the coordination part (registered by bimrobot.cli): ``simulate`` and ``allocators``."""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

from bimrobot.errors import InputError

SIMULATE_EXAMPLES = """examples:
  bimrobot example steel-frame -o frame.ifc
  bimrobot simulate frame.ifc --fleet fleet2 -o sim/
  bimrobot simulate frame.ifc --fleet my_fleet.yaml --site site.yaml --evaluator quickest-finish -o sim/
  bimrobot simulate frame.ifc --fleet fleet2 --breakdown AssemblyRobot32@600 -o sim_fault/
  bimrobot simulate frame.ifc --fleet fleet1 --breakdown AssemblyRobot31@600+900 -o sim_repair/
  bimrobot simulate generated:10x10x5 --fleet fleet2 -o big/     # a generated 10 x 10 column, 5-floor frame

output (in the -o folder): events.log (Listing 4.2 style), events.jsonl, robots.csv / robots.txt
(per robot: steps, busy time, utilisation), summary.json (makespan, steps, utilisation), states.json
(state history of every component), schedule.csv (one row per activity), gantt.png
"""

ALLOCATORS_EXAMPLES = """examples:
  bimrobot allocators generated:2x1x1 --fleet fleet2 -o cmp/
  bimrobot allocators frame.ifc --fleet fleet1 --seeds 10 --no-optimal -o cmp/

Compares the market (least-cost, quickest-finish) with greedy-nearest and random allocation and, when
the build is small enough (<= --max-tasks tasks), with an optimal CP-SAT schedule (needs ortools:
pip install 'bimrobot[optimize]'). Writes allocators.csv and allocators.md.
"""

GENERATED = re.compile(r"^generated:(\d+)x(\d+)x(\d+)$")


def _breakdown(text: str) -> tuple[str, float, float | None]:
    """ROBOT@SECONDS (for good) or ROBOT@SECONDS+REPAIR_SECONDS."""
    name, sep, when = text.rpartition("@")
    at, plus, repair = when.partition("+")
    try:
        seconds = float(at)
        repair_s = float(repair) if plus else None
    except ValueError:
        seconds = None
    if not sep or not name or seconds is None:
        raise argparse.ArgumentTypeError(
            f"expected ROBOT@SECONDS or ROBOT@SECONDS+REPAIR, e.g. AssemblyRobot32@600+900, got {text!r}"
        )
    return name, seconds, repair_s


def _add_common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", help="IFC file, or generated:NXxNYxFLOORS for a generated steel frame")
    parser.add_argument("--fleet", default="fleet2", help="fleet1, fleet2 (thesis Table 4.1) or a fleet YAML file (default fleet2)")
    parser.add_argument("--site", help="site YAML: yard, robot_home, construction_area, model_offset (default: thesis fig. 4.11)")
    parser.add_argument("-o", "--output", required=True, help="output folder (replaced atomically)")
    parser.add_argument(
        "--prebuilt", default="IfcFooting,IfcPile", metavar="CLASSES",
        help="comma-separated IFC classes already built on site, e.g. cast-in-place slabs and walls "
        "(default IfcFooting,IfcPile)",
    )
    parser.add_argument(
        "--tolerance", type=float, default=0.01,
        help="metres; bodies this close count as touching when connections are inferred (default 0.01)",
    )


def register(subparsers) -> None:
    """Add this part's sub-commands to the bimrobot parser."""
    from bimrobot.coordination.market import EVALUATORS

    simulate = subparsers.add_parser(
        "simulate",
        help="market-based multi-robot construction simulation of a building (thesis ch. 4)",
        description="Smart components publish their requirements, robots of the fleet bid, the evaluator "
        "awards; a SimPy discrete-event simulation builds the whole structure floor by floor.",
        epilog=SIMULATE_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_common(simulate)
    simulate.add_argument("--evaluator", default="least-cost", choices=EVALUATORS, help="how the winning bid is chosen (default least-cost; greedy-nearest and random are baselines)")
    simulate.add_argument("--seed", type=int, default=0, help="seed of the random allocator (default 0)")
    simulate.add_argument("--breakdown", type=_breakdown, action="append", default=[], metavar="ROBOT@SECONDS[+REPAIR]", help="the robot breaks down at that time, for good or for REPAIR seconds (repeatable)")
    simulate.add_argument("--no-gantt", action="store_true", help="skip the Gantt chart (faster on big buildings)")
    simulate.add_argument("--no-progress", action="store_true", help="no progress bar")
    simulate.set_defaults(func=run_simulate)

    allocators = subparsers.add_parser(
        "allocators",
        help="compare the market with greedy, random and optimal (CP-SAT) allocation",
        epilog=ALLOCATORS_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_common(allocators)
    allocators.add_argument("--seeds", type=int, default=5, help="runs of the random allocator (default 5)")
    allocators.add_argument("--no-optimal", action="store_true", help="skip the CP-SAT optimum")
    allocators.add_argument("--time-limit", type=float, default=60.0, help="CP-SAT time limit, seconds (default 60)")
    allocators.add_argument("--max-tasks", type=int, default=60, help="largest build (in tasks) given to CP-SAT (default 60)")
    allocators.set_defaults(func=run_allocators)


def load_building(spec: str):
    """(BuildingModel, storey elevations in metres) from an IFC path or ``generated:NXxNYxF``."""
    match = GENERATED.match(spec)
    if match:
        from bimrobot.coordination.generate import generated_frame

        nx, ny, floors = (int(v) for v in match.groups())
        if min(nx, ny, floors) < 1:
            raise InputError(f"{spec}: NX, NY and FLOORS must be at least 1")
        model = generated_frame(nx, ny, floors)
    else:
        path = Path(spec)
        if not path.is_file():
            raise InputError(f"model file {spec!r} does not exist")
        from bimrobot.bim import load_model

        model = load_model(path)
    return model, [s.elevation for s in model.storeys]


def _prepare(args):
    from bimrobot.coordination.fleet import load_fleet, load_site
    from bimrobot.sco.build import build_smart_model

    fleet = load_fleet(args.fleet)
    site = load_site(args.site)
    model, elevations = load_building(args.model)
    prebuilt = tuple(c.strip() for c in args.prebuilt.split(",") if c.strip())
    bad = [c for c in prebuilt if not c.startswith("Ifc")]
    if bad:
        raise InputError(f"--prebuilt expects IFC class names such as IfcSlab, got {bad[0]!r}")
    return model, elevations, fleet, site, lambda: build_smart_model(
        model, prebuilt_classes=prebuilt, inferred_tolerance_m=args.tolerance
    )


def run_simulate(args) -> int:
    from bimrobot.coordination.report import format_robot_table, write_outputs
    from bimrobot.coordination.simulation import simulate
    from bimrobot.io import atomic_output_dir

    from tqdm import tqdm

    model, elevations, fleet, site, smart_model = _prepare(args)
    smart = smart_model()
    with tqdm(total=len(smart.components), desc="components assembled", unit="", disable=True if args.no_progress else None, leave=False) as bar:
        result = simulate(smart, fleet, site, args.evaluator, args.seed, args.breakdown, elevations, on_assembled=lambda _: bar.update(1))
    with atomic_output_dir(args.output) as tmp:
        write_outputs(result, tmp, gantt=not args.no_gantt)
    info = smart.summary()
    print(
        f"{len(smart.components)} components ({len(info['prebuilt'])} prebuilt), {info['connection_nodes']} connection nodes, "
        f"{info['joints']} joints from {info['connection_source']}"
    )
    if smart.inferred:
        print(f"inferred joints (no IfcRelConnectsWithRealizingElements): {len(smart.inferred)}, listed in summary.json")
    if smart.unknown_weight:
        print(f"warning: {len(smart.unknown_weight)} components have no weight in the model; payload checks treat them as 0 kg "
              f"(listed under unknown_weight in summary.json)")
    if smart.duplicates:
        print(f"not built: {len(smart.duplicates)} elements duplicating a connected element in place (listed in summary.json)")
    print(f"fleet {fleet.name}, evaluator {result.evaluator}: makespan {result.makespan:.1f} s, {result.steps} steps, "
          f"fleet utilisation {result.utilisation:.1%}")
    print(format_robot_table(result))
    print(f"output: {Path(args.output).resolve()}/ (events.log, events.jsonl, robots.csv, summary.json, states.json, schedule.csv"
          f"{'' if args.no_gantt else ', gantt.png'})")
    return 0


def run_allocators(args) -> int:
    from bimrobot.coordination.compare import compare_allocators, format_markdown, write_csv
    from bimrobot.io import atomic_output_dir

    model, elevations, fleet, site, smart_model = _prepare(args)
    rows = compare_allocators(
        smart_model, fleet, site, elevations,
        seeds=args.seeds, optimal=not args.no_optimal, time_limit_s=args.time_limit, max_tasks=args.max_tasks,
    )
    table = format_markdown(rows, title=f"{args.model}, fleet {fleet.name}")
    with atomic_output_dir(args.output) as tmp:
        write_csv(rows, tmp / "allocators.csv")
        (tmp / "allocators.md").write_text(table + "\n")
        (tmp / "allocators.json").write_text(json.dumps(rows, indent=2) + "\n")
    print(table)
    print(f"output: {Path(args.output).resolve()}/ (allocators.csv, allocators.md, allocators.json)")
    return 0
