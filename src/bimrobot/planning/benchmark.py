"""``bimrobot plan benchmark`` (issue 38): every planner on the same buildings, executed by the one event
simulation, against CP-SAT's lower bound.

For each model (an IFC file or a ``generated:KIND:...`` spec) the problem is read as ``simulate
--per-joint`` reads it (CP-SAT's tasks, so that the bound applies to every planner's run): IFC files with
``site-crane`` (and, when that fleet cannot build them, IfcFooting, IfcSlab and IfcWall prebuilt, as
``tests/test_real_models.py``), generated buildings with the fleet and site the generator draws for them.
CP-SAT runs once per model within ``time_limit_s``; its lower bound is every planner's reference:
gap = (makespan - bound) / bound. Planning time is wall time (CP-SAT's solve plus the dispatcher's
rounds); time per decision is the rounds' time divided by the awards made. Seconds throughout.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

from bimrobot.core.errors import BimrobotError, InputError

PREBUILT = "IfcFooting,IfcSlab,IfcWall"
#: the planners benchmarked by default (``learned`` where a policy is installed: the policy with its search of
#: 400 rollouts, each a whole simulation, so by far the dearest after CP-SAT)
DEFAULT_PLANNERS = ("market", "market:quickest-finish", "rule:most-successors", "rule:longest-path", "rule:nearest",
                    "rule:shortest-handling", "rule:completes-joints", "cp-sat", "learned")


def problem_for(model: str, fleet: str | None = None, per_joint: bool = True):
    """(DispatchProblem, fleet name, note) for an IFC path or a ``generated:KIND:...`` spec, per joint (the
    benchmark's, CP-SAT's tasks) or, ``per_joint`` False, per node (``simulate``'s default)."""
    from bimrobot.coordination.simulation import ConstructionSimulation
    from bimrobot.planning.dispatch import simulate_problem
    from bimrobot.site.generated import is_generated

    granularity = ["--per-joint"] if per_joint else []
    if is_generated(model) and fleet is None and model.count(":") >= 2:
        from bimrobot.site.fleet import fleet_yaml
        from bimrobot.site.generated import draw_fleet, draw_layout, draw_site, parse_spec
        from bimrobot.site.site import site_yaml

        spec = parse_spec(model)
        layout = draw_layout(spec)
        drawn = draw_fleet(spec, layout)
        with tempfile.TemporaryDirectory() as folder:
            fleet_file, site_file = Path(folder) / "fleet.yaml", Path(folder) / "site.yaml"
            fleet_file.write_text(fleet_yaml(drawn, spec.text()), encoding="utf-8")
            site_file.write_text(site_yaml(draw_site(spec, layout), spec.text()), encoding="utf-8")
            problem = simulate_problem([model, "--fleet", str(fleet_file), "--site", str(site_file), *granularity])
        return problem, f"{drawn.name} (drawn)", ""
    fleet = fleet or "site-crane"
    try:
        problem = simulate_problem([model, "--fleet", fleet, *granularity])
        ConstructionSimulation(problem.smart, problem.fleet, problem.site, storey_elevations=problem.storey_elevations)
        return problem, fleet, ""
    except InputError as exc:  # the simulation's pre-flight check: the fleet cannot build some component
        if "cannot build" not in str(exc):
            raise
    return simulate_problem([model, "--fleet", fleet, *granularity, "--prebuilt", PREBUILT]), fleet, f"prebuilt {PREBUILT}"


def bench_model(model: str, planners=DEFAULT_PLANNERS, fleet: str | None = None, time_limit_s: float = 60.0,
                cpsat_max_tasks: int = 20_000, log=print) -> dict:
    """One model's rows: each planner's makespan, gap to CP-SAT's bound, planning time, time per decision."""
    from bimrobot.planning.planners import plan

    started, started_cpu = time.perf_counter(), cpu_s()
    try:
        problem, fleet_name, note = problem_for(model, fleet)
        path, work = simple_bound(problem)  # also the simulation's pre-flight check of the fleet
    except BimrobotError as exc:  # a model no fleet can build, or with nothing to build: a line, not a stop
        log(f"{model}: not benchmarked: {exc}")
        return {"model": model, "fleet": fleet or "site-crane", "note": f"not benchmarked: {exc}", "components": 0,
                "read_s": None, "tasks": None, "lower_bound_s": None, "cpsat_status": None, "cpsat_method": None,
                "rows": []}
    read_s, read_cpu_s = time.perf_counter() - started, cpu_s() - started_cpu
    components = sum(1 for c in problem.smart.components.values() if not c.prebuilt)
    entry = {"model": model, "fleet": fleet_name, "note": note, "components": components, "read_s": round(read_s, 2),
             "read_cpu_s": round(read_cpu_s, 2), "tasks": _tasks(problem), "lower_bound_s": None, "cpsat_bound_s": None, "cpsat_status": None,
             "cpsat_method": None, "path_bound_s": round(path, 2), "work_bound_s": round(work, 2), "rows": []}
    order = [p for p in planners if p == "cp-sat"] + [p for p in planners if p != "cp-sat"]  # the bound first
    for name in order:
        row = {"planner": name}
        try:
            options = {"time_limit_s": time_limit_s, "deterministic_s": None, "workers": 1} if name == "cp-sat" else {}
            if name == "cp-sat" and _tasks(problem) > cpsat_max_tasks:
                raise InputError(f"{_tasks(problem):,} tasks, over the benchmark's {cpsat_max_tasks:,} for CP-SAT")
            t0 = time.perf_counter()
            result, stats = plan(name, problem, **options)
            row.update(makespan_s=round(result.makespan, 2), planning_s=round(stats.planning_s, 3),
                       planning_cpu_s=round(stats.planning_cpu_s, 3), decisions=stats.decisions,
                       ms_per_decision=_round(stats.ms_per_decision, 3),
                       cpu_ms_per_decision=_round(stats.cpu_ms_per_decision, 3),
                       run_s=round(time.perf_counter() - t0, 2))
            notes = stats.notes
            if "search_rollouts" in notes:  # the learned planner's and rollout's search
                row.update({k: notes[k] for k in ("search_budget", "search_rollouts", "policy_greedy_s", "portfolio_s")})
            if "cpsat_lower_bound_s" in notes:
                entry.update(tasks=notes["cpsat_tasks"], cpsat_bound_s=round(notes["cpsat_lower_bound_s"], 2),
                             cpsat_status=notes["cpsat_status"], cpsat_method=notes["cpsat_method"])
                row.update(cpsat_objective_s=round(notes["cpsat_makespan_s"], 2), reordered=notes["replay"].reordered,
                           unplanned=notes["replay"].unplanned)
        except BimrobotError as exc:
            row["skipped"] = str(exc)
        entry["rows"].append(row)
        log(f"{model}: {name}: {row.get('makespan_s', row.get('skipped'))}")
    done = [r["decisions"] for r in entry["rows"] if "decisions" in r]
    if entry["cpsat_bound_s"] is None and done:  # per joint, one award per task
        entry["tasks"] = done[0]
    bound = max(b for b in (entry["cpsat_bound_s"], entry["path_bound_s"], entry["work_bound_s"]) if b is not None)
    entry["lower_bound_s"] = round(bound, 2)
    entry["bound_from"] = ("CP-SAT" if entry["cpsat_bound_s"] == bound else
                           "critical path" if entry["path_bound_s"] == bound else "work / robots")
    for row in entry["rows"]:
        if bound and row.get("makespan_s") is not None:
            row["gap_pct"] = round(100.0 * (row["makespan_s"] - bound) / bound, 2)
    entry["rows"].sort(key=lambda r: list(planners).index(r["planner"]))
    return entry


def cpu_s() -> float:
    """CPU seconds of this process and of its finished children (the reader's worker processes)."""
    import resource

    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def simple_bound(problem) -> tuple[float, float]:
    """Two lower bounds (s) of any run of ``problem`` on the simulation, cheap at any size: the longest
    path of shortest handling times through the task graph (floor gates included, travel left out), and
    the total shortest handling time divided by the number of robots. One task graph for both (the
    numbers of the longest-path and shortest-handling rules, :mod:`bimrobot.planning.rules`)."""
    from bimrobot.coordination.simulation import ConstructionSimulation
    from bimrobot.planning.dispatch import task_graph
    from bimrobot.planning.rules import remaining_paths, shortest_handling

    sim = ConstructionSimulation(problem.smart, problem.fleet, problem.site, storey_elevations=problem.storey_elevations,
                                 per_node=problem.per_node)
    sim.start()
    graph = task_graph(sim)
    shortest = shortest_handling(sim, graph.requests)
    work = sum(shortest)
    return max(remaining_paths(graph, shortest), default=0.0), work / max(1, len(problem.fleet.robots))


def _tasks(problem) -> int:
    """About CP-SAT's task count (an upper bound: a transport and a positioning per robot-built component,
    an assembly per joint); replaced by the awards a run made, one per task, once a planner has run."""
    built = sum(1 for c in problem.smart.components.values() if not c.prebuilt)
    return 2 * built + len(problem.smart.joints)


def _round(value, digits):
    return None if value is None else round(value, digits)


def markdown(entries: list[dict], time_limit_s: float) -> str:
    """The table: one line per model and planner."""
    lines = [f"CP-SAT: one worker, {time_limit_s:g} s per model; gap = (makespan - lower bound) / bound; "
             "planning = CP-SAT's solve + the dispatcher's rounds, wall s (CPU s of this process); "
             "ms/decision = rounds' CPU time / awards. The bound is the largest of CP-SAT's, the critical path of "
             "shortest handling times, and total shortest handling / robots.", "",
             "| model | components | tasks | lower bound (s) | planner | makespan (s) | gap to bound | planning wall s (CPU s) | decisions | CPU ms/decision |",
             "|---|---:|---:|---:|---|---:|---:|---:|---:|---:|"]
    for e in entries:
        if e["lower_bound_s"] is None:
            bound = "-"
        elif e["bound_from"] == "CP-SAT":
            bound = f"{e['lower_bound_s']:,.1f} (CP-SAT, {e['cpsat_status']}, {e['cpsat_method']})"
        else:
            bound = f"{e['lower_bound_s']:,.1f} ({e['bound_from']})"
        name = Path(e["model"]).name if not e["model"].startswith("generated:") else e["model"]
        if not e["rows"]:
            lines.append(f"| {name} | | | | {e['note'][:160]} | | | | | |")
            continue
        if e["note"]:
            name += f" ({e['note']})"
        for i, r in enumerate(e["rows"]):
            head = (f"| {name}, {e['fleet']} | {e['components']:,} | {e['tasks'] or '-'} | {bound} " if i == 0 else "| | | | ")
            if "skipped" in r:
                lines.append(head + f"| {r['planner']} | not run: {r['skipped'][:90]} | | | | |")
                continue
            gap = "-" if r.get("gap_pct") is None else f"{r['gap_pct']:.1f} %"
            ms = "-" if r["cpu_ms_per_decision"] is None else f"{r['cpu_ms_per_decision']:.2f}"
            lines.append(head + f"| {r['planner']} | {r['makespan_s']:,.1f} | {gap} | {r['planning_s']:.2f} ({r['planning_cpu_s']:.2f}) | "
                         f"{r['decisions']:,} | {ms} |")
    return "\n".join(lines) + "\n"


def write(entries: list[dict], time_limit_s: float, folder: Path) -> None:
    """``benchmark.md`` and ``benchmark.json`` into ``folder``."""
    from bimrobot.core.io import signature

    (folder / "benchmark.md").write_text(markdown(entries, time_limit_s), encoding="utf-8")
    record = {"bimrobot": signature("plan benchmark"), "time_limit_s": time_limit_s, "models": entries}
    (folder / "benchmark.json").write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
