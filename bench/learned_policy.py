"""The learned planner against the least-cost market on the shared real models (issue 38).

Each problem as ``simulate`` reads it: per node (simulate's default), fleet site-crane (IfcFooting, IfcSlab
and IfcWall prebuilt where that fleet cannot build them otherwise), the chapter-4 frame with fleet2. For each:
the market's makespan, the policy's own (greedy), and the guarded planner's (the shorter of the two),
executed by ``simulate`` with the planner's dispatcher (asserted equal, no market fallback).
Makespans in simulated seconds; no timing.

    .venv/bin/python bench/learned_policy.py [POLICY.zip]                 # default: the shipped policy
    .venv/bin/python bench/learned_policy.py --validation A.zip B.zip ...   # pick among policies
    .venv/bin/python bench/learned_policy.py --scale generated:steel:100:seed=0 generated:steel:1000:seed=0 [--reference]
    .venv/bin/python bench/learned_policy.py --search [--budget N] [--no-ablation] [--policy P.zip] [MODEL ...]  # the search
    .venv/bin/python bench/learned_policy.py --scale [--policy P.zip] [--alone [--reference]] generated:steel:10000
    .venv/bin/python bench/learned_policy.py --slice 4000:8000 [--sample] generated:steel:10000   # where a decision goes

``--search`` plans each model per joint with site-crane (as ``bimrobot plan benchmark``; default: the ten
buildable shared models) with the learned planner's decision-time search (``--budget`` rollouts,
default 400) and the same search on the advisers' choices only (``rollout``, the ablation): makespans
against the market, the portfolio and CP-SAT's figures of docs/planning.md, this process's CPU seconds,
rollouts used; each searched schedule executed by ``simulate`` (asserted equal to the plan, no fallback).

``--validation`` plays each policy alone on generated buildings that no training run draws (seeds from
9,000), larger than the training ones, and prints each policy's mean and worst makespan in per cent of the
market's: how a policy is chosen without looking at the real models (docs/planning.md, "How it was chosen":
the lowest mean among those never longer than the market on any of them).

``--scale`` measures the shipped policy's planning cost on generated buildings (per node, the drawn fleet
and site, as ``bench/dispatch.py``): this process's CPU seconds of ``--planner learned`` (and of the
market's run it forks, apart), its wall seconds, per decision; of the policy alone, and where the policy's go (observation, advice, network; the
rest is the environment's simulation). ``--reference`` also plays sb3-contrib's path (every pair scored)
and checks that it takes the same actions.

``--slice A:B`` plays the shipped policy alone (greedy) on one generated building, decisions A to B timed
(this process's CPU): ms per decision, of it the network and its inputs (``LearnedPolicy(timed=True)``),
the rest the environment's step and the glue; the observed nodes at B. ``--sample``: instead of the
clock reads, a sampling profile (``SIGPROF`` every 0.2 ms of CPU): ms per decision inside each function
(each sample's stack counted once per function; time in compiled code goes to the Python function that
called it), the 30 largest.
"""

import sys

import torch as th

from bimrobot.coordination.simulation import simulate

from bimrobot.core.errors import InputError
from bimrobot.planning.dispatch import MarketPolicy, frame_problem, play, simulate_problem
from bimrobot.planning.learned import DEFAULT_POLICY, LearnedPlanner, env_for

SHARED = "../shared/data/ifc/"
MODELS = ("MULTICOM-trappen_bordessen.ifc", "ifcColumn.ifc", "GEELEN-Breedplaat_V1.ifc", "ROOT-staal.ifczip")


def problems():
    """(name, problem) of the frame and the shared real models."""
    yield "chapter-4 frame (fleet2)", frame_problem()
    for name in MODELS:
        try:
            yield name, simulate_problem([SHARED + name, "--fleet", "site-crane"])
        except InputError:
            yield name + " (prebuilt)", simulate_problem([SHARED + name, "--fleet", "site-crane",
                                                          "--prebuilt", "IfcFooting,IfcSlab,IfcWall"])


