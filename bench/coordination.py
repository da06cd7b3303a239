"""Scaling of the market-based construction simulation: generated steel frames, 100 robots.

Builds a 20 x 20 column grid of 1 to 9 floors (1,160 to 10,440 components to build, plus 400
prebuilt footings) with a fleet of 100 robots (25 transport, 25 positioning, 25 assembly, 25 mobile
manipulators) and reports, per size, the wall time of generating the model, building the smart
components and simulating, and the peak memory. Each size runs in a fresh child process (so peak
memory is its own); growth is given as ratios against the smallest size, measured in the same run.
Time ratios use CPU time, which other processes on a shared machine disturb far less than wall time.

    .venv/bin/python bench/coordination.py            # 1, 2, 4 and 9 floors
    .venv/bin/python bench/coordination.py --floors 1 9

Goal: 10,000 components in under 30 s, growth close to linear.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

GRID = 20
ROBOTS_PER_KIND = 25


def bench_fleet():
    from bimrobot.site.fleet import fleet_from_dict

    robots = []
    for i in range(ROBOTS_PER_KIND):
        robots.append({"name": f"Transport{i}", "kind": "transport", "speed": 0.8, "carry_load": 300, "platform_size": [4, 1]})
        robots.append({"name": f"Positioning{i}", "kind": "positioning", "speed": 1.0, "payload": 300, "reach": 4.5, "time_per_node": 60})
        robots.append({"name": f"Assembly{i}", "kind": "assembly", "speed": 1.0, "reach": 4.5, "time_per_point": 30})
        robots.append({
            "name": f"Manipulator{i}", "kind": "mobile_manipulator", "speed": 1.0, "carry_load": 300, "platform_size": [4, 1],
            "payload": 300, "reach": 4.5, "time_per_node": 60, "time_per_point": 30,
        })
    return fleet_from_dict({"name": "bench-100", "robots": robots}, "bench/coordination.py")


def bench_site():
    from bimrobot.site.site import Site

    return Site(
        yard=tuple((-5.0, 3.0 * k) for k in range(GRID)),
        robot_home=tuple((-8.0, 1.5 * k) for k in range(2 * GRID)),
        construction_area=((0.0, 0.0), (60.0, 60.0)),
        model_offset=(0.0, 0.0),
    )


def run_one(floors: int) -> dict:
    """Generate, build and simulate one size; wall times in s, peak RSS in MiB."""
    from bimrobot.coordination.generate import generated_frame
    from bimrobot.coordination.simulation import simulate
    from bimrobot.sco import build_smart_model

    cpu0 = time.process_time()
    t0 = time.perf_counter()
    model = generated_frame(GRID, GRID, floors, bay_x=3.0, bay_y=3.0)
    t1 = time.perf_counter()
    smart = build_smart_model(model)
    t2 = time.perf_counter()
    result = simulate(smart, bench_fleet(), bench_site(), storey_elevations=[s.elevation for s in model.storeys])
    t3 = time.perf_counter()
    cpu = time.process_time() - cpu0
    return {
        "cpu_s": cpu,
        "floors": floors,
        "components": sum(1 for c in smart.components.values() if not c.prebuilt),
        "generate_s": t1 - t0,
        "smart_components_s": t2 - t1,
        "simulate_s": t3 - t2,
        "total_s": t3 - t0,
        "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "makespan_s": result.makespan,
        "steps": result.steps,
        "utilisation": result.utilisation,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--floors", type=int, nargs="+", default=[1, 2, 4, 9])
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one is not None:
        print(json.dumps(run_one(args.one)))
        return 0
    rows = []
    for floors in args.floors:
        child = subprocess.run([sys.executable, __file__, "--one", str(floors)], capture_output=True, text=True, check=True)
        rows.append(json.loads(child.stdout.strip().splitlines()[-1]))
        print(f"  {rows[-1]['components']:>6} components done in {rows[-1]['total_s']:.1f} s", file=sys.stderr)
    ref = rows[0]
    print(f"generated {GRID}x{GRID} frames, {4 * ROBOTS_PER_KIND} robots; ratios against the {ref['components']}-component run")
    print(f"{'components':>10} {'model s':>8} {'SCO s':>7} {'sim s':>7} {'wall s':>8} {'CPU s':>7} {'peak MiB':>9} "
          f"{'size x':>7} {'CPU x':>7} {'mem x':>6} {'makespan h':>10} {'util.':>6}")
    for row in rows:
        print(
            f"{row['components']:>10} {row['generate_s']:>8.2f} {row['smart_components_s']:>7.2f} {row['simulate_s']:>7.2f} "
            f"{row['total_s']:>8.2f} {row['cpu_s']:>7.2f} {row['peak_rss_mib']:>9.0f} {row['components'] / ref['components']:>7.2f} "
            f"{row['cpu_s'] / ref['cpu_s']:>7.2f} {row['peak_rss_mib'] / ref['peak_rss_mib']:>6.2f} "
            f"{row['makespan_s'] / 3600:>10.1f} {row['utilisation']:>6.1%}"
        )
    largest = rows[-1]
    verdict = "met" if largest["components"] >= 10_000 and largest["total_s"] < 30 else "not met"
    print(f"goal (10,000 components in < 30 s): {verdict} ({largest['components']} components, {largest['total_s']:.1f} s wall, "
          f"{largest['cpu_s']:.1f} s CPU)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
