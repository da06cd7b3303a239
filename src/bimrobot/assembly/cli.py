"""Sub-commands of the assembly part: ``bimrobot assembly optimum | play | validate | from-ifc``."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

OPTIMUM_EXAMPLES = """examples:
  bimrobot assembly optimum --setting E2S2            # optimal and random-policy return of one setting
  bimrobot assembly optimum --setting all             # the 16-setting table (about a minute)
  bimrobot assembly optimum --setting all --write     # also store it in settings/reference_returns.json
  bimrobot assembly optimum --scenario frame.yaml     # a custom scenario (e.g. from `assembly from-ifc`)
"""

PLAY_EXAMPLES = """examples:
  bimrobot assembly play --setting E2S2 --policy planner --gif e2s2.gif
  bimrobot assembly play --setting E4S3 --policy random --seed 7 --ansi
  bimrobot assembly play --scenario my_site.yaml --policy planner --gif my_site.gif
  bimrobot assembly play --setting E3S2 --policy runs/E3S2-ppo-0/ --gif ppo.gif   # a trained agent
"""

VALIDATE_EXAMPLES = """examples:
  bimrobot assembly validate my_site.yaml             # exit 0 and a summary, or exit 2 and what is wrong
"""

FROM_IFC_EXAMPLES = """examples:
  bimrobot example steel-frame -o frame.ifc
  bimrobot assembly from-ifc frame.ifc --storey "Level 1" -o frame.yaml       # the grid measured (auto)
  bimrobot assembly from-ifc model.ifc --storey 0 --grid 6x7.2 -o ground.yaml  # storey by index, grid in metres
  bimrobot assembly play --scenario frame.yaml --policy planner --gif frame.gif
"""


def register(subparsers) -> None:
    """Add this part's sub-commands to the bimrobot parser."""
    parser = subparsers.add_parser(
        "assembly",
        help="DRL assembly-planning benchmark: optimal returns, animated episodes, scenario validation",
        description="The voxel assembly-planning benchmark of the thesis' chapter 6 (16 settings E1S1..E4S4).",
        epilog=OPTIMUM_EXAMPLES + PLAY_EXAMPLES + VALIDATE_EXAMPLES + FROM_IFC_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="assembly_command", metavar="SUBCOMMAND")
    parser.set_defaults(func=lambda args: (parser.print_help(), 1)[1])
    _add_optimum(sub)
    _add_play(sub)
    _add_validate(sub)
    _add_from_ifc(sub)


