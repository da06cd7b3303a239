"""The dispatching environment's cost per decision against the plain market run (issue 38).

    .venv/bin/python bench/dispatch.py                      # generated frames 2x2x1, 4x4x2, 6x6x3, per node
    .venv/bin/python bench/dispatch.py --sizes 2x2x1 8x8x4 --per-joint --repeat 3
    .venv/bin/python bench/dispatch.py --sizes generated:steel:10000 --observation views   # a generated IFC building
    .venv/bin/python bench/dispatch.py --sizes 12x12x4 --mode full local --observation views   # the local observation too

For each building: ``simulate`` with the least-cost market, then the same build in ``bimrobot/Dispatch-v0``
driven by ``MarketPolicy`` (the same schedule; checked). ``NXxNYxFLOORS`` is the in-memory steel frame
(``bimrobot.coordination.generate.generated_frame``, fleet2, its derived site); ``generated:KIND:...`` a
generated IFC building (``bimrobot.site.generated``, written once into its cache) with the fleet and
site drawn for it. The environment is padded to the building's own size, as the learned planner pads
it (``--pad pow2``: to the next powers of two); its observations are new arrays at every step
(``copies``, gymnasium's contract, the default) or read-only views of the kept arrays (``views``, as the
learned planner reads them), or each in turn (``--observation copies views``); of the whole building
(``--mode full``, the default) or of the ready tasks' neighbourhood (``--mode local``, ``observation="local"``). Times are this process's CPU seconds (the machine may be
shared; min over ``--repeat``), with the numba pass of the earliest starts loaded before. Printed:
nodes, edges, decisions, simulate's and the environment's CPU seconds, their ratio, CPU ms per decision
and the same less simulate's share (what the environment adds per decision).
"""

from __future__ import annotations

import argparse
import time


def problem(size: str, per_node: bool):
    """The DispatchProblem of a frame ``NXxNYxFLOORS`` or a ``generated:KIND:...`` spec."""
    from bimrobot.planning.dispatch import frame_problem

    if size.startswith("generated:"):
        from bimrobot.planning.benchmark import problem_for

        return problem_for(size, per_joint=not per_node)[0]
    nx, ny, floors = (int(v) for v in size.split("x"))
    return frame_problem(per_node=per_node, size=(nx, ny, floors))


def best(repeat: int, run) -> tuple[float, object]:
    """(least CPU seconds over ``repeat`` runs, the last run's value)."""
    times, value = [], None
    for _ in range(repeat):
        start = time.process_time()
        value = run()
        times.append(time.process_time() - start)
    return min(times), value


def padded(count: int, pad: str) -> int:
    return max(1, count) if pad == "own" else 1 << (max(1, count) - 1).bit_length()


def main() -> None:
    from bimrobot.coordination.simulation import ConstructionSimulation, simulate
    from bimrobot.planning.dispatch import DispatchEnv, MarketPolicy, play, task_graph

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["2x2x1", "4x4x2", "6x6x3"],
                        help="NXxNYxFLOORS frames or generated:KIND:... specs")
    parser.add_argument("--per-joint", action="store_true", help="tasks per joint (default per node, as simulate)")
    parser.add_argument("--pad", choices=("own", "pow2"), default="own", help="padding of the observation")
    parser.add_argument("--observation", nargs="+", choices=("copies", "views"), default=["copies", "views"],
                        help="new arrays at every step (gymnasium's contract) or read-only views")
    parser.add_argument("--mode", nargs="+", choices=("full", "local"), default=["full"],
                        help="the observation: the whole building, or the ready tasks' neighbourhood (observation='local')")
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    load = time.process_time()
    DispatchEnv().reset(seed=0)  # loads (or compiles) the numba passes once, outside the measured runs
    DispatchEnv(observation="local").reset(seed=0)
    print(f"first environment (numba pass loaded): {time.process_time() - load:.2f} CPU s")
    print(f"{'building':>22} {'mode':>5} {'obs':>6} {'nodes':>6} {'edges':>6} {'robots':>6} {'decisions':>9} {'simulate s':>10} {'env s':>7} "
          f"{'env/sim':>7} {'ms/decision':>11} {'env-sim ms':>10}")
    for size in args.sizes:
        p = problem(size, not args.per_joint)
        sim_s, reference = best(args.repeat, lambda: simulate(p.smart, p.fleet, p.site, storey_elevations=p.storey_elevations,
                                                              per_node=p.per_node))
        sizing = ConstructionSimulation(p.smart, p.fleet, p.site, storey_elevations=p.storey_elevations, per_node=p.per_node)
        sizing.start()
        graph = task_graph(sizing)
        nodes, edges, robots = len(graph.keys), len(graph.edges), len(p.fleet.robots)
        for mode, observation in ((m, o) for m in args.mode for o in args.observation):
            env = DispatchEnv(p, max_tasks=padded(nodes, args.pad), max_robots=padded(robots, args.pad),
                              max_edges=padded(edges, args.pad), copy_observation=observation == "copies",
                              observation=mode)
            env_s, (_, result) = best(args.repeat, lambda: play(env, MarketPolicy()))
            assert result.makespan == reference.makespan, "the market in the environment must be simulate"
            per_decision = 1000 * env_s / env.decisions
            print(f"{size:>22} {mode:>5} {observation:>6} {nodes:>6} {edges:>6} {robots:>6} {env.decisions:>9} {sim_s:>10.2f} "
                  f"{env_s:>7.2f} {env_s / sim_s:>7.1f} {per_decision:>11.2f} "
                  f"{1000 * (env_s - sim_s) / env.decisions:>10.2f}", flush=True)


if __name__ == "__main__":
    main()
