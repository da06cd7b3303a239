"""Speed of the assembly benchmark, per setting, measured in one process.

    .venv/bin/python bench/assembly.py [--settings E2S2,E4S4] [--steps 20000] [--num-envs 1024]

Columns: single unwrapped env steps/s (uniform random actions, a reset at episode end or at the time
limit), the registered env (gym.make, with TimeLimit and Gymnasium's checker wrappers) as the
reference, batched env-steps/s at N envs (and its ratio to the single env), mean reset time, and the
exact planner's time per reset (mean and max over seeded resets). Times are CPU time of this process
and throughputs the best of ``--repeat`` runs (as timeit does), because the machines this runs on are
often shared. Goals from the issue: single >= 50k
steps/s, batched >= 1M env-steps/s at N = 1024, reset < 1 ms, planner < 1 s on Env4.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import bimrobot.assembly as assembly
from bimrobot.assembly.env import AssemblyEnv
from bimrobot.assembly.planner import plan
from bimrobot.assembly.vector import BatchedAssemblySim


def single_steps_per_s(env, steps: int, time_limit: int, seed: int = 0) -> float:
    actions = np.random.default_rng(seed).integers(6, size=steps).tolist()
    env.reset(seed=seed)
    elapsed = 0
    start = time.process_time()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        elapsed += 1
        if terminated or truncated or elapsed >= time_limit:
            env.reset()
            elapsed = 0
    return steps / (time.process_time() - start)


def batched_steps_per_s(setting: str, num_envs: int, batches: int) -> float:
    sim = BatchedAssemblySim(setting, num_envs, seed=0)
    sim.reset()
    actions = np.random.default_rng(1).integers(6, size=(batches, num_envs))
    sim.step(actions[0])  # warm-up
    start = time.process_time()
    for batch in actions:
        sim.step(batch)
    return batches * num_envs / (time.process_time() - start)


def reset_ms(env, resets: int) -> float:
    env.reset(seed=0)
    start = time.process_time()
    for _ in range(resets):
        env.reset()
    return (time.process_time() - start) / resets * 1e3


def planner_ms(setting: str, resets: int) -> tuple[float, float]:
    env = AssemblyEnv(setting)
    times = []
    for seed in range(resets):
        env.reset(seed=seed)
        start = time.process_time()
        plan(env)
        times.append(time.process_time() - start)
    return float(np.mean(times) * 1e3), float(np.max(times) * 1e3)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--settings", default="all")
    parser.add_argument("--steps", type=int, default=20000, help="single-env steps per setting")
    parser.add_argument("--num-envs", type=int, default=1024)
    parser.add_argument("--batches", type=int, default=100, help="batched steps per setting")
    parser.add_argument("--plans", type=int, default=10, help="seeded resets planned per setting")
    parser.add_argument("--repeat", type=int, default=3, help="runs per throughput figure (best is kept)")
    args = parser.parse_args()
    settings = assembly.SETTINGS if args.settings == "all" else args.settings.split(",")
    print(
        f"{'setting':8} {'single/s':>10} {'gym.make/s':>11} {'batched/s':>11} {'x single':>9} "
        f"{'reset ms':>9} {'plan ms':>8} {'plan max':>9}"
    )
    worst = {"single": np.inf, "batched": np.inf, "reset": 0.0, "plan4": 0.0}
    for setting in settings:
        limit = assembly.benchmark_scenario(setting).time_limit
        best = lambda measure: max(measure() for _ in range(args.repeat))  # noqa: E731
        single = best(lambda: single_steps_per_s(AssemblyEnv(setting), args.steps, limit))
        wrapped = best(lambda: single_steps_per_s(assembly.make_env(setting), args.steps // 4, limit))
        batched = best(lambda: batched_steps_per_s(setting, args.num_envs, args.batches))
        reset = min(reset_ms(AssemblyEnv(setting), 300) for _ in range(args.repeat))
        plan_mean, plan_max = planner_ms(setting, args.plans)
        print(
            f"{setting:8} {single:10.0f} {wrapped:11.0f} {batched:11.0f} {batched / single:9.1f} "
            f"{reset:9.3f} {plan_mean:8.1f} {plan_max:9.1f}"
        )
        worst["single"] = min(worst["single"], single)
        worst["batched"] = min(worst["batched"], batched)
        worst["reset"] = max(worst["reset"], reset)
        if setting.startswith("E4"):
            worst["plan4"] = max(worst["plan4"], plan_max)
    print()
    print(f"slowest single env   {worst['single']:>10.0f} steps/s      (goal >= 50000)")
    print(f"slowest batched      {worst['batched']:>10.0f} env-steps/s  (goal >= 1000000 at N = {args.num_envs})")
    print(f"slowest reset        {worst['reset']:>10.3f} ms           (goal < 1)")
    if worst["plan4"]:
        print(f"slowest Env4 plan    {worst['plan4']:>10.1f} ms           (goal < 1000)")


if __name__ == "__main__":
    main()
