"""Construction-graph build time against the number of triples (issue 14: 505k triples took 155 s).

    .venv/bin/python bench/graph.py                     # 20 x 20 frames of 1, 4 and 9 floors
    .venv/bin/python bench/graph.py --floors 1 2 --repeat 3 --stores oxigraph-memory memory

Generated steel frames (as bench/coordination.py) of about 1,200 to 10,400 components with the
synthetic schedule of bench/schedule.py (transport, position, one assembly per node, chained) and the
simulation's joints and nodes (``build_graph(..., smart=...)``). Timed, min/median/max over ``--repeat``
runs: building the graph in each store (``oxigraph-memory`` is what ``bimrobot graph`` uses when the
oxigraph extra is installed, ``memory`` the rdflib store of the Python API) and writing it as Turtle.
Growth is printed as ratios of medians against the smallest size, measured in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from schedule import frame, spread, timed  # noqa: E402  (bench/schedule.py)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--floors", type=int, nargs="+", default=[1, 4, 9])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--stores", nargs="+", default=["oxigraph-memory"], choices=["oxigraph-memory", "memory"])
    args = parser.parse_args()
    from bimrobot.lbd.graph import build_graph

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for floors in args.floors:
            model, smart, schedule, components = frame(floors)
            for store in args.stores:
                graphs = []
                build = timed(lambda: graphs.append(build_graph(model, schedule, store=store, smart=smart)), args.repeat)
                graph = graphs[-1]
                out = Path(tmp) / f"graph-{floors}-{store}.ttl"
                write = timed(lambda: (out.unlink(missing_ok=True), graph.serialize(out)), args.repeat)
                rows.append((store, components, len(schedule), len(smart.joints), len(graph), build, write))
                print(f"  {store}: {components} components, {len(graph)} triples done", file=sys.stderr)
                for g in graphs:
                    g.close()
    print(f"generated 20x20 frames with schedule and joints; seconds min/median/max over {args.repeat} runs; "
          "ratios of medians against the smallest size of the same store")
    print(f"{'store':>16} {'components':>10} {'activities':>10} {'joints':>7} {'triples':>9} {'build s':>20} "
          f"{'write .ttl s':>20} {'triples/s':>10} {'triples x':>9} {'build x':>8} {'write x':>8}")
    for store in args.stores:
        mine = [r for r in rows if r[0] == store]
        ref = mine[0]
        for _, components, activities, joints, triples, build, write in mine:
            print(
                f"{store:>16} {components:>10} {activities:>10} {joints:>7} {triples:>9} "
                f"{'/'.join(f'{v:.2f}' for v in spread(build)):>20} {'/'.join(f'{v:.2f}' for v in spread(write)):>20} "
                f"{triples / statistics.median(build):>10.0f} {triples / ref[4]:>9.2f} "
                f"{statistics.median(build) / statistics.median(ref[5]):>8.2f} {statistics.median(write) / statistics.median(ref[6]):>8.2f}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
