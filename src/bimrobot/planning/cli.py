"""``bimrobot plan``: the planning problem as data (``plan export``). Light imports: the work is imported
inside the command function."""

from __future__ import annotations

import argparse
from pathlib import Path

EXPORT_EXAMPLES = """examples:
  bimrobot example steel-frame -o frame.ifc
  bimrobot plan export frame.ifc --fleet fleet2 -o frame_fleet2.json
  bimrobot plan export house.ifc --fleet site-crane --prebuilt IfcFooting,IfcSlab,IfcWall -o house.json

The instance (JSON, version 2, docs/planning.md) is the problem `bimrobot simulate --per-joint` runs:
tasks, precedences and the rule behind each, release rule, robots with capabilities, speeds and handling
times, each task's handling time on each capable robot, the site (model_offset, yard, homes).
"""


def register(subparsers) -> None:
    """Add ``plan`` and its sub-command ``export`` to the bimrobot parser."""
    from bimrobot.bim.selection import add_prebuilt_option, add_selection_options
    from bimrobot.bim.unknown_weight import add_unknown_weight_option
    from bimrobot.coordination.options import ranged
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
        "--tolerance", type=ranged(float, 0.0, MAX_TOLERANCE_M, "m", low_inclusive=False), default=0.01,
        help=f"metres, > 0 and <= {MAX_TOLERANCE_M:g}; bodies this close count as touching (default 0.01)",
    )
    export.add_argument("--by-element", action="store_true", help="build element by element even when the model groups them into assemblies")
    add_selection_options(export, built=True)
    add_unknown_weight_option(export)
    export.set_defaults(func=run_export)
    _register_generate(commands)  # issue 38: generated buildings (block at the end of this file)
    register_train(commands)  # issue 38: the learned planner (block at the end of this file)
    _register_benchmark(commands)  # issue 38: planners compared (block at the end of this file)


def run_export(args) -> int:
    """``bimrobot plan export``: read model, fleet and site as ``simulate`` does; write the instance."""
    from bimrobot.coordination.inputs import input_files, prepare
    from bimrobot.core.io import atomic_output_file
    from bimrobot.planning.problem import build_instance, dumps

    # simulate's own checks and readers: output refused before the long work, fleet, site, model, prebuilt
    _, elevations, fleet, site, _, smart_model = prepare(args, None, folder=False)
    smart = smart_model()
    instance = build_instance(smart, fleet, site, elevations)
    with atomic_output_file(args.output, inputs=input_files(args)) as tmp:
        tmp.write_text(dumps(instance), encoding="utf-8")
    print(f"{args.output}: {len(instance['tasks'])} tasks, {len(instance['precedences'])} precedences, "
          f"{len(instance['robots'])} robots (fleet {fleet.name}); the problem of `simulate --per-joint`")
    print(f"output: {Path(args.output).resolve()}")
    return 0


# --- issue 38: `plan generate`, generated buildings for training (bimrobot.site.generated) -------------

GENERATE_EXAMPLES = """examples:
  bimrobot plan generate --kind precast --grid 4x3x5 --seed 7 -o precast_7/
  bimrobot plan generate --kind steel --components 1000 --seed 3 -o steel_1000/
  bimrobot simulate steel_1000/building.ifc --fleet steel_1000/fleet.yaml --site steel_1000/site.yaml -o sim/
  bimrobot simulate generated:panel:3x2x2:seed=1 --fleet site-crane -o sim_panel/   # the same building, no folder
  bimrobot plan generate --kind plates --grid 4x3x2 --seed 7 -o plates_7/   # 4 bays, 3 floor plates each, 2 floors

Writes building.ifc (IFC4, written with ifcopenshell.api: a steel frame, a precast column-beam-slab frame,
a panel building or a cross-wall building with precast floor plates), fleet.yaml (a random fleet varied
from a built-in one), site.yaml (the site derived from the building) and generated.json (spec, layout,
counts). The same kind, size and seed always give the same building. Real IFC models are the test set:
never generate them, never train on them.
"""


