"""Sub-commands of the lbd part (registered by bimrobot.cli): ``graph`` and ``query``."""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path

from bimrobot.core.errors import InputError

GRAPH_EXAMPLES = """examples:
  bimrobot graph frame.ifc -o frame.ttl
  bimrobot graph frame.ifc --schedule sim/schedule.csv -o frame.jsonld --format json-ld
  bimrobot graph frame.ifc --schedule sim/schedule.csv -o frame.ttl --ifc-out frame-4d.ifc   # + IfcWorkSchedule
  bimrobot graph frame.ifc --schedule sim/schedule.csv -o frame.ttl --schedule-out plan.xml --site site.yaml
                                                                  # MS Project (.p6.xml: Primavera P6)
  bimrobot graph prefab.ifc --schedule planning.xml -o prefab.ttl          # a Microsoft Project XML schedule
  bimrobot graph house.ifc --ifc-schedule -o house.ttl            # tasks from the IfcWorkSchedule
  bimrobot graph frame.ifc --schedule schedule.csv --store oxigraph --store-path frame.oxigraph
  bimrobot graph frame.ifc --schedule schedule.csv --store sparql --store-path http://127.0.0.1:7878 -o frame.ttl
"""

QUERY_EXAMPLES = """examples:
  bimrobot query frame.ttl ready_activities
  bimrobot query frame.ttl component_state --bind globalId='2O2Fr$t4X7Zf8NOew3FLOH'
  bimrobot query frame.oxigraph storey_components --bind storeyId='1Eiqmlp21PmegDDW$BfDnr' --format csv
  bimrobot query frame.ttl my_query.rq --format json
  bimrobot query http://127.0.0.1:7878 progress                 # a remote SPARQL endpoint
"""


def register(subparsers) -> None:
    """Add this part's sub-commands to the ``bimrobot`` parser."""
    _add_graph(subparsers)
    _add_query(subparsers)


