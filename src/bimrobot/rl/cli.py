"""Sub-commands of the rl part (registered by bimrobot.cli): ``bimrobot rl train | eval | benchmark | compare``."""

from __future__ import annotations

import argparse
import json
import shlex
import sys

TRAIN_EXAMPLE = """examples:
  bimrobot rl train --setting E3S2 --algo ppo --timesteps 1e6 --seed 0 -o runs/
  bimrobot rl train --setting E1S2 --algo maskable-ppo --profile fast --shaping 1 --timesteps 2e5 -o runs/
  tensorboard --logdir runs/      # the TensorBoard logs of every run
"""
EVAL_EXAMPLE = """example:
  bimrobot rl eval runs/E3S2-ppo-s0 --episodes 20
"""
BENCHMARK_EXAMPLE = """examples:
  bimrobot rl benchmark --settings all --algos maskable-ppo,double-dqn --seeds 0-2 --workers 2 \\
      --profile fast --shaping 1 --timesteps-per-env E1=2e5,E2=3e5,E3=6e5,E4=1e6 -o docs/results/maskable-ppo
  bimrobot rl benchmark --settings E1,E2 --algos all --seeds 0-4 --workers 16 --ray auto -o bench_out/
"""
COMPARE_EXAMPLE = """example:
  bimrobot rl compare docs/results/double-dqn docs/results/baselines docs/results/maskable-ppo \\
      -o docs/results/table.md
"""


def register(subparsers) -> None:
    """Add this part's sub-commands to the bimrobot parser."""
    rl = subparsers.add_parser("rl", help="DRL assembly planning: train, evaluate, benchmark (thesis ch. 6)",
                               description="Train and benchmark DRL agents on the assembly-planning settings.")
    commands = rl.add_subparsers(dest="rl_command", metavar="RL_COMMAND")
    rl.set_defaults(func=lambda args: (rl.print_help(), 1)[1])
    _add_train(commands)
    _add_eval(commands)
    _add_benchmark(commands)
    _add_compare(commands)


def _common(parser: argparse.ArgumentParser) -> None:
    """The training options ``train`` and ``benchmark`` share: profile, shaping, evaluation, threads."""
    from bimrobot.rl.names import PROFILE_NAMES, SHAPING_METRICS

    parser.add_argument("--profile", choices=list(PROFILE_NAMES), default="thesis",
                        help="hyperparameters: 'thesis' = appendix A.1 (default), 'fast' = more envs and larger "
                             "batches for a small CPU budget (see docs/rl.md)")
    parser.add_argument("--shaping", type=float, default=0.0, metavar="SCALE",
                        help="potential-based distance shaping of the training reward (0 = off, default); "
                             "reported returns are always the env's own")
    parser.add_argument("--shaping-metric", choices=list(SHAPING_METRICS), default="path",
                        help="the shaping's distance to the nearest free slot: 'path' = shortest path of "
                             "unblocked moves (default), 'manhattan' = L1, blind to obstacles")
    parser.add_argument("--eval-episodes", type=int, default=20, help="greedy evaluation episodes (default 20)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads per run (default 1)")


def _add_train(commands) -> None:
    """``rl train``: one algorithm on one setting."""
    from bimrobot.rl.names import ALGORITHM_NAMES

    train = commands.add_parser("train", help="train one algorithm on one setting", epilog=TRAIN_EXAMPLE,
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                description="Train, checkpoint and evaluate; writes the run dir <out>/<setting>-<algo>-s<seed>.")
    train.add_argument("--setting", required=True, help="E1S1 .. E4S4")
    train.add_argument("--algo", required=True, choices=list(ALGORITHM_NAMES))
    train.add_argument("--timesteps", default="1e6", help="env steps (e.g. 1e6, 250k; default 1e6)")
    train.add_argument("--seed", type=int, default=0)
    _output(train, default="runs", help="parent folder of the run dir (default runs/); a run dir of the same setting, "
            "algorithm and seed already there is kept, and the new run written beside it (<name>-2, ...)")
    train.add_argument("--checkpoint-every", default="1e5", help="env steps between checkpoints (default 1e5)")
    train.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help="override one hyperparameter, e.g. --set ent_coef=0.05 (JSON values); repeatable")
    train.add_argument("--no-progress", action="store_true", help="no progress bar")
    _common(train)
    train.set_defaults(func=_train)