VALIDATION = tuple(f"generated:{kind}:{grid}:seed={9000 + i}" for i, (kind, grid) in enumerate(
    (("steel", "4x3x2"), ("steel", "3x3x3"), ("precast", "3x3x2"), ("precast", "4x2x2"), ("panel", "3x3x2"), ("panel", "4x3x1"),
     ("plates", "4x3x2"), ("plates", "3x4x1"))))


def validation(paths) -> None:
    """Each policy alone against the market on :data:`VALIDATION` (per cent of the market's makespan)."""
    from bimrobot.planning.learned import generated_problem

    th.set_num_threads(1)
    planners = [LearnedPlanner(p, guard=False) for p in paths]
    ratios = [[] for _ in paths]
    for spec in VALIDATION:
        problem = generated_problem(spec)
        _, market = play(env_for(problem), MarketPolicy(), seed=0)
        cells = []
        for planner, mine in zip(planners, ratios):
            _, result = planner.play(problem)
            mine.append(100.0 * result.makespan / market.makespan)
            cells.append(f"{mine[-1] - 100:+.2f} %")
        print(f"| {spec} | {market.makespan:,.1f} | " + " | ".join(cells) + " |", flush=True)
    print("| mean | | " + " | ".join(f"{sum(r) / len(r) - 100:+.2f} %" for r in ratios) + " |")
    print("| worst | | " + " | ".join(f"{max(r) - 100:+.2f} %" for r in ratios) + " |")


def scale(specs, path=None, alone: bool = False, reference: bool = False) -> None:
    """CPU seconds of ``--planner learned`` (the policy at ``path``, default the shipped one, with its
    decision-time search under the simulated-decision budget) per decision of its plan, on each generated
    building; ``alone``: also the policy alone (greedy, no guard), ``reference`` with sb3-contrib's path."""
    import time

    from bimrobot.planning.benchmark import problem_for
    from bimrobot.planning.learned import LearnedPolicy, load_policy, sizes

    th.set_num_threads(1)
    from bimrobot.planning.dispatch import DispatchEnv

    DispatchEnv().reset(seed=0)  # the numba passes loaded (or compiled) outside the measured runs
    DispatchEnv(observation="local").reset(seed=0)
    print("| building | observation | nodes | plan decisions | learned CPU s (this process + forked) | wall s | "
          "ms per decision (CPU / wall) | market s | policy s | planned s | members, rollouts | alone CPU s | sb3 path ms |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|")
    for spec in specs:
        problem = problem_for(spec, per_joint=False)[0]
        planner = LearnedPlanner(path)
        start, wall, forked = time.process_time(), time.perf_counter(), _children_cpu()
        planner.dispatcher(problem)
        cpu, last = time.process_time() - start, planner.last
        wall, forked = time.perf_counter() - wall, _children_cpu() - forked
        decisions = int(last["planned_decisions"])
        extra = ["", ""]
        if alone:
            env = env_for(problem, copy_observation=False, observation=planner.observation)
            policy = LearnedPolicy(load_policy(planner.path, env))
            start = time.process_time()
            awards, _ = planner.play(problem, policy)
            extra[0] = f"{time.process_time() - start:.1f}"
            if reference:
                start = time.process_time()
                same, _ = planner.play(problem, LearnedPolicy(policy.policy, fast=False))
                extra[1] = f"{1000 * (time.process_time() - start) / policy.decisions:.2f}"
                assert same == awards, "the fast greedy choice must be sb3-contrib's"
        print(f"| {spec} | {planner.observation} | {sizes(problem)[0]:,} | {decisions:,} | {cpu:.1f} + {forked:.1f} | {wall:.1f} | "
              f"{1000 * cpu / decisions:.2f} / {1000 * wall / decisions:.2f} | {last['market_s']:,.1f} | {last['policy_s']:,.1f} | {last['planned_s']:,.1f} | "
              f"{', '.join(last['search_members'])}; {last['search_rollouts']} | {extra[0]} | {extra[1]} |", flush=True)


