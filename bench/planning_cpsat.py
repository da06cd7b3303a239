"""CP-SAT at scale (issue 38): proof or gap on generated frames of growing size, and the cost of
generating buildings.

For each generated steel frame (``generated:NXxNYxFLOORS``, the chapter-4 shape) and fleet it prints the
tasks, how CP-SAT solved it (whole model, or floor by floor above ``--whole-tasks``), whether it proved
the optimum, the best makespan found and the lower bound with the gap between them, the least-cost
market's makespan (CP-SAT's first solution) and how far above the bound it is, and the wall and CPU
time. Ratios are against the market measured in the same run (best / market) and against the time
limit (time / limit). Wall time on a shared 2-core machine is disturbed by other processes; the CPU
time is the solver's own work (``--workers`` threads), and CP-SAT's deterministic time (its own work
units) is comparable across machines and loads; the load average at the start and end of each row is
printed with it, and each floor's own bound (solved alone; ``P`` where proved optimal, ``r`` where the floor
repeats one below it and takes its solve).

    .venv/bin/python bench/planning_cpsat.py                      # the default ladder, 600 s per instance
    .venv/bin/python bench/planning_cpsat.py --time-limit 120 --only 2x2x1:fleet1 4x3x2:fleet2
    .venv/bin/python bench/planning_cpsat.py --deterministic-limit 30 --time-limit 3600 --only 3x2x2:fleet2
    .venv/bin/python bench/planning_cpsat.py --generate           # generation time and size, 10 to 10,000 components
    .venv/bin/python bench/planning_cpsat.py --models generated:precast:3x3x3 ../shared/data/ifc/ROOT-staal.ifczip

``--models`` takes other instances, per joint: an IFC path (fleet site-crane, or the benchmark's prebuilt
fallback) or a ``generated:KIND:...`` spec (its drawn fleet and site), read as ``bimrobot plan benchmark``
reads them (:func:`bimrobot.planning.benchmark.problem_for`).

Goal (issue 38): where CP-SAT proves the optimum, up to at least 200 tasks within 10 minutes on a
2-core machine; beyond, a bound and a gap.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

#: (frame NXxNYxFLOORS, fleet): 10, 28, 28, 46, 92, 150, 208, 432 and 1,392 tasks
LADDER = ["2x1x1:fleet2", "2x2x1:fleet1", "2x2x1:fleet2", "3x2x1:fleet2", "3x2x2:fleet2", "3x3x2:fleet2",
          "4x3x2:fleet2", "4x4x3:fleet2", "6x6x4:fleet2"]


def _instance(item: str, model: bool):
    """(name, fleet name, smart model, fleet, site, storey elevations) of a ladder item FRAME:FLEET or,
    ``model`` True, of an IFC path or ``generated:KIND:...`` spec (the benchmark's problem, per joint)."""
    if model:
        from bimrobot.planning.benchmark import problem_for

        problem, fleet_name, note = problem_for(item)
        name = os.path.basename(item) + (f" ({note})" if note else "")
        return name, fleet_name, problem.smart, problem.fleet, problem.site, problem.storey_elevations
    from bimrobot.bim.selection import DEFAULT_PREBUILT
    from bimrobot.coordination.inputs import load_building
    from bimrobot.site.fleet import load_fleet
    from bimrobot.sco import build_smart_model

    frame, fleet = item.split(":")
    built, elevations = load_building(f"generated:{frame}")
    return frame, fleet, build_smart_model(built, prebuilt_classes=DEFAULT_PREBUILT), load_fleet(fleet), None, elevations


def solve(item: str, time_limit: float, workers: int, whole_tasks: int, deterministic: float | None = None,
          model: bool = False, linearization: int = 0) -> dict:
    from bimrobot.planning.optimal import solve_optimal

    frame, fleet, smart, robots, site, elevations = _instance(item, model)
    wall, cpu, load = time.perf_counter(), time.process_time(), os.getloadavg()[0]
    schedule = solve_optimal(smart, robots, site, storey_elevations=elevations, time_limit_s=time_limit,
                             workers=workers, whole_tasks=whole_tasks, deterministic_limit=deterministic,
                             linearization=linearization)
    return {"frame": frame, "fleet": fleet, "tasks": schedule.tasks, "method": schedule.method,
            "proved": schedule.status == "OPTIMAL", "best_s": schedule.makespan, "bound_s": schedule.lower_bound,
            "gap_pct": 100 * schedule.gap, "market_s": schedule.hinted_s,
            "market_over_bound_pct": 100 * (schedule.hinted_s - schedule.lower_bound) / schedule.hinted_s,
            "wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu,
            "deterministic_s": schedule.deterministic_s, "load_start": load, "load": os.getloadavg()[0],
            "floors": "/".join(f"{'P' if row['status'] == 'OPTIMAL' else '-'}{row['bound_s']:.1f}{'r' if row.get('repeats') else ''}"
                               for row in schedule.floors)
            + (f"; chained {schedule.chained_s:.1f}" if schedule.chained_s else "")}


def run_ladder(args) -> None:
    print(f"CP-SAT, {args.workers} workers, linearization {args.linearization}, {args.time_limit:g} s per instance, "
          f"whole model up to {args.whole_tasks} tasks, "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the start")
    print("| frame | fleet | tasks | method | proved | best (s) | bound (s) | gap | market (s) | market over bound | best / market "
          "| wall (s) | wall / limit | CPU (s) | deterministic (s) | load at start, end | floor bounds (s; P: proved, r: repeated); floors chained (s) |")
    print("|---|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    items = [(m, True) for m in args.models] if args.models else [(i, False) for i in args.only or LADDER]
    for item, model in items:
        r = solve(item, args.time_limit, args.workers, args.whole_tasks, args.deterministic_limit, model,
                  args.linearization)
        print(f"| {r['frame']} | {r['fleet']} | {r['tasks']} | {r['method']} | {'yes' if r['proved'] else 'no'} | "
              f"{r['best_s']:.1f} | {r['bound_s']:.1f} | {r['gap_pct']:.2f} % | {r['market_s']:.1f} | "
              f"{r['market_over_bound_pct']:.2f} % | {r['best_s'] / r['market_s']:.4f} | {r['wall_s']:.1f} | "
              f"{r['wall_s'] / args.time_limit:.2f} | {r['cpu_s']:.1f} | {r['deterministic_s']:.1f} | "
              f"{r['load_start']:.1f}, {r['load']:.1f} | {r['floors']} |", flush=True)


def run_generate(args) -> None:
    from bimrobot.site.generated import KINDS, generate

    print("| kind | asked | components | grid | wall (s) | CPU (s) | IFC (MB) | CPU per component (ms) |")
    print("|---|---:|---:|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as folder:
        for kind in args.kinds or KINDS:
            for count in args.components:
                wall, cpu = time.perf_counter(), time.process_time()
                made = generate(f"generated:{kind}:{count}", os.path.join(folder, f"{kind}-{count}.ifc"))
                wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
                size = made.path.stat().st_size / 1e6
                lay = made.layout
                print(f"| {kind} | {count:,} | {made.components:,} | {lay.nx} x {lay.ny} x {lay.floors} | {wall:.1f} | "
                      f"{cpu:.1f} | {size:.2f} | {1000 * cpu / made.components:.1f} |", flush=True)
                made.path.unlink()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--time-limit", type=float, default=600.0, help="seconds per instance (default 600)")
    parser.add_argument("--deterministic-limit", type=float, default=None,
                        help="CP-SAT's deterministic time per solve (its own work units: the same work under any load)")
    parser.add_argument("--workers", type=int, default=2, help="CP-SAT threads (default 2: this machine's cores)")
    parser.add_argument("--linearization", type=int, default=0,
                        help="CP-SAT's linearization_level (default 0: no LP; 1 was the default before)")
    parser.add_argument("--whole-tasks", type=int, default=400, help="above this many tasks, solve floor by floor")
    parser.add_argument("--only", nargs="*", help="instances FRAME:FLEET, e.g. 4x3x2:fleet2")
    parser.add_argument("--models", nargs="*", help="other instances: IFC paths or generated:KIND:... specs (instead of frames)")
    parser.add_argument("--generate", action="store_true", help="measure generated buildings instead")
    parser.add_argument("--kinds", nargs="*", help="with --generate: the building kinds (default all)")
    parser.add_argument("--components", type=int, nargs="*", default=[10, 100, 1000, 10000])
    args = parser.parse_args(argv)
    run_generate(args) if args.generate else run_ladder(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