def _add_graph(subparsers) -> None:
    """``bimrobot graph``: the model, the schedule, the output and its store, what the graph holds. Long only
    because the command has many options (one ``add_argument`` each)."""
    from bimrobot.bim.selection import add_prebuilt_option, add_selection_options
    from bimrobot.bim.unknown_weight import add_unknown_weight_option

    graph = subparsers.add_parser(
        "graph",
        help="build the construction knowledge graph (BOT + DiCon + schedule + states) of an IFC model",
        description="Build the RDF construction graph of an IFC model: BOT topology, element properties, "
        "precast assemblies with their parts, connections as bot:Interface, DiCon activities from a "
        "schedule, and the live states.",
        epilog=GRAPH_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    graph.add_argument("model", type=Path, help="IFC file (.ifc or .ifczip)")
    source = graph.add_mutually_exclusive_group()
    source.add_argument(
        "--schedule", type=Path,
        help="schedule: CSV (docs/conventions.md, e.g. from `bimrobot simulate`) or Microsoft Project XML (.xml)",
    )
    source.add_argument("--ifc-schedule", action="store_true", help="take the activities from the model's IfcWorkSchedule")
    graph.add_argument("-o", "--output", type=Path, required=True, help="graph file to write (.ttl, .jsonld, .nt)")
    graph.add_argument("--format", choices=["turtle", "json-ld", "ntriples"], help="default: from the output suffix")
    graph.add_argument("--store", choices=["memory", "oxigraph", "sparql"], default="memory", help="triple store (default: memory)")
    graph.add_argument(
        "--store-path",
        help="new folder for the persistent Oxigraph store (--store oxigraph), or URL of the SPARQL endpoint (--store sparql)",
    )
    graph.add_argument("--base", default=None, help="base IRI of the graph's resources")
    graph.add_argument("--no-properties", action="store_true", help="leave the elements' property-set values out")
    graph.add_argument(
        "--by-element", action="store_true",
        help="every element on its own: leave the model's IfcElementAssemblies out (by default each is an element "
        "with its parts as bot:hasSubElement, the unit that is lifted)",
    )
    add_prebuilt_option(graph)  # a selector, as for `bimrobot simulate` (bimrobot.bim.selection)
    _add_graph_run_options(graph)
    add_selection_options(graph, built=True)
    add_unknown_weight_option(graph)
    graph.set_defaults(func=graph_command)


def _add_graph_run_options(graph: argparse.ArgumentParser) -> None:
    """The options of ``graph`` about the run the schedule belongs to: the work schedule written out
    (--ifc-out, --schedule-out, --start), and the site, fleet and world package the graph holds."""
    graph.add_argument(
        "--ifc-out", type=Path, metavar="FILE.ifc",
        help="also write a copy of the model with the schedule as an IfcWorkSchedule (summary tasks per storey "
        "and assembly unit, IfcTask, IfcTaskTime in working time, IfcWorkCalendar, IfcRelSequence, outputs on "
        "the parts), for 4D viewers such as Bonsai",
    )
    graph.add_argument(
        "--schedule-out", type=Path, metavar="FILE.xml",
        help="also write the same work schedule for a scheduler, through ifc4d: FILE.xml Microsoft Project XML, "
        "FILE.p6.xml Primavera P6 XML",
    )
    graph.add_argument(
        "--site", type=Path,
        help="site YAML of the run: held by the graph (robot homes, the building's placement) and its work_calendar "
        "(working days and hours) the --ifc-out / --schedule-out times are laid onto (default: as `simulate` "
        "chooses; Monday-Friday 07:00-16:00)",
    )
    graph.add_argument(
        "--fleet", metavar="FLEET",
        help="the fleet that built the schedule (fleet1, fleet2, site-crane or a fleet YAML file; default: the "
        "fleet.yaml `simulate` wrote beside the schedule): the graph holds its robots and what they do, so "
        "`bimrobot rcan run --graph` needs no --fleet",
    )
    graph.add_argument(
        "--package", type=Path, metavar="DIR",
        help="world package of the same model written by `bimrobot convert --layout yard`: each component waiting "
        "on the yard gets its pick-up position there (brc:pickUpPosition), which `rcan run --graph` drives to",
    )
    graph.add_argument("--start", metavar="ISO", help="date-time of t = 0 s for --ifc-out / --schedule-out (default: "
                       "the schedule's own, else today 08:00; outside working hours, the next working period)")


def _add_query(subparsers) -> None:
    """``bimrobot query``: a SPARQL query on a construction graph."""
    from bimrobot.lbd.graph import query_names

    query = subparsers.add_parser(
        "query",
        help="run a SPARQL query on a construction graph",
        description="Run a SPARQL query on a graph file (.ttl/.jsonld) or an Oxigraph store directory. "
        f"Shipped queries: {', '.join(query_names())}.",
        epilog=QUERY_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    query.add_argument("graph", help="graph file (.ttl, .jsonld, .nt), Oxigraph store directory, or SPARQL endpoint URL")
    query.add_argument("query", help="a shipped query name, or a .rq file")
    query.add_argument("--bind", action="append", default=[], metavar="VAR=VALUE", help="bind a query variable (repeatable)")
    query.add_argument("--format", choices=["table", "csv", "json"], default="table", help="output format (default: table)")
    query.set_defaults(func=query_command)


def _check_outputs(args, inputs: list) -> None:
    """The output policy for -o and --store-path, applied before the model is read."""
    from bimrobot.core import io

    io.check_output(args.output, folder=False, inputs=inputs, option="-o")
    if args.store == "oxigraph":
        io.check_output(args.store_path, folder=True, inputs=inputs, option="--store-path")
        store, output = Path(args.store_path).resolve(), Path(args.output).resolve()
        if store == output or store in output.parents:
            raise InputError(f"-o {args.output} is inside the --store-path folder {args.store_path}; write the graph file elsewhere")


def graph_command(args, model=None, ifc=None) -> int:
    """``bimrobot graph``: the construction graph of ``args.model`` into ``args.output``. ``model``: the
    BuildingModel of that file already read with the same selection and unknown-weight rule, and ``ifc``
    its parse, which ``--ifc-out`` writes the schedule into (``bimrobot build`` reads the file once for
    every stage); None reads them here."""
    from bimrobot.lbd.graph import checked_base
    from bimrobot.lbd.terms import DEFAULT_BASE
    from bimrobot.lbd.store import format_for

    if args.store != "memory" and args.store_path is None:
        raise InputError(f"--store {args.store} needs --store-path ({'DIR' if args.store == 'oxigraph' else 'URL'})")
    if args.store == "memory" and args.store_path is not None:
        raise InputError("--store-path is only used with --store oxigraph (a folder) or --store sparql (a URL)")
    inputs = [args.model, args.schedule, *([args.package / "report.json"] if args.package else [])]
    _check_outputs(args, inputs)
    calendar = _check_work_schedule_outputs(args, inputs)
    format_for(args.output, args.format)  # fail on a bad suffix before the slow work
    base = checked_base(args.base or DEFAULT_BASE)
    started = time.perf_counter()
    model, schedule = _model_and_schedule(args, model)
    options = _graph_options(args, model, base)
    triples = _build_and_write(args, model, schedule, options, inputs)
    _print_graph_summary(args, model, schedule, options["smart"], triples, time.perf_counter() - started)
    if args.ifc_out is not None or args.schedule_out is not None:
        _write_work_schedule(args, schedule, calendar, inputs, ifc)
    return 0


def _model_and_schedule(args, model=None):
    """The model (read here when not given, with the command's selection and unknown-weight rule; the rule's
    note printed) and the schedule of --schedule or --ifc-schedule (None without either)."""
    from bimrobot.bim import load_model
    from bimrobot.schedule.csv import load_schedule
    from bimrobot.schedule.task_rows import load_schedule_ifc

    if model is None:
        from bimrobot.sco.build import prebuilt_selector

        model = load_model(args.model, include=args.include, exclude=args.exclude,
                           prebuilt=prebuilt_selector(args.prebuilt), unknown_weight=args.unknown_weight)
    weights = model.unknown_weights  # the rule, applied once when the model was read
    if weights.message():
        print(weights.message(), flush=True)
    schedule = None
    if args.schedule is not None:
        schedule = load_schedule(args.schedule, model=model)
    elif args.ifc_schedule:
        schedule = load_schedule_ifc(args.model, model=model)
    return model, schedule


def _graph_options(args, model, base: str) -> dict:
    """What :func:`bimrobot.lbd.graph.build_graph` is given besides the model and schedule: base IRI,
    properties, assemblies, the smart model's joints, the run's site, its fleet and the pick-up positions."""
    from bimrobot.site.fleet import load_fleet, schedule_fleet
    from bimrobot.site.site import site_for

    site = site_for(args.site, model.elements.values())  # the run's site, held by the graph
    smart = _smart_model(model, args, site.assembly_points_per_joint)
    options = {"base": base, "properties": not args.no_properties, "assemblies": not args.by_element, "smart": smart,
               "site": site}
    fleet = load_fleet(args.fleet) if args.fleet else schedule_fleet(args.schedule) if args.schedule else None
    if fleet is not None:
        options["fleet"] = fleet  # given, else the one `simulate` wrote beside the schedule
    if args.package is not None:
        from bimrobot.lbd.package import pick_up_positions

        options["pick_up"] = pick_up_positions(args.package, model, args.model)
    return options


def _build_and_write(args, model, schedule, options: dict, inputs: list) -> int:
    """Build the graph in the chosen store and write it to -o; the number of triples."""
    from bimrobot.core import io
    from bimrobot.lbd.graph import build_graph

    def build_and_write(store: str, path) -> int:
        graph = build_graph(model, schedule, store=store, path=path, **options)
        try:
            graph.serialize(args.output, args.format, inputs=inputs, option="-o")
            return len(graph)
        finally:
            graph.close()

    if args.store == "oxigraph":
        # Built in a temporary sibling folder that becomes --store-path only when everything worked.
        with io.atomic_output_dir(args.store_path, kind="graph (Oxigraph store)", inputs=inputs, option="--store-path") as tmp:
            return build_and_write("oxigraph", tmp)
    # The memory store is only a way to the file here: an in-memory Oxigraph store builds and writes
    # large graphs several times faster than rdflib (same triples), when the oxigraph extra is installed.
    fast = args.store == "memory" and _oxigraph_installed()
    return build_and_write("oxigraph-memory" if fast else args.store, args.store_path if args.store == "sparql" else None)


def _print_graph_summary(args, model, schedule, smart, triples: int, seconds: float) -> None:
    """What the graph holds (triples, elements, assemblies, storeys, connections, joints, activities), the
    tasks that name nothing of the model, and where the store is."""
    activities = len(schedule.activities) + len(schedule.phases) if schedule else 0
    assemblies = 0 if args.by_element else len(model.assemblies)
    joints = ""
    if smart is not None:
        inferred = sum(1 for j in smart.joints.values() if j.inferred)
        joints = f", {len(smart.joints)} joints ({inferred} inferred from geometry) with {len(smart.nodes)} nodes"
    print(
        f"{args.output}: {triples} triples, {len(model.elements)} elements"
        + (f" ({assemblies} assemblies)" if assemblies else "")
        + f", {len(model.storeys)} storeys, {len(model.connections)} connections{joints}, {activities} activities "
        f"({seconds:.1f} s)"
    )
    if schedule is not None and schedule.unmatched:
        first = schedule[schedule.unmatched[0]]
        print(f"{args.schedule}: {len(schedule.unmatched)} of {len(schedule.activities)} tasks name no element or storey of "
              f"the model (e.g. {first.id} {first.name!r}); they are in the graph as activities without a component")
    if args.store != "memory":
        print(f"{'Oxigraph store' if args.store == 'oxigraph' else 'SPARQL endpoint'}: {args.store_path}")


def _check_work_schedule_outputs(args, inputs: list):
    """The names of --ifc-out and --schedule-out and their output policy, checked before anything is
    written; the site's work calendar (None when neither is asked for)."""
    from bimrobot.core import io
    from bimrobot.schedule.ifc import check_ifc_out, schedule_export_kind
    from bimrobot.site.site import load_site

    wanted = [(option, path) for option, path in (("--ifc-out", args.ifc_out), ("--schedule-out", args.schedule_out))
              if path is not None]
    if not wanted:
        return load_site(args.site).work_calendar if args.site else None  # a bad site file is refused all the same
    if args.schedule is None and not args.ifc_schedule:
        raise InputError(f"{wanted[0][0]} writes the schedule out: give --schedule FILE (or --ifc-schedule)")
    if args.ifc_out is not None:
        check_ifc_out(args.ifc_out)
    if args.schedule_out is not None:
        schedule_export_kind(args.schedule_out)
    for option, path in wanted:
        io.check_output(path, folder=False, inputs=[*inputs, args.site], option=option)
    if args.ifc_out is not None and args.schedule_out is not None and args.ifc_out.resolve() == args.schedule_out.resolve():
        raise InputError(f"--ifc-out and --schedule-out are the same file {args.ifc_out}; give two names")
    return load_site(args.site).work_calendar


def _write_work_schedule(args, schedule, calendar, inputs: list, ifc=None) -> None:
    """The model with the schedule as an IfcWorkSchedule (--ifc-out) and its scheduler export (--schedule-out).
    ``ifc``: the model's file already parsed, which the schedule is written into (None: parsed here)."""
    from bimrobot.schedule.ifc import (
        SCHEDULE_EXPORTS, schedule_export_kind, scheduled_model, write_schedule_export, write_scheduled_ifc)

    inputs = [*inputs, args.site]
    ifc, figures = scheduled_model(args.model, schedule, epoch=args.start, calendar=calendar, parsed=ifc)
    if args.ifc_out is not None:
        write_scheduled_ifc(ifc, args.ifc_out, inputs=inputs)
        print(f"{args.ifc_out}: {args.model.name} with an IfcWorkSchedule of {figures.describe()}")
    if args.schedule_out is not None:
        write_schedule_export(ifc, args.schedule_out, calendar, inputs=inputs)
        kind = SCHEDULE_EXPORTS[".p6.xml" if schedule_export_kind(args.schedule_out) == "p6" else ".xml"]
        print(f"{args.schedule_out}: {kind} of the same {figures.tasks} tasks (ifc4d)")


def _oxigraph_installed() -> bool:
    import importlib.util

    return importlib.util.find_spec("pyoxigraph") is not None


def _smart_model(model, args, points_per_joint: int | None = None):
    """The joints and connection nodes the simulation would use (same options as `bimrobot simulate`), or
    None with a note when the model has nothing robots build."""
    from bimrobot.sco.build import build_smart_model, prebuilt_rule

    prebuilt = args.prebuilt  # a selector (evaluated when the model was read), or IFC class names
    prebuilt_rule(model, prebuilt)  # an unknown class name is refused with the model's classes
    try:
        points = {"assembly_points_per_joint": points_per_joint} if points_per_joint else {}
        return build_smart_model(model, prebuilt_classes=prebuilt, by_element=args.by_element, **points)
    except InputError as exc:
        print(f"bimrobot graph: no joints in the graph: {exc}", file=sys.stderr)
        return None


def _bindings(pairs: list[str]) -> dict[str, object]:
    bindings: dict[str, object] = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep or not name:
            raise InputError(f"--bind {pair!r} is not VAR=VALUE")
        bindings[name.lstrip("?$")] = value
    return bindings


def query_command(args) -> int:
    from bimrobot.lbd.graph import ConstructionGraph

    graph = ConstructionGraph.open(args.graph)
    try:
        rows = graph.query(args.query, **_bindings(args.bind))
    finally:
        graph.close()
    columns = list(rows[0]) if rows else []
    if args.format == "json":
        json.dump(rows, sys.stdout, indent=2, default=str)
        print()
    elif args.format == "csv":
        writer = csv.DictWriter(sys.stdout, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    else:
        _print_table(rows, columns)
    return 0


def _print_table(rows: list[dict], columns: list[str]) -> None:
    if not rows:
        print("(no results)")
        return
    cells = [["" if row[c] is None else str(row[c]) for c in columns] for row in rows]
    widths = [max(len(c), *(len(r[i]) for r in cells)) for i, c in enumerate(columns)]
    print("  ".join(c.ljust(w) for c, w in zip(columns, widths)).rstrip())
    for row in cells:
        print("  ".join(v.ljust(w) for v, w in zip(row, widths)).rstrip())
    print(f"({len(rows)} rows)")
