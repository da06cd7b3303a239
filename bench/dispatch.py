"""The dispatching environment's cost per decision against the plain market run (issue 38).

    .venv/bin/python bench/dispatch.py                      # generated frames 2x2x1, 4x4x2, 6x6x3, per node
    .venv/bin/python bench/dispatch.py --sizes 2x2x1 8x8x4 --per-joint --repeat 3

For each generated steel frame (``bimrobot.coordination.generate.generated_frame``, fleet2, its derived
site): ``simulate`` with the least-cost market, then the same build in ``bimrobot/Dispatch-v0`` driven by
``MarketPolicy`` (the same schedule), padded to the next power of two. Printed: nodes, decisions, seconds
(min over ``--repeat``) and the ratios a reader can compare across machines: the environment's time over
simulate's, and the time per decision against the smallest frame's, measured in the same run.
"""

from __future__ import annotations

import argparse
import time


def problem(size: str, per_node: bool):
    from bimrobot.planning.dispatch import frame_problem

    nx, ny, floors = (int(v) for v in size.split("x"))
    return frame_problem(per_node=per_node, size=(nx, ny, floors))


def best(repeat: int, run) -> tuple[float, object]:
    times, value = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        value = run()
        times.append(time.perf_counter() - start)
    return min(times), value


def main() -> None:
    from bimrobot.coordination.simulation import ConstructionSimulation, simulate
    from bimrobot.planning.dispatch import DispatchEnv, MarketPolicy, play, task_graph

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["2x2x1", "4x4x2", "6x6x3"], help="NXxNYxFLOORS frames")
    parser.add_argument("--per-joint", action="store_true", help="tasks per joint (default per node, as simulate)")
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    print(f"{'frame':>8} {'nodes':>6} {'decisions':>9} {'simulate s':>10} {'env s':>7} {'env/sim':>7} {'ms/decision':>11} {'vs first':>8}")
    first = None
    for size in args.sizes:
        p = problem(size, not args.per_joint)
        sim_s, reference = best(args.repeat, lambda: simulate(p.smart, p.fleet, p.site, storey_elevations=p.storey_elevations,
                                                              per_node=p.per_node))
        sizing = ConstructionSimulation(p.smart, p.fleet, p.site, storey_elevations=p.storey_elevations, per_node=p.per_node)
        sizing.start()
        graph = task_graph(sizing)
        nodes, edges = len(graph.keys), len(graph.edges)
        env = DispatchEnv(p, max_tasks=1 << (nodes - 1).bit_length(), max_edges=1 << (edges - 1).bit_length())
        env_s, (_, result) = best(args.repeat, lambda: play(env, MarketPolicy()))
        assert result.makespan == reference.makespan, "the market in the environment must be simulate"
        per_decision = 1000 * env_s / env.decisions
        first = first or per_decision
        print(f"{size:>8} {nodes:>6} {env.decisions:>9} {sim_s:>10.2f} {env_s:>7.2f} {env_s / sim_s:>7.1f} "
              f"{per_decision:>11.2f} {per_decision / first:>8.1f}")


if __name__ == "__main__":
    main()
