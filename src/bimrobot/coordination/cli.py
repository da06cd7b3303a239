"""Sub-commands of the coordination part (registered by bimrobot.cli): ``simulate`` and ``allocators``."""

from __future__ import annotations

import argparse
from pathlib import Path

from bimrobot.coordination.inputs import input_files, prepare
from bimrobot.coordination.options import add_building_options, add_simulate_options, ranged
from bimrobot.core.errors import InputError

SIMULATE_EXAMPLES = """examples:
  bimrobot example steel-frame -o frame.ifc
  bimrobot simulate frame.ifc --fleet fleet2 -o sim/
  bimrobot simulate frame.ifc --fleet fleet2 --per-node -o sim_nodes/   # positioning and assembly per connection node
  bimrobot example steel-frame --bolts-per-node 6 -o frame6.ifc
  bimrobot simulate frame6.ifc --fleet fleet1 --mode thesis -o table42/  # the thesis' step loop (Table 4.2)
  bimrobot simulate frame6.ifc --fleet fleet2 --mode thesis --step-time phase -o table42_phase/
  bimrobot simulate frame.ifc --fleet my_fleet.yaml --site site.yaml --evaluator quickest-finish -o sim/
  bimrobot simulate frame.ifc --fleet fleet2 --breakdown AssemblyRobot32@600 -o sim_fault/
  bimrobot simulate frame.ifc --fleet fleet1 --breakdown AssemblyRobot31@600+900 -o sim_repair/
  bimrobot simulate generated:10x10x5 --fleet fleet2 -o big/     # a generated 10 x 10 column, 5-floor frame
  bimrobot simulate house.ifc --fleet site-crane --prebuilt IfcFooting,IfcSlab,IfcWall -o house_sim/
  bimrobot simulate precast.ifc --fleet site-crane -o units/                 # one component per IfcElementAssembly
  bimrobot simulate precast.ifc --fleet site-crane --by-element -o parts/   # every element on its own

--mode thesis writes events.log (Listing 4.2), robots.txt / robots.csv (Table 4.2, with the thesis'
figures on the chapter-4 frame), requests.csv (every request and its ACC / RCC rule) and summary.json.

output (in the -o folder): events.log (Listing 4.2 style), events.jsonl, robots.csv / robots.txt
(per robot: steps, busy time, utilisation), summary.json (makespan, steps, utilisation), states.json
(state history of every component), schedule.csv (one row per activity), gantt.png
"""

ALLOCATORS_EXAMPLES = """examples:
  bimrobot allocators generated:2x1x1 --fleet fleet2 -o cmp/
  bimrobot allocators frame.ifc --fleet fleet1 --seeds 10 --no-optimal -o cmp/

Compares the market (least-cost, quickest-finish) with greedy-nearest and random allocation and, when
the build is small enough (<= --max-tasks tasks), with CP-SAT's schedule: the optimum where it is proved
within --time-limit, else its best schedule and its lower bound, against which the gaps are then
given (needs ortools: pip install 'bimrobot[optimize]'). Writes allocators.csv and allocators.md.
"""