def _add_optimum(sub) -> None:
    """``assembly optimum``: the reference table of optimal and random returns."""
    optimum = sub.add_parser(
        "optimum",
        help="optimal (exact planner) and random-policy returns",
        description="Optimal return (exact planner) and uniformly random policy's mean return per setting; "
        "where resets are random, means over seeded resets 0..N-1.",
        epilog=OPTIMUM_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    optimum.add_argument("--setting", default="all", help="a setting such as E2S2, or 'all' (default)")
    optimum.add_argument("--scenario", metavar="YAML", help="a custom scenario file instead of --setting")
    optimum.add_argument("--episodes", type=int, default=100, help="seeded resets / random episodes (default 100)")
    optimum.add_argument("--write", action="store_true", help="store the table in settings/reference_returns.json")
    optimum.add_argument("--json", metavar="FILE", help="also write the table as JSON to FILE")
    optimum.set_defaults(func=cmd_optimum)


def _add_play(sub) -> None:
    """``assembly play``: one episode, printed or as a GIF."""
    play = sub.add_parser(
        "play",
        help="play one episode with the planner, a random or a trained policy (GIF, text)",
        description="Play one episode and print its return; optionally save an animated GIF.",
        epilog=PLAY_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    play.add_argument("--setting", help="benchmark setting (default: the run's setting for a run dir, else E2S2)")
    play.add_argument("--scenario", metavar="YAML", help="a custom scenario file instead of --setting")
    play.add_argument("--policy", default="planner", help="planner | random | a training run directory")
    play.add_argument("--seed", type=int, default=0, help="reset seed (default 0)")
    play.add_argument("--gif", metavar="FILE", help="write the episode as an animated GIF")
    play.add_argument("--fps", type=float, default=6.0, help="GIF frames per second (default 6)")
    play.add_argument("--ansi", action="store_true", help="print a text map of every step")
    play.set_defaults(func=cmd_play)


def _add_validate(sub) -> None:
    """``assembly validate``: check a scenario file."""
    validate = sub.add_parser(
        "validate",
        help="check a scenario YAML file",
        description="Load and validate a scenario YAML file; prints a summary, or the problem and exit status 2.",
        epilog=VALIDATE_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    validate.add_argument("scenario", help="scenario YAML file")
    validate.set_defaults(func=cmd_validate)


def _add_from_ifc(sub) -> None:
    """``assembly from-ifc``: a scenario from a storey of an IFC model."""
    from_ifc = sub.add_parser(
        "from-ifc",
        help="turn a storey's columns and beams into a custom scenario",
        description="Read a storey's columns (IfcColumn) and beams (IfcBeam, IfcMember when horizontal) from an IFC "
        "model, snap them to a voxel grid shaped like the benchmark's (a bay 4 cells, a column 4 cells tall), write the "
        "scenario YAML and validate it; says what was dropped and why.",
        epilog=FROM_IFC_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from_ifc.add_argument("model", help="IFC model (.ifc or .ifczip)")
    from_ifc.add_argument("--storey", required=True, help="storey name, or its index from 0 in the model's order")
    from_ifc.add_argument("--grid", default="auto",
                          help="grid spacing: 'auto' (of the most common column spacings per axis, the pair that keeps the most "
                          "beams; default), metres, or XxY metres")
    from_ifc.add_argument("--interchangeable", action="store_true",
                          help="any component may fill any free slot of its type (the benchmark's S2); the planner's "
                          "search grows exponentially with it")
    from_ifc.add_argument("--name", help="scenario name (default: MODEL-STOREY)")
    from_ifc.add_argument("-o", "--output", required=True, metavar="YAML", help="scenario file to write")
    from_ifc.set_defaults(func=cmd_from_ifc)


def _settings(arg: str) -> list[str]:
    from bimrobot.assembly.scenario import SETTINGS
    from bimrobot.core.errors import InputError

    if arg == "all":
        return list(SETTINGS)
    chosen = [s.strip() for s in arg.split(",") if s.strip()]
    for s in chosen:
        if s not in SETTINGS:
            raise InputError(f"--setting: unknown setting '{s}' (expected 'all' or one of {', '.join(SETTINGS)})")
    return chosen


MAX_EPISODES = 100_000
MAX_FPS = 100.0


def _check_seed(seed: int) -> None:
    from bimrobot.assembly.env import MAX_SEED
    from bimrobot.core.errors import InputError

    if not 0 <= seed <= MAX_SEED:
        raise InputError(f"--seed must be from 0 to {MAX_SEED}, got {seed}")


def cmd_optimum(args) -> int:
    from tqdm import tqdm

    from bimrobot.assembly.planner import REFERENCE_FILE, compute_reference_returns
    from bimrobot.assembly.scenario import SETTINGS_DIR
    from bimrobot.core.errors import InputError
    from bimrobot.core.io import atomic_output_file, check_output, signature

    scenario = None
    if args.scenario:
        if args.write:
            raise InputError("--write stores the benchmark's reference table: it does not take --scenario")
        from bimrobot.assembly.scenario import load_scenario

        scenario = load_scenario(args.scenario)
    settings = [scenario.name] if scenario else _settings(args.setting)
    if not 2 <= args.episodes <= MAX_EPISODES:
        raise InputError(f"--episodes must be from 2 to {MAX_EPISODES}, got {args.episodes}")
    if args.write and (args.setting != "all" or args.episodes != 100):
        raise InputError("--write stores the reference table: use it with --setting all and the default --episodes 100")
    inputs = [args.scenario] if scenario else [SETTINGS_DIR / f"{setting}.yaml" for setting in settings]
    # before the minute of planning, so that a bad path never throws the table away
    if args.json:
        check_output(args.json, folder=False, inputs=inputs, option="--json")
    if args.write:
        check_output(REFERENCE_FILE, folder=False, inputs=inputs, option="--write")
    rows = {}
    for setting in tqdm(settings, desc="settings", disable=len(settings) < 2 or not sys.stderr.isatty()):
        rows[setting] = compute_reference_returns(None if scenario else setting, args.episodes, scenario)
    width = max(8, *(len(setting) for setting in rows))
    print(f"{'setting':{width}} {'optimal':>10} {'± sem':>7} {'random':>10} {'± sem':>7}")
    for setting, row in rows.items():
        print(
            f"{setting:{width}} {row['optimal']:10.2f} {row['optimal_sem']:7.2f} {row['random']:10.2f} {row['random_sem']:7.2f}"
        )
    print(
        f"optimal: exact planner (mean over seeded resets 0..{args.episodes - 1} where resets are random); "
        f"random: uniform random actions, {args.episodes} seeded episodes"
    )
    table = {
        "generator": signature("assembly optimum"),
        "description": "Optimal (exact planner) and uniformly random policy mean returns per setting; "
        "written by `bimrobot assembly optimum --setting all --write`. "
        "score = (return - random) / (optimal - random).",
        "settings": rows,
    }
    if args.json:
        with atomic_output_file(args.json, inputs=inputs, option="--json") as tmp:
            tmp.write_text(json.dumps(table, indent=2) + "\n")
        print(f"wrote {args.json}")
    if args.write:
        with atomic_output_file(REFERENCE_FILE, inputs=inputs, option="--write") as tmp:
            tmp.write_text(json.dumps(table, indent=2) + "\n")
        print(f"wrote {REFERENCE_FILE}")
    return 0


def _make_policy(spec: str, env, seed: int):
    """(obs, info) -> action for 'planner' or 'random'."""
    import numpy as np

    from bimrobot.assembly.planner import planner_policy

    if spec == "planner":
        return planner_policy(env)
    rng = np.random.default_rng(seed)
    return lambda obs, info: int(rng.integers(6))


def _load_run_policy(spec: str):
    """The greedy policy of a training run directory (bimrobot.rl.policy.load_policy, imported lazily)."""
    from bimrobot.core.errors import InputError

    if not Path(spec).is_dir():
        raise InputError(f"--policy: '{spec}' is neither 'planner', 'random' nor a training run directory")
    try:
        from bimrobot.rl.policy import load_policy
    except ImportError as exc:
        raise InputError(f"--policy {spec}: loading trained policies needs the rl part (bimrobot.rl.policy): {exc}") from None
    return load_policy(spec)


def cmd_play(args) -> int:
    from bimrobot.assembly.scenario import SETTINGS_DIR
    from bimrobot.core.errors import InputError
    from bimrobot.core.io import check_output

    render_mode = "rgb_array" if args.gif else ("ansi" if args.ansi else None)
    if not (math.isfinite(args.fps) and 0 < args.fps <= MAX_FPS):
        raise InputError(f"--fps must be a number of frames per second above 0 and at most {MAX_FPS:g}, got {args.fps}")
    _check_seed(args.seed)
    inputs = [args.scenario] if args.scenario else [SETTINGS_DIR / f"{args.setting}.yaml"] if args.setting else []
    if args.policy not in ("planner", "random"):
        inputs += [Path(args.policy) / "model.zip", Path(args.policy) / "config.json"]
    if args.gif:  # before the episode (and the policy's loading), so that a bad path costs nothing
        check_output(args.gif, folder=False, inputs=inputs, option="--gif")
    run_policy = None if args.policy in ("planner", "random") else _load_run_policy(args.policy)
    env, name = _play_env(args, run_policy, render_mode)
    policy = run_policy or _make_policy(args.policy, env.unwrapped, args.seed)
    total, steps, placed, terminated, frames = _play_episode(env, policy, args)
    outcome = "terminated: structure complete" if terminated else "truncated: time limit"
    print(f"{name} seed {args.seed} policy {args.policy}: return {total:.4f} in {steps} steps ({outcome})")
    print(f"placed in order: {', '.join(placed) if placed else 'nothing'}")
    if args.gif:
        _write_play_gif(frames, args, inputs)
    env.close()
    return 0


def _play_env(args, run_policy, render_mode):
    """The environment ``play`` runs (time-limited) and the name it prints: the --scenario file's, or the
    setting given, the trained policy's, or E2S2."""
    import gymnasium as gym

    from bimrobot.assembly import make_env
    from bimrobot.assembly.env import AssemblyEnv
    from bimrobot.assembly.scenario import load_scenario
    from bimrobot.core.errors import InputError

    if args.scenario:
        scenario = load_scenario(args.scenario)
        env = gym.wrappers.TimeLimit(AssemblyEnv(scenario=scenario, render_mode=render_mode), scenario.time_limit)
        return env, scenario.name
    name = args.setting or getattr(run_policy, "setting", None) or "E2S2"
    _settings(name)
    if len(name) != 4:
        raise InputError("--setting: give one setting such as E2S2")
    trained_on = getattr(run_policy, "setting", None)
    if trained_on and trained_on != name:
        print(f"note: the policy was trained on {trained_on}, playing it on {name}", file=sys.stderr)
    return make_env(name, render_mode=render_mode), name


def _play_episode(env, policy, args):
    """One episode from reset seed ``args.seed``: (return, steps, ids placed in order, terminated, GIF frames);
    with --ansi (and no --gif) each step's text map is printed as it comes."""
    obs, info = env.reset(seed=args.seed)
    frames = []
    ansi = args.ansi and not args.gif
    if args.gif:
        frames.append(env.render())
    elif ansi:
        print(env.render())
    total, steps, placed = 0.0, 0, []
    terminated = truncated = False
    while not (terminated or truncated):
        action = int(policy(obs, info))
        obs, reward, terminated, truncated, info = env.step(action)
        total += reward
        steps += 1
        if info["placed"]:
            placed.append(info["placed"])
        if args.gif:
            frames.append(env.render())
        elif ansi:
            print(env.render())
    return total, steps, placed, terminated, frames


def _write_play_gif(frames: list, args, inputs: list) -> None:
    """The episode's frames as ``args.gif``, the last one held a second, written atomically."""
    from bimrobot.assembly.render import write_gif
    from bimrobot.core.io import atomic_output_file

    frames += [frames[-1]] * int(args.fps)  # hold the last frame a second
    with atomic_output_file(args.gif, inputs=inputs, option="--gif") as tmp:
        write_gif(frames, tmp, args.fps)
    print(f"wrote {args.gif} ({len(frames)} frames)")


def cmd_validate(args) -> int:
    from bimrobot.assembly.planner import plan
    from bimrobot.assembly.env import AssemblyEnv
    from bimrobot.assembly.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    n_handled = len(scenario.handled)
    print(
        f"{args.scenario}: valid scenario '{scenario.name}': grid {'x'.join(map(str, scenario.grid))}, "
        f"{n_handled} components to handle, {len(scenario.prebuilt)} prebuilt, {len(scenario.targets)} targets, "
        f"{len(scenario.obstacles)} obstacles, {scenario.layout} layout, time limit {scenario.time_limit}"
    )
    env = AssemblyEnv(scenario=scenario)
    env.reset(seed=0)
    best = plan(env)
    fits = "within" if best.steps <= scenario.time_limit else "BEYOND"
    print(f"solvable: the exact planner completes reset seed 0 in {best.steps} steps ({fits} the time limit), "
          f"return {best.return_:.4f}")
    return 0


#: Largest scenario whose optimum ``from-ifc`` computes (handled components; own slots: a chain of
#: shortest paths; interchangeable slots: the planner's search over slot sets grows exponentially).
PLAN_LIMIT = {False: 100, True: 13}


def cmd_from_ifc(args) -> int:
    from bimrobot.assembly.env import AssemblyEnv
    from bimrobot.assembly.from_ifc import dropped_summary, find_storey, frame_scenario, parse_grid, scenario_yaml
    from bimrobot.assembly.planner import plan
    from bimrobot.assembly.scenario import load_scenario
    from bimrobot.bim import load_model
    from bimrobot.core.io import atomic_output_file, check_output, signature

    grid = parse_grid(args.grid)
    check_output(args.output, folder=False, inputs=[args.model], option="-o")
    model = load_model(args.model, include="IfcColumn, IfcBeam, IfcMember", properties=False)
    storey = find_storey(model, args.storey)
    result = frame_scenario(model, storey, grid, args.interchangeable, args.name, source=args.output)
    sx, sy = result.spacing
    cx, cy, cz = result.cell
    read = ", ".join(f"{n} {cls}" for cls, n in sorted(result.read.items()))
    print(f"{result.model}: storey '{storey.name}': read {read}; grid {sx:g} x {sy:g} m "
          f"({'auto: the column spacings that keep the most beams' if result.auto else 'given'}), cells {cx:.3f} x {cy:.3f} x {cz:.3f} m")
    scenario = result.scenario
    columns = sum(c.type == "column" for c in scenario.components)
    print(f"kept {columns} columns and {len(scenario.components) - columns} beams; dropped {len(result.dropped)}")
    for line in dropped_summary(result.dropped):
        print(f"  dropped {line}")
    with atomic_output_file(args.output, inputs=[args.model], option="-o") as tmp:
        tmp.write_text(scenario_yaml(result, signature("assembly from-ifc")), encoding="utf-8")
    scenario = load_scenario(args.output)  # what a user's `validate` reads
    print(f"wrote {args.output}: valid scenario '{scenario.name}', grid {'x'.join(map(str, scenario.grid))}, "
          f"{len(scenario.handled)} components, time limit {scenario.time_limit}")
    if len(scenario.handled) > PLAN_LIMIT[args.interchangeable]:
        print(f"not planned: more than {PLAN_LIMIT[args.interchangeable]} components for the exact planner here")
        return 0
    env = AssemblyEnv(scenario=scenario)
    env.reset(seed=0)
    best = plan(env)
    fits = "within" if best.steps <= scenario.time_limit else "BEYOND"
    print(f"solvable: the exact planner completes it in {best.steps} steps ({fits} the time limit), return {best.return_:.4f}")
    return 0