def sliced(spec: str, first: int, last: int, sample: bool = False) -> None:
    """The shipped policy alone on ``spec``, decisions ``first`` to ``last`` timed or sampled (see the docstring)."""
    import collections
    import signal
    import time

    from bimrobot.planning.benchmark import problem_for
    from bimrobot.planning.learned import LearnedPolicy, load_policy

    th.set_num_threads(1)
    env = env_for(problem_for(spec, per_joint=False)[0], copy_observation=False, observation="local")
    policy = LearnedPolicy(load_policy(DEFAULT_POLICY, env), timed=not sample)
    env.reset(seed=0)
    while env.decisions < first:
        env.step(policy(env))
    policy.cpu = dict.fromkeys(policy.cpu, 0.0)
    inside, samples = collections.Counter(), [0]

    def count(_signal, frame):
        samples[0] += 1
        inside.update({f"{f.f_code.co_filename.rsplit('/', 1)[-1]}:{f.f_code.co_name}" for f in _stack(frame)})

    if sample:
        signal.signal(signal.SIGPROF, count)
        signal.setitimer(signal.ITIMER_PROF, 0.0002, 0.0002)
    start, done = time.process_time(), False
    while env.decisions < last and not done:
        _, _, done, _, _ = env.step(policy(env))
    ms = 1000 * (time.process_time() - start) / max(env.decisions - first, 1)
    signal.setitimer(signal.ITIMER_PROF, 0, 0)
    print(f"{spec}, decisions {first:,}-{env.decisions:,}: {ms:.3f} ms per decision, {env._local.count:,} observed nodes at the last")
    if not sample:
        network, inputs = (1000 * policy.cpu[k] / max(env.decisions - first, 1) for k in ("network", "observation"))
        print(f"network {network:.3f} ms, its inputs {inputs:.3f}, the environment and the glue {ms - network - inputs:.3f}")
    for name, hits in inside.most_common(30):
        print(f"  {ms * hits / samples[0]:.3f} ms  {name}")


def _stack(frame):
    while frame is not None:
        yield frame
        frame = frame.f_back


def _children_cpu() -> float:
    """CPU seconds of this process's ended children (the market's forked run), user and system."""
    import resource

    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def main(path) -> None:
    th.set_num_threads(1)
    planner = LearnedPlanner(path, search=0)  # learned:greedy: the policy alone, guarded
    print("| model | market (s) | policy (s) | policy vs market | guarded planner (s) | plan used |")
    print("|---|---:|---:|---:|---:|---|")
    for name, problem in problems():
        _, market = play(env_for(problem), MarketPolicy(), seed=0)
        replay = planner.dispatcher(problem)
        run = simulate(problem.smart, problem.fleet, problem.site, "least-cost", 0, problem.breakdowns,
                       problem.storey_elevations, per_node=problem.per_node, dispatcher=replay)
        last = planner.last
        assert abs(last["market_s"] - market.makespan) < 1e-6
        diff = 100.0 * (last["policy_s"] - market.makespan) / market.makespan
        used = min(last["policy_s"], last["market_s"])
        assert abs(run.makespan - used) < 1e-6 and replay.fallbacks == 0, (run.makespan, used, replay.fallbacks)
        print(f"| {name} | {market.makespan:,.1f} | {last['policy_s']:,.1f} | {diff:+.1f} % | {used:,.1f} | {last['chosen']} |",
              flush=True)


#: CP-SAT's best schedule (as executed) and lower bound (s) per joint with site-crane, from ``bimrobot plan
#: benchmark`` of 2026-11-29 04:39-04:45 (S11: CP-SAT without its LP, from the portfolio's shortest schedule
#: and its own list schedule, the floors as the simulation closes them; docs/planning.md, "Shared real
#: models": one worker, 90 s; None: no schedule found)
CPSAT = {"AC20-FZK-Haus.ifc": (71656.3, 60387.2), "GEELEN-Breedplaat_V1.ifc": (6908.9, 6655.4),
         "IfcOpenHouse_IFC4.ifc": (1252.2, 1252.2), "MULTICOM-Prefab.ifc": (28250.6, 27274.0),
         "MULTICOM-trappen_bordessen.ifc": (3000.6, 3000.6), "ROOT-staal.ifczip": (26879.5, 25667.5),
         "column-extruded-solid.ifc": (749.5, 749.5), "construction-scheduling-task.ifc": (5339.3, 5339.3),
         "ifcColumn.ifc": (1121.3, 1121.3), "ifcUnit.ifc": (6061.1, 6061.2)}