def register(subparsers) -> None:
    """Add this part's sub-commands to the bimrobot parser."""
    from bimrobot.planning.compare import ALLOCATORS_MAX_TASKS

    simulate = subparsers.add_parser(
        "simulate",
        help="market-based multi-robot construction simulation of a building (thesis ch. 4)",
        description="Smart components publish their requirements, robots of the fleet bid, the evaluator "
        "awards; a SimPy discrete-event simulation builds the whole structure floor by floor.",
        epilog=SIMULATE_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_building_options(simulate)
    add_simulate_options(simulate)
    simulate.set_defaults(func=run_simulate)

    allocators = subparsers.add_parser(
        "allocators",
        help="compare the market with greedy, random and optimal (CP-SAT) allocation",
        epilog=ALLOCATORS_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_building_options(allocators)
    allocators.add_argument("--seeds", type=ranged(int, 1, 1000, ""), default=5, help="runs of the random allocator, 1 to 1000 (default 5)")
    allocators.add_argument("--no-optimal", action="store_true", help="skip the CP-SAT optimum")
    allocators.add_argument(
        "--time-limit", type=ranged(float, 0.0, 86_400.0, "s", low_inclusive=False), default=60.0,
        help="CP-SAT time limit, seconds, > 0 and <= 86400 (default 60)",
    )
    allocators.add_argument(
        "--max-tasks", type=ranged(int, 1, 100_000, ""), default=ALLOCATORS_MAX_TASKS,
        help=f"largest build (in tasks) given to CP-SAT, at least 1 (default {ALLOCATORS_MAX_TASKS}: every shared "
        "real model; a larger build gets no CP-SAT row, and CP-SAT's time limit is not kept far above it)",
    )
    allocators.set_defaults(func=run_allocators)


def run_simulate(args, model=None) -> int:
    """``bimrobot simulate``: the build simulated into ``args.output``. ``model``: the BuildingModel of
    ``args.model`` already read (see :func:`~bimrobot.coordination.inputs.prepare`); None reads it."""
    from bimrobot.site.fleet import RUN_FLEET_FILE, fleet_yaml
    from bimrobot.coordination.report import format_robot_table, write_outputs
    from bimrobot.coordination.simulation import simulate
    from bimrobot.core.io import atomic_output_dir
    from bimrobot.site.site import site_yaml

    from tqdm import tqdm

    if args.mode == "thesis":
        return run_thesis(args, model)
    if args.step_time is not None:
        raise InputError("--step-time applies to --mode thesis only (the event mode times every task as it happens)")
    if getattr(args, "planner", None) is not None:  # a wrong name is refused before the model is read
        from bimrobot.planning.planners import check_planner

        check_planner(args.planner, per_node=not args.per_joint, breakdowns=args.breakdown)
        if args.evaluator != "least-cost":
            raise InputError(f"give --planner or --evaluator, not both (got --planner {args.planner} and --evaluator {args.evaluator})")
    model, elevations, fleet, site, weights, smart_model = prepare(args, "simulate", model)
    smart = smart_model()
    dispatcher, stats = _planner(args, smart, fleet, site, elevations)
    to_build = sum(1 for c in smart.components.values() if not c.prebuilt)
    with tqdm(total=to_build, desc="components assembled", unit="", disable=True if args.no_progress else None, leave=False) as bar:
        result = simulate(smart, fleet, site, args.evaluator, args.seed, args.breakdown, elevations,
                          on_assembled=lambda _: bar.update(1), per_node=not args.per_joint, dispatcher=dispatcher)
    with atomic_output_dir(args.output, kind="simulate", inputs=input_files(args)) as tmp:
        write_outputs(result, tmp, gantt=not args.no_gantt, unknown_weight=weights.as_dict())
        if stats is not None:
            from bimrobot.planning.planners import plan_record

            (tmp / "plan.json").write_text(plan_record(args.planner, result, stats), encoding="utf-8")
        (tmp / "site.yaml").write_text(site_yaml(site, "this simulation"), encoding="utf-8")
        (tmp / RUN_FLEET_FILE).write_text(fleet_yaml(fleet, "this simulation"), encoding="utf-8")  # the schedule's fleet
    _print_smart_model(smart, weights)
    print(f"fleet {fleet.name}, {'evaluator' if stats is None else 'planner'} {result.evaluator}: makespan {result.makespan:.1f} s, {result.steps} steps, "
          f"fleet utilisation {result.utilisation:.1%}")
    print(format_robot_table(result))
    if stats is not None:
        from bimrobot.planning.planners import plan_line

        print(plan_line(result, stats))
    print(f"output: {Path(args.output).resolve()}/ (events.log, events.jsonl, robots.csv, summary.json, states.json, schedule.csv"
          f"{'' if args.no_gantt else ', gantt.png'}{'' if stats is None else ', plan.json'})")
    return 0


def _print_smart_model(smart, weights) -> None:
    """What ``simulate`` says about the smart model before the result: components, nodes, joints, and
    what was inferred, assumed, unknown or left out."""
    info = smart.summary()
    units = f", {info['assembly_units']} of them assembly units" if info["assembly_units"] else ""
    later = f", {len(info['prebuilt_after_supports'])} made once what they rest on is placed" if info["prebuilt_after_supports"] else ""
    print(
        f"{len(smart.components)} components{units} ({len(info['prebuilt'])} prebuilt{later}), "
        f"{info['connection_nodes']} connection nodes, {info['joints']} joints" + ("" if info["connection_source"] == "none" else f" ({info['connection_source']})")
    )
    if smart.internal_connections:
        print(f"{smart.internal_connections} connections between parts of one assembly are internal (made in the factory, not on site)")
    if smart.inferred:
        print(f"inferred joints (no IfcRelConnectsWithRealizingElements): {len(smart.inferred)}, listed in summary.json")
    message = weights.message()
    if message:
        print(message)
    if smart.unknown_weight:
        print(f"warning: {len(smart.unknown_weight)} components have no weight and no closed volume; payload checks "
              f"cannot verify them (listed under components_without_weight in summary.json)")
    if smart.duplicates:
        print(f"not built: {len(smart.duplicates)} elements duplicating a connected element in place (listed in summary.json)")


def _planner(args, smart, fleet, site, elevations):
    """``--planner``: (the dispatcher that carries out the plan, its PlanStats), or (None, None) for the
    market of ``--evaluator`` (simulate's default, unchanged; ``--planner market`` is the same run)."""
    planner = getattr(args, "planner", None)
    if planner is None or planner == "market":  # the default market: the very same run and outputs
        return None, None
    from bimrobot.planning.dispatch import DispatchProblem
    from bimrobot.planning.planners import PlanStats, dispatcher_for

    stats = PlanStats()
    problem = DispatchProblem(smart, fleet, site, elevations, not args.per_joint, tuple(args.breakdown))
    return dispatcher_for(planner, problem, stats), stats


def run_thesis(args, model=None) -> int:
    """``simulate --mode thesis``: the thesis' step loop, Table 4.2 and Listing 4.2 outputs."""
    from bimrobot.coordination.thesis import DEFAULT_STEP_TIME, format_thesis_table, simulate_thesis, write_thesis_outputs
    from bimrobot.core.io import atomic_output_dir

    if args.per_joint:  # None unless given
        raise InputError("--per-joint is not available with --mode thesis (the thesis' loop works per connection node); use --mode event")
    if args.breakdown:
        raise InputError("--breakdown is not available with --mode thesis (the thesis' loop has no faults); use --mode event")
    if getattr(args, "planner", None) is not None:
        raise InputError("--planner is not available with --mode thesis (the thesis' loop is the market's); use --mode event")
    if args.evaluator != "least-cost":
        raise InputError(f"--mode thesis awards to the lowest bid (least-cost) only, got --evaluator {args.evaluator}")
    step_time = args.step_time or DEFAULT_STEP_TIME
    model, elevations, fleet, site, weights, smart_model = prepare(args, "simulate", model)
    smart = smart_model()
    result = simulate_thesis(smart, fleet, site, step_time, elevations)
    with atomic_output_dir(args.output, kind="simulate", inputs=input_files(args)) as tmp:
        write_thesis_outputs(result, tmp, unknown_weight=weights.as_dict(), smart_summary=smart.summary())
    message = weights.message()
    if message:
        print(message)
    info = smart.summary()
    print(f"{len(smart.components)} components ({len(info['prebuilt'])} prebuilt), {info['connection_nodes']} connection "
          f"nodes, {info['assembly_points']} assembly points")
    default = " (default)" if args.step_time is None else ""
    print(f"fleet {fleet.name}, thesis step loop: {result.steps} steps, construction time {result.construction_time:.1f} s "
          f"(step time rule: {step_time}{default})")
    print(format_thesis_table(result))
    print(f"output: {Path(args.output).resolve()}/ (events.log, robots.txt, robots.csv, requests.csv, summary.json)")
    return 0


def run_allocators(args) -> int:
    from bimrobot.planning.compare import compare_allocators, format_markdown, write_outputs
    from bimrobot.core.io import atomic_output_dir

    model, elevations, fleet, site, weights, smart_model = prepare(args, "allocators")
    message = weights.message()
    if message:
        print(message)
    rows = compare_allocators(
        smart_model, fleet, site, elevations,
        seeds=args.seeds, optimal=not args.no_optimal, time_limit_s=args.time_limit, max_tasks=args.max_tasks,
    )
    table = format_markdown(rows, title=f"{args.model}, fleet {fleet.name}")
    with atomic_output_dir(args.output, kind="allocators", inputs=input_files(args)) as tmp:
        write_outputs(rows, table, tmp)
    print(table)
    print(f"output: {Path(args.output).resolve()}/ (allocators.csv, allocators.md, allocators.json, allocators.png)")
    return 0
