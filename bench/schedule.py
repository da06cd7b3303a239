"""Schedule planning time against the number of activities (issue 14: a 14.5k-row schedule plans in < 5 s).

    .venv/bin/python bench/schedule.py                 # 20 x 20 frames of 1, 4 and 9 floors
    .venv/bin/python bench/schedule.py --floors 1 2 --repeat 5

Generated steel frames (``bimrobot.coordination.generate.generated_frame``, as bench/coordination.py)
of about 1,200 to 10,400 components; a synthetic schedule gives each component a transport, a
positioning and one assembly per connection node it owns, chained (seconds). Timed, min/median/max over
``--repeat`` runs: writing and reading the schedule CSV (validated against the model),
``Schedule.topological_order`` and RCAN's ``plan_from_schedule``. Growth is printed as ratios against the
smallest size, measured in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

GRID = 20


def synthetic_schedule(smart):
    """Transport, position and one assemble per connection node for every component to build (chained)."""
    from bimrobot.schedule.csv import PREDEFINED_TYPE
    from bimrobot.core.tasks import Activity
    from bimrobot.schedule.schedule import Schedule

    activities, clock = [], 0.0
    for component in smart.components.values():
        if component.prebuilt:
            continue
        previous = None
        steps = [("transport", None), ("position", None)] + [("assemble", n.id) for n in component.connection_nodes]
        for kind, node in steps:
            activity = Activity(
                id=f"A{len(activities) + 1:06d}", name=f"{kind} {node or component.id}", activity=kind,
                global_id=component.id, robot=f"{kind} robot", start=clock, finish=clock + 10.0,
                predecessors=(previous.id,) if previous else (), target=tuple(float(v) for v in component.origin),
                storey=component.storey_id, predefined_type=PREDEFINED_TYPE[kind], node_id=node,
            )  # fmt: skip
            clock, previous = activity.finish, activity
            activities.append(activity)
    return Schedule(activities)


def frame(floors: int):
    """(model, smart model, schedule, components to build) of a generated GRID x GRID frame."""
    from bimrobot.coordination.generate import generated_frame
    from bimrobot.sco import build_smart_model

    model = generated_frame(GRID, GRID, floors, bay_x=3.0, bay_y=3.0)
    smart = build_smart_model(model)
    return model, smart, synthetic_schedule(smart), sum(1 for c in smart.components.values() if not c.prebuilt)


def spread(times: list[float]) -> tuple[float, float, float]:
    return min(times), statistics.median(times), max(times)


def timed(function, repeat: int) -> list[float]:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return times


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--floors", type=int, nargs="+", default=[1, 4, 9])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    from bimrobot.schedule.csv import load_schedule_csv, write_schedule_csv
    from bimrobot.rcan.plans import plan_from_schedule

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for floors in args.floors:
            model, _, schedule, components = frame(floors)
            path = Path(tmp) / f"schedule-{floors}.csv"
            write_times = timed(lambda: (path.unlink(missing_ok=True), write_schedule_csv(schedule, path)), args.repeat)
            read_times = timed(lambda: load_schedule_csv(path, model=model), args.repeat)
            loaded = load_schedule_csv(path, model=model)
            order_times = timed(loaded.topological_order, args.repeat)
            plan_times = timed(lambda: plan_from_schedule(loaded, model), args.repeat)
            rows.append((components, len(schedule), write_times, read_times, order_times, plan_times))
            print(f"  {components} components, {len(schedule)} activities done", file=sys.stderr)
    ref = rows[0]
    print(f"generated {GRID}x{GRID} frames; seconds min/median/max over {args.repeat} runs; ratios of medians "
          f"against the {ref[1]}-activity schedule")
    print(f"{'components':>10} {'activities':>10} {'write csv s':>20} {'read csv s':>20} {'topo order s':>20} "
          f"{'plan s':>20} {'size x':>7} {'read x':>7} {'topo x':>7} {'plan x':>7}")
    for components, n, write, read, order, plan in rows:
        cells = " ".join(f"{'/'.join(f'{v:.3f}' for v in spread(t)):>20}" for t in (write, read, order, plan))
        ratios = " ".join(f"{statistics.median(t) / statistics.median(r):>7.2f}" for t, r in zip((read, order, plan), ref[3:]))
        print(f"{components:>10} {n:>10} {cells} {n / ref[1]:>7.2f} {ratios}")
    largest = rows[-1]
    total = statistics.median(largest[3]) + statistics.median(largest[4]) + statistics.median(largest[5])
    print(f"goal (a 14.5k-row schedule plans in < 5 s): read + order + plan of {largest[1]} rows = {total:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