def _register_generate(commands) -> None:
    """Add ``plan generate``."""
    from bimrobot.site.generated import KINDS, MAX_COMPONENTS

    generate = commands.add_parser(
        "generate", help="write a generated building (IFC), its random fleet and its site",
        epilog=GENERATE_EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    generate.add_argument("--kind", choices=KINDS, default="steel", help="steel frame, precast frame, panel building or cross-wall building with floor plates (default steel)")
    size = generate.add_mutually_exclusive_group(required=True)
    size.add_argument("--components", type=int, help=f"about this many components (1 to {MAX_COMPONENTS:,}); the grid is drawn from the seed")
    size.add_argument("--grid", help="NXxNYxFLOORS: grid lines (panel: bays; plates: bays x plates per bay) and floors")
    generate.add_argument("--seed", type=int, default=0, help="seed of the layout, fleet and site (default 0)")
    generate.add_argument("--bolts", type=int, help="fasteners per connection node, 1 to 12 (default drawn from the seed)")
    generate.add_argument("-o", "--output", required=True, help="output folder (new, or one `plan generate` wrote)")
    generate.set_defaults(func=run_generate)


def run_generate(args) -> int:
    """``bimrobot plan generate``: the building, its fleet and its site in one folder."""
    import json
    import time

    from bimrobot.site.fleet import fleet_yaml
    from bimrobot.core.errors import InputError
    from bimrobot.core.io import atomic_output_dir, signature
    from bimrobot.site.generated import generate, parse_spec, summary
    from bimrobot.site.site import site_yaml

    if args.seed < 0:
        raise InputError(f"--seed must be a whole number >= 0, got {args.seed}")
    size = args.grid if args.grid is not None else str(args.components)
    spec = parse_spec(f"generated:{args.kind}:{size}:seed={args.seed}" + (f":bolts={args.bolts}" if args.bolts is not None else ""))
    with atomic_output_dir(args.output, kind="plan-generate") as tmp:
        started = time.perf_counter()
        made = generate(spec, tmp / "building.ifc")
        seconds = time.perf_counter() - started
        (tmp / "fleet.yaml").write_text(fleet_yaml(made.fleet, spec.text()), encoding="utf-8")
        (tmp / "site.yaml").write_text(site_yaml(made.site, spec.text()), encoding="utf-8")
        info = {"bimrobot": signature("generated building"), **summary(made),
                "ifc_bytes": (tmp / "building.ifc").stat().st_size}
        (tmp / "generated.json").write_text(json.dumps(info, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    layout = made.layout
    print(f"{spec.text()}: {made.components:,} components ({layout.nx} x {layout.ny} x {layout.floors} floors, "
          f"bays {layout.bay_x} x {layout.bay_y} m, storeys {layout.storey_height} m, {layout.bolts_per_node} fasteners "
          f"per node), {len(made.fleet.robots)} robots; written in {seconds:.1f} s")
    print(f"output: {Path(args.output).resolve()}/ (building.ifc, fleet.yaml, site.yaml, generated.json)")
    return 0


# --- issue 38: `plan benchmark`, every planner against CP-SAT's bound (bimrobot.planning.benchmark) ---------

BENCHMARK_EXAMPLES = """examples:
  bimrobot plan benchmark frame.ifc generated:steel:100:seed=0 -o bench/
  bimrobot plan benchmark ../shared/data/ifc/*.ifc* --time-limit 60 -o bench_real/
  bimrobot plan benchmark generated:steel:1000:seed=0 --planners market,rule:longest-path,cp-sat -o bench_1000/

Per model and planner: makespan (the plan executed by simulate's event simulation, per joint), CP-SAT's
lower bound and the gap to it, planning time (wall s) and time per decision. IFC files are built by
site-crane (with IfcFooting, IfcSlab and IfcWall prebuilt where it cannot build them otherwise),
generated:KIND:... buildings by the fleet drawn for them, unless --fleet is given. Writes benchmark.md
and benchmark.json. Planning times are wall times: compare them on one machine.
"""


def _register_benchmark(commands) -> None:
    """Add ``plan benchmark``."""
    from bimrobot.coordination.options import ranged

    bench = commands.add_parser(
        "benchmark", help="every planner on the same buildings: makespan, gap to CP-SAT's bound, planning time",
        epilog=BENCHMARK_EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    bench.add_argument("models", nargs="+", type=_ModelArgument,
                       help="IFC files or generated:KIND:NXxNYxF|N[:seed=S] specs")
    bench.add_argument("--planners", help="comma-separated planner names (default: all; learned where installed)")
    bench.add_argument("--fleet", help="fleet for every model (default: site-crane, or the generated building's own)")
    bench.add_argument("--time-limit", type=ranged(float, 0.0, 86_400.0, "s", low_inclusive=False), default=60.0,
                       help="CP-SAT's wall-clock limit per model, seconds (default 60)")
    bench.add_argument("--cpsat-max-tasks", type=ranged(int, 1, 1_000_000, ""), default=20_000,
                       help="larger models get no CP-SAT run (no bound), default 20000 tasks")
    bench.add_argument("-o", "--output", required=True, help="output folder (new, or one `plan benchmark` wrote)")
    bench.set_defaults(func=run_benchmark)


class _ModelArgument:
    """A benchmark model as the user wrote it: a generated spec stays a spec (its drawn fleet and its name
    in the table), not the cached file that bimrobot.cli gives other commands."""

    def __init__(self, text: str):
        self.text = text


def run_benchmark(args) -> int:
    """``bimrobot plan benchmark``: the table, printed and written."""
    from bimrobot.core.io import atomic_output_dir, check_output
    from bimrobot.planning.benchmark import DEFAULT_PLANNERS, bench_model, markdown, write
    from bimrobot.planning.planners import planner_for

    planners = tuple(p.strip() for p in args.planners.split(",")) if args.planners else DEFAULT_PLANNERS
    for name in planners:
        planner_for(name)  # an unknown name: one sentence, before any work
    check_output(args.output, folder=True, inputs=[], kind="plan-benchmark")
    entries = [bench_model(m.text, planners, args.fleet, args.time_limit, args.cpsat_max_tasks) for m in args.models]
    with atomic_output_dir(args.output, kind="plan-benchmark") as tmp:
        write(entries, args.time_limit, tmp)
    print(markdown(entries, args.time_limit))
    print(f"output: {Path(args.output).resolve()}/ (benchmark.md, benchmark.json)")
    return 0


# --- issue 38: `plan train`, the learned planner (bimrobot.planning.learned) ------------------------------

TRAIN_EXAMPLES = """examples:
  bimrobot plan train --seed 0 --steps 4096 -o runs/dispatch-s0/
  bimrobot plan train --seed 1 --steps 0 --imitation-steps 2000 -o runs/imitation-s1/   # imitation only

Trains on generated buildings only (steel, precast, panel; bimrobot.site.generated, drawn from the
seed): behaviour cloning of a teacher, then MaskablePPO fine-tuning with a size-independent policy
(docs/planning.md, "Learned planner"). The teacher is the pilot (at each decision where the market and the
priority rules disagree, it tries each and lets the market finish; it keeps the shortest build, so it is
never longer than the market), the least-cost market (--teacher market), the search (--teacher search)
or CP-SAT's schedules per joint (--teacher cp-sat). Writes policy.zip (use it with
--planner PATH.zip), imitation.zip (the policy after imitation, before PPO) and train.json (command, seed, accuracy, the
training buildings and the market's makespan on each). Bounded by steps, never by wall time; one torch thread.
"""


def register_train(commands) -> None:
    """Add ``plan train``."""
    train = commands.add_parser(
        "train", help="train the learned planner on generated buildings (imitation of a teacher, then PPO)",
        epilog=TRAIN_EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    train.add_argument("--seed", type=int, default=0, help="seed of the training buildings, weights and PPO (default 0)")
    train.add_argument("--steps", type=int, default=4096, help="PPO env steps after imitation (default 4096; 0: imitation only)")
    train.add_argument("--imitation-steps", type=int, default=400, help="behaviour-cloning mini-batches of the teacher's choices (default 400; 0: none)")
    # learned_train.TEACHERS, written out: importing it would load torch for every `bimrobot plan` command
    train.add_argument("--teacher", choices=("pilot", "market", "search", "cp-sat"), default="pilot",
                       help="whose decisions are imitated: the pilot (market and rules tried, the shortest kept; default), the "
                       "least-cost market, the search (--planner rollout: the portfolio's best improved by 400 rollouts), or "
                       "CP-SAT (5 deterministic seconds per solve, on the buildings per joint)")
    train.add_argument("--observation", choices=("full", "local"), default="full",
                       help="what the policy reads: the whole building (default, advised) or the ready tasks' "
                            "neighbourhood (size-independent cost per decision; not advised; teacher search or market)")
    train.add_argument("--hidden", type=int, default=32,
                       help="the network's width (default 32; its cost per decision grows with its square)")
    train.add_argument("-o", "--output", required=True, help="output folder (new, or one `plan train` wrote)")
    train.set_defaults(func=run_train)


def run_train(args) -> int:
    """``bimrobot plan train``: train, write policy.zip, imitation.zip and train.json in one folder."""
    import json

    from bimrobot.core.io import atomic_output_dir, check_output, signature
    from bimrobot.planning.learned import policy_bytes, save
    from bimrobot.planning.learned_train import train, train_command

    check_output(args.output, folder=True, kind="plan-train")  # refused before the long work
    command = train_command(args.seed, args.steps, args.imitation_steps, args.teacher, args.observation, args.hidden,
                            args.output)
    imitated: dict = {}

    def keep(model, accuracy):
        # the observation too: without it the policy would be read as one of the full observation
        imitated["zip"] = policy_bytes(model, {"stage": "after imitation, before PPO", "imitation_accuracy": accuracy,
                                               "observation": args.observation, "teacher": args.teacher})

    result = train(args.seed, args.steps, args.imitation_steps, command=command, on_imitated=keep, teacher=args.teacher,
                   observation=args.observation, hidden=args.hidden)
    with atomic_output_dir(args.output, kind="plan-train") as tmp:
        save(result.model, tmp / "policy.zip", result.meta)
        if imitated:
            (tmp / "imitation.zip").write_bytes(imitated["zip"])
        info = {"bimrobot": signature("plan train"), **result.meta}
        (tmp / "train.json").write_text(json.dumps(info, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    accuracy = "" if result.accuracy is None else f"; imitation reproduces {100 * result.accuracy:.1f} % of the {args.teacher} teacher's choices"
    print(f"trained on {len(result.pool)} generated buildings, {args.imitation_steps} imitation steps, {args.steps} PPO steps{accuracy}")
    print(f"output: {Path(args.output).resolve()}/ (policy.zip, imitation.zip, train.json)")
    return 0