def searched(models, budget: int, ablation: bool = True, path=None) -> None:
    """The search with the policy (``path``, default the shipped one) and, ``ablation``, without it, on
    each model, against the baselines."""
    import time

    from bimrobot.planning.benchmark import problem_for
    from bimrobot.planning.learned import LearnedPolicy, load_policy
    from bimrobot.planning.learned_search import AwardsReplay, awards_of, search

    th.set_num_threads(1)
    print(f"budget {budget} rollouts; CPU s of this process; per cent against the market")
    print("| model | actions | market (s) | portfolio (s) | policy alone | learned (s) | vs market | vs portfolio | "
          "CP-SAT best / bound (s) | learned vs bound | rollouts | CPU s | ablation (s) | vs market | rollouts | CPU s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for model in models:
        problem = problem_for(SHARED + model if "/" not in model and not model.startswith("generated:") else model)[0]
        rows = []
        for guided in (True, False)[: 1 + ablation]:
            start = time.process_time()
            path = path or DEFAULT_POLICY
            env = env_for(problem, copy_observation=False, observation=LearnedPlanner(path).observation)
            found = search(problem, LearnedPolicy(load_policy(path, env)) if guided else None, budget, env=env)
            cpu = time.process_time() - start
            awards, _ = awards_of(problem, found.actions)
            assert awards == found.awards, "the awards recorded by the search are its schedule's"
            replay = AwardsReplay(awards)
            run = simulate(problem.smart, problem.fleet, problem.site, "least-cost", 0, problem.breakdowns,
                           problem.storey_elevations, per_node=problem.per_node, dispatcher=replay)
            assert abs(run.makespan - found.makespan_s) < 1e-6 and replay.fallbacks == 0, (run.makespan, found.makespan_s)
            rows.append((found, cpu))
        (mine, cpu), (other, cpu_ab) = rows if ablation else (rows[0], (None, 0.0))
        market, best = mine.market_s, mine.portfolio_s
        cpsat, bound = CPSAT.get(model.rsplit("/", 1)[-1], (None, None))
        pct = lambda x, ref: f"{100.0 * (x - ref) / ref:+.1f} %"  # noqa: E731
        print(f"| {model} | {len(mine.actions)} | {market:,.1f} | {best:,.1f} ({mine.portfolio_chosen}) | "
              f"{mine.policy_s:,.1f} | {mine.makespan_s:,.1f} | {pct(mine.makespan_s, market)} | {pct(mine.makespan_s, best)} | "
              f"{'-' if cpsat is None else f'{cpsat:,.1f}'} / {'-' if bound is None else f'{bound:,.1f}'} | "
              f"{'-' if bound is None else pct(mine.makespan_s, bound)} | {mine.rollouts} | {cpu:.1f} | "
              + (f"{other.makespan_s:,.1f} | {pct(other.makespan_s, market)} | {other.rollouts} | {cpu_ab:.1f} |"
                 if other is not None else "not run | | | |"), flush=True)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--search"]:
        args = sys.argv[2:]
        budget = int(args[args.index("--budget") + 1]) if "--budget" in args else 400
        policy = args[args.index("--policy") + 1] if "--policy" in args else None
        names = [a for i, a in enumerate(args) if not a.startswith("--") and (i == 0 or args[i - 1] not in ("--budget", "--policy"))]
        searched(names or list(CPSAT), budget, "--no-ablation" not in args, policy)
    elif sys.argv[1:2] == ["--validation"]:
        validation(sys.argv[2:])
    elif sys.argv[1:2] == ["--slice"]:
        first, last = (int(v) for v in sys.argv[2].split(":"))
        sliced([a for a in sys.argv[3:] if not a.startswith("--")][0], first, last, "--sample" in sys.argv)
    elif sys.argv[1:2] == ["--scale"]:
        args = sys.argv[2:]
        policy = args[args.index("--policy") + 1] if "--policy" in args else None
        specs = [a for i, a in enumerate(args) if not a.startswith("--") and (i == 0 or args[i - 1] != "--policy")]
        scale(specs, policy, "--alone" in args, "--reference" in args)
    else:
        main(sys.argv[1] if len(sys.argv) > 1 else DEFAULT_POLICY)
