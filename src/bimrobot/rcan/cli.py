"""Sub-commands of the rcan part (registered by bimrobot.cli): ``rcan run``, ``rcan executor``,
``rcan capabilities``, and those the backends declare (``rcan robot-node``: the ros2 backend's)."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from dataclasses import asdict

from bimrobot.core.errors import InputError
from bimrobot.rcan.backends import BACKENDS

RUN_EXAMPLES = """examples:
  bimrobot rcan run --experiment 1 --backend sim          # thesis experiment 1, prints the interaction log
  bimrobot rcan run --experiment 2 --backend ros2         # the same against the shipped ROS 2 robot node
  bimrobot rcan run --schedule sim/schedule.csv --model frame.ifc --backend sim --state-db run.sqlite
      (kill it at any time; the same command resumes without losing or repeating an activity)
  bimrobot rcan run --experiment 3 --redis redis://127.0.0.1:6379/0 --failure-probability 0.3 --seed 7
"""


def register(subparsers) -> None:
    """Add this part's sub-commands to the bimrobot parser."""
    rcan = subparsers.add_parser("rcan", help="RCAN: drive robots from construction activities (thesis ch. 5)",
                                 description="Robot Construction Action Nodes: the middle layer between smart "
                                             "components and robots.", epilog=RUN_EXAMPLES,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = rcan.add_subparsers(dest="rcan_command", metavar="RCAN_COMMAND")
    rcan.set_defaults(func=lambda args: (rcan.print_help(), 1)[1])
    _add_run(commands)
    _add_executor(commands)
    _add_capabilities(commands)

    from bimrobot.rcan.backends import backend_commands

    for register_commands in backend_commands():  # e.g. ros2's robot-node
        register_commands(commands)


def _add_run(commands) -> None:
    """``rcan run``: an experiment, a schedule or a graph through RCAN. Long only because the command has
    many options (one ``add_argument`` each)."""
    from bimrobot.bim.selection import add_selection_options
    from bimrobot.bim.unknown_weight import add_unknown_weight_option

    run = commands.add_parser("run", help="run an experiment or a whole schedule through RCAN",
                              description="Run the thesis' experiments or a schedule CSV through RCAN and print "
                                          "the interaction log (component publishes, node instantiated, robot "
                                          "executes, result, new state).",
                              epilog=RUN_EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    what = run.add_mutually_exclusive_group(required=True)
    what.add_argument("--experiment", type=int, choices=(1, 2, 3),
                      help="1: column within reach; 2: column that needs transport; 3: footing")
    what.add_argument("--schedule", help="schedule CSV (docs/conventions.md), Microsoft Project XML (.xml), or an IFC "
                                         "file with an IfcWorkSchedule (its tasks' output elements are the components)")
    what.add_argument("--graph", help="construction graph of `bimrobot graph --schedule` (Turtle, JSON-LD, an Oxigraph "
                                      "folder or a SPARQL endpoint URL): the activities, robots, components, weights "
                                      "and positions are selected from it with SPARQL, and the live states go back to it")
    run.add_argument("--model", help="IFC model of the schedule (component weights and sections, GlobalId check)")
    add_selection_options(run, built=True)
    add_unknown_weight_option(run)
    _common(run)
    run.add_argument("--max-attempts", type=int, default=3, help="attempts before a failure is escalated (default 3)")
    run.add_argument("--retry-escalated", action="store_true",
                     help="with a --state-db of an earlier run: retry the activities it escalated (the cause is fixed)")
    run.add_argument("--no-local-executors", action="store_true",
                     help="do not start executors here; `bimrobot rcan executor` processes serve the robots (needs --redis)")
    run.add_argument("--yard", type=float, nargs=3, default=(-10.0, -10.0, 0.0), metavar=("X", "Y", "Z"),
                     help="first yard slot of a schedule's components, metres (default -10 -10 0)")
    run.add_argument("--standoff", type=float, default=0.6,
                     help="base stand-off from pick/install poses, m (default 0.6, within every built-in robot's reach)")
    _backend_run_options(run)
    run.add_argument("--report", help="also write the run report (JSON) to this new file (or one bimrobot wrote)")
    run.add_argument("--graph-out", help="with --graph, or --schedule and --model: write the construction graph (BOT + "
                                         "DiCon + live states; Turtle, or JSON-LD for .jsonld) as it stands after the "
                                         "run to this new file (or one bimrobot wrote)")
    run.add_argument("--reallocate", action="store_true",
                     help="give each activity to any capable robot (least loaded) instead of the robot the schedule assigned")
    run.add_argument("-q", "--quiet", action="store_true", help="no interaction log, only the summary")
    run.set_defaults(func=_run)


def _add_executor(commands) -> None:
    """``rcan executor``: serve robots' nodes from Redis in this process."""
    executor = commands.add_parser("executor", help="serve robots' RCAN nodes from Redis in this process",
                                   description="A robot executor in its own process: takes RCAN nodes for its "
                                               "robots from Redis, drives the backend, sends results back.",
                                   epilog="example:\n  bimrobot rcan executor --redis redis://127.0.0.1:6379/0 "
                                          "--backend sim --state-db site.sqlite",
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    _common(executor)
    executor.add_argument("--robot", action="append", help="robot to serve (repeatable; default: all)")
    executor.add_argument("--consumer", help="Redis consumer name (default executor-<host>-<pid>)")
    executor.add_argument("--workers", type=int, default=None,
                          help="worker threads: robots executed at the same time (default min(16, robots))")
    executor.set_defaults(func=_executor)


def _add_capabilities(commands) -> None:
    """``rcan capabilities``: Table 5.2 and the fleet's robots."""
    caps = commands.add_parser("capabilities", help="print Table 5.2 and the fleet's robots (what each performs)",
                               epilog="example:\n  bimrobot rcan capabilities --fleet my.yaml",
                               formatter_class=argparse.RawDescriptionHelpFormatter)
    _fleet_option(caps)
    caps.set_defaults(func=_capabilities)


def _common(parser: argparse.ArgumentParser) -> None:
    from bimrobot.rcan.backends import DEFAULT_BACKEND

    parser.add_argument("--backend", choices=tuple(BACKENDS), default=DEFAULT_BACKEND,
                        help=f"executor backend (default {DEFAULT_BACKEND})")
    _fleet_option(parser)
    _site_options(parser)
    parser.add_argument("--state-db", default=":memory:",
                        help="SQLite file for the journal and the simulated site, new or from an earlier run, "
                             "which is resumed (default in memory); another program's file is refused")
    parser.add_argument("--redis", help="Redis URL for the broker (default: in-process)")
    parser.add_argument("--redis-reconnect", type=float, default=120.0, metavar="S",
                        help="Redis: keep reconnecting (with back-off) for this long before giving up (default 120 s)")
    parser.add_argument("--claim-idle", type=float, default=60.0, metavar="S",
                        help="Redis: claim work another consumer left unacknowledged this long (a dead executor; "
                             "default 60 s, longer than any activity takes)")
    parser.add_argument("--max-deliveries", type=int, default=5, metavar="N",
                        help="Redis: a message delivered more often goes to the dead-letter stream and its "
                             "activity is escalated (default 5)")
    _backend_run_options(parser, run_only=False)


def _backend_run_options(parser: argparse.ArgumentParser, run_only: bool = True) -> None:
    """The options every registered backend declares (bimrobot.rcan.backends), those of ``rcan run`` alone
    (``run_only``) or the others."""
    from bimrobot.rcan.backends import backend_options

    for option in backend_options():
        if option.run_only == run_only:
            option.add_to(parser)


def _fleet_option(parser: argparse.ArgumentParser) -> None:
    """--fleet (alias --capabilities, the older name): the robots RCAN runs with."""
    parser.add_argument("--fleet", "--capabilities", dest="capabilities", metavar="FLEET",
                        help="a built-in fleet (`bimrobot fleet list`: fleet2, site-crane, rcan-robots, ...) or a fleet "
                             "YAML file, an older RCAN capability table too (default: the graph's fleet, else "
                             "the built-in rcan-robots)")


def _site_options(parser: argparse.ArgumentParser) -> None:
    """--site and --model-offset: where a fleet's robots start (its homes are site positions)."""
    parser.add_argument("--site", help="with a fleet whose homes are on the site: the site YAML whose robot_home the fleet's "
                                       "robots start at (default: the graph's site, or with --model the one `simulate` uses; else fig. 4.11), "
                                       "as `simulate --site`")
    parser.add_argument("--model-offset", type=float, nargs=2, metavar=("DX", "DY"),
                        help="with a fleet: model -> site translation in metres, to place the site's homes in the "
                             "model frame (default: the site's model_offset; `rcan run` otherwise centres its "
                             "plan's installs in the site's construction area, as `simulate`, and prints it: "
                             "give the same to executors and robot nodes in other processes)")


def _fleet_capabilities(args, activities=None):
    """The placed fleet of ``--fleet``; a fleet's homes go from the run's site into the model
    frame with ``--model-offset``, else the site's model_offset, else the offset that centres
    ``activities``' installs in the construction area (no plan: none). The run's site is the one the
    graph holds (``--graph``), or the one `simulate` uses for ``--model`` (:func:`bimrobot.site.site.site_for`),
    else ``--site`` (default fig. 4.11)."""
    from bimrobot.rcan.fleet import model_offset_of
    from bimrobot.rcan.generation import load_capabilities
    from bimrobot.site.site import OFFSET_LIMIT_M, load_site

    site = getattr(args, "run_site", None) or load_site(args.site)
    if args.model_offset is not None:
        if not all(math.isfinite(v) and abs(v) <= OFFSET_LIMIT_M for v in args.model_offset):
            raise InputError(f"--model-offset must be two finite numbers within +-{OFFSET_LIMIT_M:g} m, "
                             f"got {' '.join(map(str, args.model_offset))}")
        offset = tuple(args.model_offset)
    elif activities is not None:
        offset = model_offset_of(activities, site)
    else:
        offset = site.model_offset or (0.0, 0.0)
    graph_fleet = getattr(args, "graph_fleet", None)
    if args.capabilities is None and graph_fleet is not None:
        from bimrobot.rcan.fleet import load_rcan_fleet

        name = str(graph_fleet.get("name") or "fleet")
        source = f"the construction graph's fleet {name}"
        return load_rcan_fleet(name, graph_fleet, source, site, offset), offset
    return load_capabilities(args.capabilities, site=site, model_offset=offset), offset


def _check_backend_options(args) -> None:
    """Every backend option the command has is checked, whichever backend runs (one sentence naming it)."""
    from bimrobot.rcan.backends import backend_options

    for option in backend_options():
        if hasattr(args, option.dest):
            option.check(getattr(args, option.dest))


def _redis_options(args) -> dict:
    for option, value, low in (("--redis-reconnect", args.redis_reconnect, 0.0), ("--claim-idle", args.claim_idle, 0.01)):
        if not (math.isfinite(value) and low <= value <= 86400):
            raise InputError(f"{option} must be between {low:g} and 86400 seconds, got {value}")
    if not 1 <= args.max_deliveries <= 1000:
        raise InputError(f"--max-deliveries must be between 1 and 1000, got {args.max_deliveries}")
    return {"reconnect_s": args.redis_reconnect, "claim_idle_s": args.claim_idle, "max_deliveries": args.max_deliveries}


def _backend_options(args) -> dict:
    """The chosen backend's options from the command line, after every backend option was checked."""
    from bimrobot.rcan.backends import backend_class

    _check_backend_options(args)
    return backend_class(args.backend).options_from(args)


def _is_ifc(path: str | None) -> bool:
    return bool(path) and path.lower().endswith((".ifc", ".ifczip"))


def _inputs(args) -> list:
    """Every file ``rcan run`` reads: the schedule or graph, the model, the fleet file."""
    return [p for p in (getattr(args, "schedule", None), getattr(args, "graph", None), getattr(args, "model", None),
                        args.capabilities) if p]


def _check_outputs(args, inputs: list) -> None:
    """The output policy for --report, --graph-out and --state-db, before anything is read or run."""
    from bimrobot.core.io import check_output
    from bimrobot.rcan.state_db import is_state_db

    outputs = {}
    for option, path in (("--report", getattr(args, "report", None)), ("--graph-out", getattr(args, "graph_out", None))):
        if path is not None:
            check_output(path, folder=False, inputs=inputs, option=option)
            outputs[option] = path
    if args.state_db != ":memory:":
        check_output(args.state_db, folder=False, inputs=inputs, option="--state-db", recognise=is_state_db)
        outputs["--state-db"] = args.state_db
    seen: dict = {}
    for option, path in outputs.items():
        key = os.path.realpath(path)
        if key in seen:
            raise InputError(f"{seen[key]} and {option} name the same file {path}; give each its own file")
        seen[key] = option


def _load_plan(args):
    """(RCAN activities, construction graph or None, unknown-weight report or None) for the run."""
    from bimrobot.rcan.plans import experiment, plan_from_graph, plan_from_schedule

    if args.experiment:
        exp = experiment(args.experiment)
        print(f"== RCAN experiment {exp.number}: {exp.title}", flush=True)
        return list(exp.activities), None, None
    if args.graph:
        from bimrobot.lbd.graph import ConstructionGraph

        graph = ConstructionGraph.open(args.graph)
        if args.site is None:  # the site the graph's run used (homes, placement), when the graph holds it
            args.run_site = graph.run_site()
        if args.capabilities is None:  # the fleet the graph's run used, when the graph holds it
            args.graph_fleet = graph.fleet_data()
        return plan_from_graph(graph, tuple(args.yard), standoff_m=args.standoff), graph, None
    from bimrobot.schedule.csv import load_schedule

    model, weights = None, None
    from_ifc = _is_ifc(args.schedule)
    if args.model or from_ifc:
        from bimrobot.bim import load_model

        source = args.model or args.schedule  # an IFC work schedule usually sits in its model
        model = load_model(source, include=args.include, exclude=args.exclude, unknown_weight=args.unknown_weight)
        weights = model.unknown_weights  # the rule, applied once when the model was read
        if weights.message():
            print(weights.message(), flush=True)
        from bimrobot.site.site import site_for

        args.run_site = site_for(args.site, model.elements.values())  # as `simulate` and `convert` place it
    schedule = load_schedule(args.schedule, model)
    graph = None
    if args.graph_out:
        from bimrobot.lbd.graph import build_graph

        graph = build_graph(model, schedule)
    return plan_from_schedule(schedule, model, tuple(args.yard), standoff_m=args.standoff), graph, weights


def _check_robots(activities, capabilities, reallocate: bool) -> None:
    """A schedule that assigns robots the fleet does not have is refused (its fleet is another
    one), unless --reallocate gives every activity to capable robots of the fleet."""
    unknown = sorted({a.robot for a in activities if a.robot and a.robot not in capabilities.by_name})
    if not unknown:
        return
    shown = ", ".join(unknown[:5]) + (f" and {len(unknown) - 5} more" if len(unknown) > 5 else "")
    robots = list(capabilities.names)
    table = ", ".join(robots[:5]) + (f" and {len(robots) - 5} more" if len(robots) > 5 else "")
    if not reallocate:
        raise InputError(f"the schedule assigns robot(s) {shown}, which {capabilities.source} does not have ({table}): "
                         "give the schedule's fleet with --fleet (e.g. --fleet fleet2), or --reallocate")
    print(f"the schedule names robot(s) {shown}, which are not in {capabilities.source}: with --reallocate their "
          f"activities go to capable robots of the fleet ({table})", flush=True)


def _unknown_weight_notice(activities, model_given: bool) -> list[str]:
    from bimrobot.rcan.plans import unknown_weight_components

    unknown = unknown_weight_components(activities)
    if unknown:
        why = "the model gives no weight and no closed volume" if model_given else "no --model gives their weights"
        print(f"{len(unknown)} component(s) have an unknown weight ({why}): robots' payloads are not checked "
              f"for them, e.g. {unknown[0]}", flush=True)
    return unknown


def _run(args) -> int:
    from bimrobot.rcan.backends import backend_class
    from bimrobot.rcan.state_db import removed_unless_used
    from bimrobot.rcan.system import run_plan

    _check_run_args(args)
    options = _backend_options(args)
    redis_options = _redis_options(args)
    inputs = _inputs(args)
    _check_outputs(args, inputs)
    activities, graph, weights = _load_plan(args)
    capabilities, offset = _fleet_capabilities(args, activities)
    _check_robots(activities, capabilities, args.reallocate)
    unknown = _unknown_weight_notice(activities, args.model is not None or _is_ifc(args.schedule) or bool(args.graph)) \
        if args.schedule or args.graph else []
    observers = []
    if graph is not None:
        from bimrobot.rcan.observers import GraphStateObserver

        observers.append(GraphStateObserver(graph, activities))
    log = None if args.quiet else (lambda line: print(line, flush=True))
    with removed_unless_used(args.state_db), backend_class(args.backend).around_run(args, offset):
        report = run_plan(activities, capabilities, backend=args.backend, state_db=args.state_db,
                          redis_url=args.redis, spawn_executors=not args.no_local_executors,
                          max_attempts=args.max_attempts, log=log, backend_options=options,
                          observers=observers, retry_escalated=args.retry_escalated, redis_options=redis_options,
                          reallocate=args.reallocate)
    _print_summary(report, len(activities))
    _print_physics(report.backend_summary)
    _print_outcome(report)
    if args.report:
        _write_report(args, report, offset, weights, unknown, inputs)
    if graph is not None and args.graph_out:
        from bimrobot.lbd.store import SUFFIX_FORMATS

        fmt = SUFFIX_FORMATS.get(os.path.splitext(args.graph_out)[1].lower(), "turtle")
        graph.serialize(args.graph_out, format=fmt, inputs=inputs, option="--graph-out")
        print(f"construction graph with live states: {args.graph_out}", flush=True)
    return 0 if report.status == "completed" else 1


def _check_run_args(args) -> None:
    """The options of ``rcan run`` that need no file: combinations, attempts, yard (m) and stand-off (m)."""
    if args.no_local_executors and not args.redis:
        raise InputError("--no-local-executors needs --redis: executors in other processes talk through Redis")
    if args.max_attempts < 1:
        raise InputError(f"--max-attempts must be at least 1, got {args.max_attempts}")
    if args.graph_out and not (args.graph or (args.schedule and (args.model or _is_ifc(args.schedule)))):
        raise InputError("--graph-out needs --graph, or --schedule and --model: the graph links the model's elements "
                         "and the schedule")
    if args.model and not args.schedule:
        raise InputError("--model is read with --schedule; the experiments and the graph bring their own components")
    if not all(math.isfinite(v) and abs(v) <= 1e7 for v in args.yard):
        raise InputError(f"--yard must be three finite coordinates within +-1e7 m, got {' '.join(map(str, args.yard))}")
    if not (math.isfinite(args.standoff) and 0 <= args.standoff <= 100):
        raise InputError(f"--standoff must be between 0 and 100 m, got {args.standoff}")


def _print_summary(report, n_activities: int) -> None:
    """The run's line: status, activities done, components per state, makespan (robot s) and wall time (s)."""
    states = {}
    for state in report.component_states.values():
        states[state] = states.get(state, 0) + 1
    print(f"== {report.status}: {len(report.done)}/{n_activities} activities done"
          + (f" ({report.resumed} re-sent after a resume)" if report.resumed else "")
          + f"; components: {', '.join(f'{n} {s}' for s, n in sorted(states.items()))}; "
          f"makespan {report.makespan_s:.1f} s (robot time), wall {report.wall_s:.2f} s", flush=True)


def _write_report(args, report, offset, weights, unknown: list[str], inputs: list) -> None:
    """The --report file (JSON): the run report, the model -> site offset (m) and the unknown weights."""
    from bimrobot.core.io import atomic_output_file, signature

    data = {"generator": signature("rcan run report"), **asdict(report)}
    data["model_offset_xy_m"] = list(offset)  # model -> site: where a fleet's site homes were placed
    data["unknown_weight"] = {**(weights.as_dict() if weights else {"rule": str(args.unknown_weight)}),
                              "components_with_unknown_weight": unknown}
    with atomic_output_file(args.report, inputs=inputs, option="--report") as tmp:
        tmp.write_text(json.dumps(data, indent=2, default=str), encoding="utf-8")


def _print_physics(summary: dict) -> None:
    """A physical backend's measures (its summary's ``placement_error`` and ``chassis_overlap_s``), in one
    line: the worst placement error, and how long robots' chassis overlapped (robots collide and plan round
    each other: any overlap says something went wrong, or that the fleet has more robots than collision bits)."""
    placed, overlaps = summary.get("placement_error"), summary.get("chassis_overlap_s")
    if placed is None:
        return
    worst = (f"worst placement error {max(e['position_mm'] for e in placed.values()):.2f} mm, "
             f"{max(e['angle_deg'] for e in placed.values()):.3f} degrees" if placed else "nothing installed")
    if overlaps:
        pair, longest = max(overlaps.items(), key=lambda item: item[1])
        crossing = (f"robots' chassis overlapped {sum(overlaps.values()):.1f} s in all (pairs of robots; the longest "
                    f"{pair}, {longest:.1f} s): robots got into each other in the scene")
    else:
        crossing = "no two robots' chassis overlapped"
    print(f"physics: {worst}; {crossing}", flush=True)


def _listed(ids: list[str], limit: int = 10) -> str:
    """``ids`` comma-separated, the first ``limit`` of them (the --report file has all)."""
    more = f" and {len(ids) - limit} more" if len(ids) > limit else ""
    return ", ".join(ids[:limit]) + more


def _print_outcome(report) -> None:
    """Escalated activities, what each one blocks, what waits for a robot, and what was done: all of
    them whenever the run did not complete."""
    if report.status == "completed":
        return
    for escalation in report.escalations:
        print(escalation, flush=True)
    by_cause: dict[str, list[str]] = {}
    for activity_id, cause in report.blocked_by.items():
        by_cause.setdefault(cause, []).append(activity_id)
    for cause, ids in by_cause.items():
        print(f"blocked by escalated {cause}: {len(ids)} activit{'y' if len(ids) == 1 else 'ies'} ({_listed(ids)})",
              flush=True)
    waiting = [a for a in report.blocked if a not in report.blocked_by]
    if waiting:
        print(f"blocked: {len(waiting)} activit{'y' if len(waiting) == 1 else 'ies'} ({_listed(waiting)}) wait for "
              "a robot that never becomes free", flush=True)
    print(f"done: {len(report.done)} activit{'y' if len(report.done) == 1 else 'ies'}"
          + (f" ({_listed(report.done)})" if report.done else ""), flush=True)


def _executor(args) -> int:
    from bimrobot.rcan.backends import backend_class
    from bimrobot.rcan.backends.info import RunContext
    from bimrobot.rcan.broker import RedisBroker
    from bimrobot.rcan.executor import RobotExecutor

    if not args.redis:
        raise InputError("rcan executor needs --redis URL: it serves robots for a coordinator in another process")
    if args.state_db != ":memory:":
        from bimrobot.core.io import check_output
        from bimrobot.rcan.state_db import is_state_db

        check_output(args.state_db, folder=False, inputs=_inputs(args), option="--state-db", recognise=is_state_db)
    capabilities, _ = _fleet_capabilities(args)
    robots = args.robot or list(capabilities.names)
    unknown = [r for r in robots if r not in capabilities.by_name]
    if unknown:
        raise InputError(f"--robot {unknown[0]!r} is not a robot of {capabilities.source} "
                         f"(its robots: {', '.join(capabilities.names)})")
    options = _backend_options(args)
    # what a backend needs that this process has: the state database (no plan: the coordinator has it)
    backend = backend_class(args.backend).create(capabilities, RunContext(state_db=args.state_db), **options)
    import socket

    # one consumer name per process: what a killed executor left unacknowledged is claimed by the others
    consumer = args.consumer or f"executor-{socket.gethostname()}-{os.getpid()}"
    broker = RedisBroker(args.redis, group="executor", consumer=consumer, **_redis_options(args))
    executor = RobotExecutor(broker, backend, robots, workers=args.workers)
    print(f"rcan executor serving {', '.join(robots)} on {args.redis} with the {args.backend} backend", flush=True)
    try:
        executor.serve()
    finally:
        backend.close()
        broker.close()
    return 0


def _capabilities(args) -> int:
    from bimrobot.rcan.generation import load_capabilities

    from bimrobot.rcan.fleet import TABLE_5_2, activities_of

    fleet = load_capabilities(args.capabilities)
    print("Robot types and their construction activities (thesis Table 5.2):")
    for name, kinds in TABLE_5_2.items():
        print(f"  {name:14s} {', '.join(sorted(k.label for k in kinds))}")
    print(f"Robots ({fleet.source}):")
    for robot in fleet.robots:
        doing = activities_of(robot)
        types = "+".join(name for name, kinds in TABLE_5_2.items() if kinds <= doing) or "part of a type"
        print(f"  {robot.name:26s} types {types}; payload {robot.payload_kg:g} kg, "
              f"reach {robot.reach_m:g} m, speed {robot.speed_m_s:g} m/s")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(0)
