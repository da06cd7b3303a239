"""Speed of the assembly benchmark, per setting, measured in one process.

    .venv/bin/python bench/assembly.py [--settings E1S1,E3S3,E4S4] [--num-envs 1024] [--repeat 5]

Reference: the single unwrapped env (``AssemblyEnv``, uniform random actions, a reset at episode end or
at the time limit), stepped in the same run as the batched simulator (``BatchedAssemblySim``, N envs,
uniform random actions, automatic resets). Each repeat measures the single env and then the batch, so
the ratio of a repeat compares two runs under the same load; min / median / max are over the repeats.
Throughputs are given in wall time (``time.perf_counter``) and in CPU time of this process
(``time.process_time``); the machine this runs on is often shared, so the ratios are the figures to
quote. The batched simulator's numba kernels are compiled (or loaded from their cache) before timing.

Also printed: the registered env (``gym.make``, with TimeLimit and Gymnasium's checker wrappers), mean
reset time and the exact planner's time per reset (mean and max over seeded resets), each the median of
the repeats. Goals from the issues: batched >= 1M env-steps/s in wall time at N = 1024, single >= 50k
steps/s, reset < 1 ms, planner < 1 s on Env4.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import bimrobot.assembly as assembly
from bimrobot.assembly.env import AssemblyEnv
from bimrobot.assembly.planner import plan
from bimrobot.assembly.vector import BatchedAssemblySim


def timed(run) -> tuple[float, float]:
    """(wall seconds, CPU seconds) of ``run()``."""
    wall, cpu = time.perf_counter(), time.process_time()
    run()
    return time.perf_counter() - wall, time.process_time() - cpu


def single_steps_per_s(env, steps: int, time_limit: int, seed: int = 0) -> tuple[float, float]:
    """(wall, CPU) steps/s of one env under uniform random actions."""
    actions = np.random.default_rng(seed).integers(6, size=steps).tolist()
    env.reset(seed=seed)

    def run():
        elapsed = 0
        for action in actions:
            _, _, terminated, truncated, _ = env.step(action)
            elapsed += 1
            if terminated or truncated or elapsed >= time_limit:
                env.reset()
                elapsed = 0

    wall, cpu = timed(run)
    return steps / wall, steps / cpu


def batched_steps_per_s(sim: BatchedAssemblySim, batches: int, seed: int = 1) -> tuple[float, float]:
    """(wall, CPU) env-steps/s of the batch under uniform random actions (its episodes go on between calls)."""
    actions = np.random.default_rng(seed).integers(6, size=(batches, sim.num_envs))

    def run():
        for batch in actions:
            sim.step(batch)

    wall, cpu = timed(run)
    return batches * sim.num_envs / wall, batches * sim.num_envs / cpu


def reset_ms(env, resets: int) -> float:
    env.reset(seed=0)
    start = time.perf_counter()
    for _ in range(resets):
        env.reset()
    return (time.perf_counter() - start) / resets * 1e3


def planner_ms(setting: str, resets: int) -> tuple[float, float]:
    env = AssemblyEnv(setting)
    times = []
    for seed in range(resets):
        env.reset(seed=seed)
        start = time.perf_counter()
        plan(env)
        times.append(time.perf_counter() - start)
    return float(np.mean(times) * 1e3), float(np.max(times) * 1e3)


def spread(values: list[float], scale: float = 1.0, fmt: str = "{:.2f}") -> str:
    """'min / median / max' of ``values / scale``."""
    low, mid, high = min(values), statistics.median(values), max(values)
    return " / ".join(fmt.format(v / scale) for v in (low, mid, high))


def measure(setting: str, args) -> dict:
    limit = assembly.benchmark_scenario(setting).time_limit
    sim = BatchedAssemblySim(setting, args.num_envs, seed=0)
    sim.reset()
    batched_steps_per_s(sim, 5)  # warm-up: kernels compiled or loaded from numba's cache
    rows: dict[str, list] = {"single": [], "batched": [], "ratio": [], "ratio_cpu": []}
    for _ in range(args.repeat):
        single = single_steps_per_s(AssemblyEnv(setting), args.steps, limit)
        batched = batched_steps_per_s(sim, args.batches)
        rows["single"].append(single)
        rows["batched"].append(batched)
        rows["ratio"].append(batched[0] / single[0])
        rows["ratio_cpu"].append(batched[1] / single[1])
    if args.extras:
        wrapped = (single_steps_per_s(assembly.make_env(setting), args.steps // 4, limit) for _ in range(args.repeat))
        rows["wrapped"] = [wall for wall, _ in wrapped]
        rows["reset"] = [reset_ms(AssemblyEnv(setting), 300) for _ in range(args.repeat)]
        rows["plan"] = planner_ms(setting, args.plans)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--settings", default="all", help="comma-separated settings (default: all 16)")
    parser.add_argument("--steps", type=int, default=20000, help="single-env steps per repeat")
    parser.add_argument("--num-envs", type=int, default=1024)
    parser.add_argument("--batches", type=int, default=300, help="batched steps per repeat")
    parser.add_argument("--plans", type=int, default=10, help="seeded resets planned per setting")
    parser.add_argument("--repeat", type=int, default=3, help="repeats per figure (>= 3)")
    parser.add_argument("--no-extras", dest="extras", action="store_false", help="only single vs batched")
    args = parser.parse_args()
    if args.repeat < 3:
        parser.error("--repeat must be at least 3 (min / median / max)")
    settings = assembly.SETTINGS if args.settings == "all" else args.settings.split(",")
    import numba

    print(f"N = {args.num_envs}, {args.repeat} repeats, min / median / max; numba {numba.__version__}")
    print(
        f"{'setting':8} {'single k/s wall':>16} {'batched M/s wall':>19} {'batched M/s CPU':>19} "
        f"{'x single (wall)':>19} {'x single (CPU)':>19}"
        + (f" {'gym.make k/s':>12} {'reset ms':>9} {'plan ms':>8} {'plan max':>9}" if args.extras else "")
    )
    worst = {"batched": np.inf, "ratio": np.inf, "single": np.inf, "reset": 0.0, "plan4": 0.0}
    for setting in settings:
        rows = measure(setting, args)
        single_wall = [s[0] for s in rows["single"]]
        batched_wall = [b[0] for b in rows["batched"]]
        batched_cpu = [b[1] for b in rows["batched"]]
        line = (
            f"{setting:8} {statistics.median(single_wall) / 1e3:16.0f} {spread(batched_wall, 1e6):>19} "
            f"{spread(batched_cpu, 1e6):>19} {spread(rows['ratio'], fmt='{:.1f}'):>19} "
            f"{spread(rows['ratio_cpu'], fmt='{:.1f}'):>19}"
        )
        if args.extras:
            plan_mean, plan_max = rows["plan"]
            line += (
                f" {statistics.median(rows['wrapped']) / 1e3:12.0f} {statistics.median(rows['reset']):9.3f}"
                f" {plan_mean:8.1f} {plan_max:9.1f}"
            )
            worst["reset"] = max(worst["reset"], statistics.median(rows["reset"]))
            if setting.startswith("E4"):
                worst["plan4"] = max(worst["plan4"], plan_max)
        print(line, flush=True)
        worst["batched"] = min(worst["batched"], statistics.median(batched_wall))
        worst["ratio"] = min(worst["ratio"], statistics.median(rows["ratio"]))
        worst["single"] = min(worst["single"], statistics.median(single_wall))
    print()
    goal = f"(goal >= 1000000 at N = {args.num_envs})"
    print(f"slowest batched (median, wall)   {worst['batched']:>12.0f} env-steps/s  {goal}")
    print(f"lowest batched / single (median) {worst['ratio']:>12.1f}")
    print(f"slowest single env (median)      {worst['single']:>12.0f} steps/s      (goal >= 50000)")
    if args.extras:
        print(f"slowest reset (median)           {worst['reset']:>12.3f} ms           (goal < 1)")
    if worst["plan4"]:
        print(f"slowest Env4 plan                {worst['plan4']:>12.1f} ms           (goal < 1000)")


if __name__ == "__main__":
    main()