def _add_eval(commands) -> None:
    """``rl eval``: greedy evaluation of a run dir."""
    evaluate = commands.add_parser("eval", help="greedy evaluation of a trained run dir", epilog=EVAL_EXAMPLE,
                                   formatter_class=argparse.RawDescriptionHelpFormatter,
                                   description="Run the run dir's policy greedily and print returns and normalised score.")
    evaluate.add_argument("run_dir")
    evaluate.add_argument("--episodes", type=int, default=20)
    evaluate.add_argument("--seed", type=int, default=None, help="first reset seed (default: the run's seed + 10000)")
    evaluate.add_argument("--json", action="store_true", help="print the result as JSON")
    evaluate.set_defaults(func=_eval)


def _add_benchmark(commands) -> None:
    """``rl benchmark``: the settings x algorithms x seeds grid."""
    from bimrobot.rl.names import ALGORITHM_NAMES

    bench = commands.add_parser("benchmark", help="the settings x algorithms x seeds grid, Table 6.1 style",
                                epilog=BENCHMARK_EXAMPLE, formatter_class=argparse.RawDescriptionHelpFormatter,
                                description="Train the grid in parallel (finished runs are reused) and write table.md, "
                                            "table.csv, grid.json and learning_curves.png to the output folder.")
    bench.add_argument("--settings", default="all", help="all, E1..E4, S1..S4 or a comma list (default all)")
    bench.add_argument("--algos", default="ppo,maskable-ppo,double-dqn",
                       help=f"comma list or 'all' ({', '.join(ALGORITHM_NAMES)})")
    bench.add_argument("--seeds", default="0-2", help="e.g. 0-4 or 0,3,7 (default 0-2)")
    bench.add_argument("--timesteps", default="1e6", help="env steps per run (default 1e6)")
    bench.add_argument("--timesteps-per-env", default=None, metavar="E1=...,E4=...",
                       help="per-environment (or per-setting) budgets, e.g. E1=1e5,E4=2e6")
    bench.add_argument("--workers", type=int, default=1, help="parallel runs (default 1)")
    bench.add_argument("--ray", default=None, metavar="ADDRESS",
                       help="run the grid on a Ray cluster ('auto', 'local' or host:port; needs pip install ray)")
    _output(bench, default="benchmark", help="output folder (default benchmark/)")
    bench.add_argument("--summary-only", action="store_true",
                       help="train nothing: rewrite the table and plots from the runs of this grid that have finished")
    _common(bench)
    bench.set_defaults(func=_benchmark)


def _add_compare(commands) -> None:
    """``rl compare``: one table from several benchmark folders."""
    compare = commands.add_parser("compare", help="one Table 6.1 from several benchmark output folders",
                                  epilog=COMPARE_EXAMPLE, formatter_class=argparse.RawDescriptionHelpFormatter,
                                  description="Put the algorithms of several benchmark grids side by side (scores, "
                                              "env steps to 0.9, goal check against the thesis' best cells).")
    compare.add_argument("grids", nargs="+", metavar="GRID", help="a bimrobot rl benchmark output folder")
    _output(compare, default=None, help="the Markdown file to write (required)")
    compare.set_defaults(func=_compare)


def _output(parser: argparse.ArgumentParser, default, help: str) -> None:
    """``-o/--output`` as every bimrobot command takes it; ``--out``, the old spelling, still works (hidden)."""
    parser.add_argument("-o", "--output", dest="out", default=default, metavar="PATH", help=help)
    parser.add_argument("--out", dest="out", default=default, help=argparse.SUPPRESS)


def _needs_rl() -> None:
    """Name the `rl` extra (PyTorch, Stable-Baselines3) before any work starts when it is missing."""
    from bimrobot.core.errors import require_extra

    for module in ("torch", "stable_baselines3", "sb3_contrib"):
        require_extra(module, "rl")


def _overrides(pairs: list[str]) -> dict:
    from bimrobot.core.errors import InputError

    overrides = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise InputError(f"--set {pair!r}: write KEY=VALUE, e.g. --set ent_coef=0.05")
        try:
            overrides[key.strip()] = json.loads(value)
        except json.JSONDecodeError:
            overrides[key.strip()] = value
    return overrides


def _train(args) -> int:
    _needs_rl()
    from bimrobot.rl.benchmark import parse_timesteps
    from bimrobot.rl.train import TrainConfig, train

    config = TrainConfig(
        setting=args.setting.upper(), algo=args.algo, timesteps=parse_timesteps(args.timesteps), seed=args.seed,
        profile=args.profile, overrides=_overrides(args.set), eval_episodes=args.eval_episodes,
        checkpoint_every=parse_timesteps(args.checkpoint_every, "--checkpoint-every"), threads=args.threads,
        progress_bar=not args.no_progress, shaping=args.shaping, shaping_metric=args.shaping_metric,
    )
    run_dir = train(config, args.out)
    results = json.loads((run_dir / "results.json").read_text())
    if run_dir.name != config.run_name:
        print(f"{run_dir.parent / config.run_name} holds an earlier run of this setting, algorithm and seed: "
              f"kept; this run is {run_dir.name}")
    print(f"run dir: {run_dir}  (config.json, model.zip, episodes.csv, progress.csv, TensorBoard events, checkpoints/)")
    _print_results(results)
    return 0


def _print_results(results: dict) -> None:
    def num(value, fmt=".2f"):
        return "n/a" if value is None else format(value, fmt)

    print(f"  last {min(results['train_episodes'], 100)} training episodes: mean return {num(results['train_last100_mean'])}"
          f" (score {num(results['train_last100_score'])})")
    print(f"  greedy evaluation, {len(results['eval_returns'])} episodes: mean return {num(results['eval_mean'])}"
          f" (score {num(results['eval_score'])})")
    print(f"  {results['timesteps']:,} env steps in {results['train_seconds']:.0f} s ({results['steps_per_second']:.0f} steps/s)")


def _eval(args) -> int:
    _needs_rl()
    from bimrobot.assembly.env import MAX_SEED
    from bimrobot.core.errors import InputError
    from bimrobot.rl.train import MAX_EVAL_EPISODES, evaluate_run

    if not 1 <= args.episodes <= MAX_EVAL_EPISODES:
        raise InputError(f"--episodes must be from 1 to {MAX_EVAL_EPISODES}, got {args.episodes}")
    if args.seed is not None and not 0 <= args.seed <= MAX_SEED:
        raise InputError(f"--seed must be from 0 to {MAX_SEED}, got {args.seed}")
    result = evaluate_run(args.run_dir, episodes=args.episodes, seed=args.seed)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        score = "n/a" if result["score"] is None else f"{result['score']:.3f}"
        print(f"{result['setting']} {result['algo']}: mean return {result['mean']:.2f} over {args.episodes} greedy "
              f"episodes (normalised score {score})")
    return 0


def _benchmark(args) -> int:
    _needs_rl()
    from bimrobot.core.errors import InputError
    from bimrobot.rl.benchmark import (
        MAX_WORKERS,
        BenchmarkSpec,
        parse_algos,
        parse_seeds,
        parse_settings,
        parse_timesteps,
        parse_timesteps_per_env,
        run_benchmark,
        summarise_finished,
    )

    if not 1 <= args.workers <= MAX_WORKERS:
        raise InputError(f"--workers must be from 1 to {MAX_WORKERS}, got {args.workers}")
    spec = BenchmarkSpec(
        settings=parse_settings(args.settings), algos=parse_algos(args.algos), seeds=parse_seeds(args.seeds),
        timesteps=parse_timesteps(args.timesteps), budgets=parse_timesteps_per_env(args.timesteps_per_env),
        profile=args.profile, eval_episodes=args.eval_episodes, threads=args.threads, shaping=args.shaping,
        shaping_metric=args.shaping_metric,
    )
    command = "bimrobot " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv[1:] else ""
    if args.summary_only:
        results = summarise_finished(spec, args.out, command=command)
    else:
        results = run_benchmark(spec, args.out, workers=args.workers, ray_address=args.ray, command=command)
    print(f"{len(results)} runs; summary in {args.out}/: table.md, table.csv, grid.json, learning_curves.png; "
          f"run dirs in {args.out}/runs/")
    return 0


def _compare(args) -> int:
    from bimrobot.core.errors import InputError
    from bimrobot.rl.compare import write_comparison

    if args.out is None:
        raise InputError("give the Markdown file to write with -o/--output, e.g. -o table.md")

    out = write_comparison(args.grids, args.out)
    print(f"comparison of {len(args.grids)} grids written to {out}")
    return 0
