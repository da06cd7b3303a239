"""Sub-commands of the bim part (registered by bimrobot.cli): example, inspect, split."""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path


EXAMPLE_NAMES = ("steel-frame", "greenhouse", "rcan-experiment-1", "rcan-experiment-2", "rcan-experiment-3")


def register(subparsers) -> None:
    """Add this part's sub-commands to the bimrobot parser."""
    _add_example(subparsers)
    _add_inspect(subparsers)
    _add_split(subparsers)


def _add_example(subparsers) -> None:
    """``bimrobot example``: write a built-in building."""
    raw = argparse.RawDescriptionHelpFormatter
    example = subparsers.add_parser(
        "example",
        help="write a built-in example building (IFC4, metres)",
        description="Write one of the thesis' example buildings, authored with IfcOpenShell: "
        "steel-frame (chapter 4: 4 footings, 4 W250x73 columns, 4 W310x38.7 beams, base plates, clip "
        "angles, bolted joints), greenhouse (chapter 3: 9 foundations, 9 columns, 10 beams), or the component "
        "of one of chapter 5's RCAN experiments (rcan-experiment-1/2: a 2 kg scale column; 3: a 3.6 kg footing).",
        epilog="examples:\n  bimrobot example steel-frame -o frame.ifc\n  bimrobot example greenhouse -o greenhouse.ifc\n"
        "  bimrobot example steel-frame --bolts-per-node 6 -o frame6.ifc   # Table 4.2's frame: 20 nodes, 120 bolts\n",
        formatter_class=raw,
    )
    example.add_argument("name", choices=EXAMPLE_NAMES, help="which building")
    example.add_argument("-o", "--output", type=Path, help="IFC file to write (default: <name>.ifc)")
    example.add_argument(
        "--bolts-per-node", type=int, metavar="N",
        help="steel-frame only: N bolts (1 to 12) at every column and beam node and none at the footings "
        "(the thesis' Table 4.2 frame has 6)",
    )
    example.set_defaults(func=_example)


def _add_inspect(subparsers) -> None:
    """``bimrobot inspect``: summarise a model."""
    raw = argparse.RawDescriptionHelpFormatter
    inspect = subparsers.add_parser(
        "inspect",
        help="summarise what an IFC model holds",
        description="Read an IFC file as the platform does and print counts by class, storeys, "
        "connections, units, weights found and missing, and the products that have no solid body.",
        epilog="examples:\n  bimrobot inspect frame.ifc\n  bimrobot inspect model.ifc --json > summary.json\n"
        "  bimrobot inspect model.ifc --elements --include 'IfcColumn, IfcBeam'\n"
        "  bimrobot inspect model.ifc --infer-connections 0.005\n",
        formatter_class=raw,
    )
    inspect.add_argument("model", type=Path, help="IFC file (IFC2X3, IFC4, IFC4X3_ADD2)")
    _add_filters(inspect)
    inspect.add_argument("--json", action="store_true", help="print the summary as JSON")
    inspect.add_argument("--elements", action="store_true", help="also list every element")
    inspect.add_argument(
        "--infer-connections", type=float, metavar="TOLERANCE_M", nargs="?", const=0.005, default=None,
        help="also count connections inferred from touching geometry (tolerance in metres, default 0.005)",
    )
    inspect.set_defaults(func=_inspect)


def _add_split(subparsers) -> None:
    """``bimrobot split``: one IFC file per assembly or element."""
    raw = argparse.RawDescriptionHelpFormatter
    split = subparsers.add_parser(
        "split",
        help="write one IFC file per assembly or building element",
        description="Split an IFC model into valid IFC files (same schema): by default one per outermost "
        "IfcElementAssembly with all its parts when the model has assemblies (in precast and steel exports "
        "the assembly is what is lifted and placed), and one per element that belongs to no assembly; "
        "--by-element gives one file per element. Each file keeps the GlobalIds, spatial context, placement "
        "chain, representation, property and quantity sets, material and the connection relations. Writes "
        "<GlobalId>.ifc files ('$' written as '-') and index.json into the output folder, atomically; an "
        "output folder that bimrobot wrote is replaced, any other non-empty folder is refused.",
        epilog="examples:\n  bimrobot split frame.ifc -o frame_parts/\n"
        "  bimrobot split precast.ifc -o units/                 # one file per precast unit (assembly)\n"
        "  bimrobot split precast.ifc -o parts/ --by-element\n"
        "  bimrobot split model.ifczip -o beams/ --include IfcBeam\n",
        formatter_class=raw,
    )
    split.add_argument("model", type=Path, help="IFC file to split (.ifc or .ifczip)")
    split.add_argument("-o", "--output", type=Path, required=True, help="output folder (a new one, or one bimrobot wrote)")
    split.add_argument(
        "--by-element", action="store_true",
        help="one file per element, even when the model has assemblies (default: one file per outermost assembly)",
    )
    _add_filters(split)
    split.set_defaults(func=_split)


def _add_filters(parser: argparse.ArgumentParser) -> None:
    from bimrobot.bim.selection import add_selection_options

    add_selection_options(parser, built=False)
    parser.add_argument("--no-progress", action="store_true", help="no progress bar (shown on a terminal otherwise)")


def _progress(args) -> bool:
    return not args.no_progress and sys.stderr.isatty()


def _example(args) -> int:
    from bimrobot.core import io
    from bimrobot.bim.examples import EXAMPLES
    from bimrobot.core.io import printable

    from bimrobot.bim.examples import MAX_BOLTS_PER_NODE
    from bimrobot.core.errors import InputError

    output = args.output or Path(f"{args.name}.ifc")
    bolts = getattr(args, "bolts_per_node", None)
    if bolts is not None and args.name != "steel-frame":
        raise InputError(f"--bolts-per-node applies to the steel-frame example only, not to {args.name}")
    if bolts is not None and not 1 <= bolts <= MAX_BOLTS_PER_NODE:
        raise InputError(f"--bolts-per-node must be from 1 to {MAX_BOLTS_PER_NODE}, got {bolts}")
    io.check_output(output, folder=False)
    if bolts is None:
        EXAMPLES[args.name](output)
    else:
        EXAMPLES[args.name](output, bolts_per_node=bolts)
    print(f"wrote {printable(str(output))} ({args.name}, IFC4, metres); see what it holds with: bimrobot inspect {printable(str(output))}")
    return 0


def _inspect(args) -> int:
    from bimrobot.bim import load_model

    model = load_model(args.model, include=args.include, exclude=args.exclude, progress=_progress(args))
    summary = summarize(model)
    if args.infer_connections is not None:
        from bimrobot.bim.connections import infer_connections

        inferred = infer_connections(model, tolerance=args.infer_connections)
        summary["inferred_connections"] = {"tolerance_m": args.infer_connections, "count": len(inferred)}
    if args.elements:
        suspect = {row["GlobalId"]: row["reason"] for row in summary["suspect_weights"]}
        summary["element_list"] = [
            {
                "GlobalId": e.global_id,
                "class": e.ifc_class,
                "name": e.name,
                "storey": e.storey_id,
                "material": e.material,
                "weight_kg": e.weight_kg,
                "weight_source": e.weight_source.value,
                "weight_basis": e.weight_basis,
                "density_kg_m3": e.density_kg_m3,
                "volume_m3": round(e.volume_m3, 9),
                "suspect": suspect.get(e.global_id),
                "position_m": [round(float(v), 4) for v in e.position],
            }
            for e in model.elements.values()
        ]
    if args.json:
        print(json.dumps(summary, indent=2, ensure_ascii=False))
    else:
        print(format_summary(summary))
    return 0


def _split(args) -> int:
    from bimrobot.core import io
    from bimrobot.bim.split import split_model
    from bimrobot.core.io import printable

    io.check_output(args.output, folder=True, inputs=[args.model])  # before reading a large model
    written = split_model(
        args.model, args.output, include=args.include, exclude=args.exclude, progress=_progress(args),
        by_element=True if args.by_element else None,
    )
    assemblies = [f for f in written if f.parts]
    singles = Counter(f.ifc_class for f in written if not f.parts)
    what = []
    if assemblies:
        parts = Counter(p.ifc_class for f in assemblies for p in f.parts)
        what.append(
            f"{len(assemblies)} assemblies with {sum(parts.values())} parts ("
            + ", ".join(f"{n} {c}" for c, n in sorted(parts.items())) + ")"
        )
    if singles:
        what.append(("single elements: " if assemblies else "") + ", ".join(f"{n} {c}" for c, n in sorted(singles.items())))
    print(f"wrote {len(written)} IFC files and index.json to {printable(str(args.output))}/: " + "; ".join(what))
    return 0


def summarize(model) -> dict:
    """A JSON-ready summary of a BuildingModel: classes, storeys, connections, units, weights, skipped.

    Weights: every element with a weight is in the class and total masses (kg), and ``by_source`` /
    ``by_source_kg`` say where they came from; "found" counts them. A weight that
    :func:`~bimrobot.bim.quantities.weight_check` finds implausible is also "suspect": counted per class
    in ``suspect_by_class`` (count, kg, implied densities) and listed one by one, with the reason, under
    ``suspect_weights``. "missing" counts elements whose weight is unknown.
    """
    suspect_weights = _suspect_weights(model)
    per_storey = Counter(e.storey_id for e in model.elements.values())
    return {
        "file": str(model.source),
        "schema": model.schema,
        "project": model.project_name,
        "site": model.site_name,
        "units": model.units,
        "elements": len(model.elements),
        "classes": _by_class(model),
        "storeys": [
            {"GlobalId": s.global_id, "name": s.name, "elevation_m": s.elevation, "elements": per_storey.get(s.global_id, 0)}
            for s in model.storeys
        ],
        "elements_without_storey": per_storey.get(None, 0),
        "connections": {
            "count": len(model.connections),
            "types": dict(Counter(c.connection_type or "(none)" for c in model.connections)),
        },
        "weights": _weights(model, suspect_weights),
        "suspect_by_class": _suspect_by_class(suspect_weights),
        "goals_from_body": _goals_from_body(model),
        "suspect_weights": suspect_weights,
        "skipped": [{"GlobalId": s.global_id, "class": s.ifc_class, "name": s.name, "reason": s.reason} for s in model.skipped],
    }


def _suspect_weights(model) -> list[dict]:
    """One row per element whose weight :func:`~bimrobot.bim.quantities.weight_check` finds implausible."""
    from bimrobot.bim.quantities import weight_check

    suspect_weights = []
    for element in model.elements.values():
        reason = weight_check(element.weight_kg, element.weight_source, element.volume_m3, element.density_kg_m3)
        if reason is not None:
            suspect_weights.append(
                {
                    "GlobalId": element.global_id,
                    "class": element.ifc_class,
                    "name": element.name,
                    "material": element.material,
                    "weight_kg": element.weight_kg,
                    "weight_source": element.weight_source.value,
                    "volume_m3": round(element.volume_m3, 9),
                    "reason": reason,
                }
            )
    return suspect_weights


def _by_class(model) -> dict[str, dict]:
    """Per IFC class, sorted: element count, total weight (kg) and elements without a weight."""
    by_class: dict[str, dict] = {}
    for element in model.elements.values():
        row = by_class.setdefault(element.ifc_class, {"count": 0, "weight_kg": 0.0, "weights_missing": 0})
        row["count"] += 1
        if element.weight_kg is None:
            row["weights_missing"] += 1
        else:
            row["weight_kg"] += element.weight_kg
    for row in by_class.values():
        row["weight_kg"] = round(row["weight_kg"], 3)
    return dict(sorted(by_class.items()))


def _weights(model, suspect_weights: list[dict]) -> dict:
    """How many weights were found, missing and suspect, by source (count and kg), and the totals (kg)."""
    sources = Counter(e.weight_source.value for e in model.elements.values())
    found = [e for e in model.elements.values() if e.weight_kg is not None]
    source_kg: dict[str, float] = {}
    for element in found:
        source_kg[element.weight_source.value] = source_kg.get(element.weight_source.value, 0.0) + element.weight_kg
    return {
        "found": len(found),
        "missing": sources.get("unknown", 0),
        "suspect": len(suspect_weights),
        "by_source": dict(sources),
        "by_source_kg": {source: round(kg, 3) for source, kg in source_kg.items()},
        "total_kg": round(sum(e.weight_kg for e in found), 3),
        "suspect_kg": round(sum(row["weight_kg"] for row in suspect_weights), 3),
    }


def _suspect_by_class(suspect_weights: list[dict]) -> dict[str, dict]:
    """The suspect weights per class, most first: count, kg, the range of implied densities (kg/m3), an example."""
    suspect_by_class: dict[str, dict] = {}
    for row in suspect_weights:
        entry = suspect_by_class.setdefault(row["class"], {"count": 0, "weight_kg": 0.0, "implied_kg_m3": [], "example": row["GlobalId"]})
        entry["count"] += 1
        entry["weight_kg"] += row["weight_kg"]
        entry["implied_kg_m3"].append(row["weight_kg"] / row["volume_m3"] if row["volume_m3"] else float("nan"))
    for entry in suspect_by_class.values():
        implied = [v for v in entry.pop("implied_kg_m3") if v == v]
        entry["weight_kg"] = round(entry["weight_kg"], 3)
        entry["implied_kg_m3"] = [round(min(implied), 1), round(max(implied), 1)] if implied else None
    return dict(sorted(suspect_by_class.items(), key=lambda item: (-item[1]["count"], item[0])))


def _goals_from_body(model) -> dict:
    """The elements whose position was taken from their body, not their placement (count, by class, each)."""
    relocated = getattr(model, "relocated", ())
    return {
        "count": len(relocated),
        "by_class": dict(Counter(r.ifc_class for r in relocated).most_common()),
        "elements": [
            {"GlobalId": r.global_id, "class": r.ifc_class, "name": r.name, "moved_m": r.distance_m,
             "file_origin_m": list(r.file_origin), "origin_m": list(r.origin)}
            for r in relocated
        ],
    }


def format_summary(summary: dict) -> str:
    """The human-readable table that ``bimrobot inspect`` prints (names made printable)."""
    from bimrobot.core.io import printable

    units = summary["units"]
    lines = [
        printable(f"{summary['file']}: {summary['schema']}, project {summary['project']!r}, site {summary['site']!r}"),
        f"units: length {units['length']} (x{units['length_scale_to_m']:g} -> m), mass {units['mass']}",
        "",
        f"{'class':<28}{'count':>7}{'weight kg':>13}{'no weight':>11}",
    ]
    for ifc_class, row in summary["classes"].items():
        lines.append(f"{ifc_class:<28}{row['count']:>7}{row['weight_kg']:>13.2f}{row['weights_missing']:>11}")
    weights = summary["weights"]
    lines.append(f"{'total':<28}{summary['elements']:>7}{weights['total_kg']:>13.2f}{weights['missing']:>11}")
    lines += ["", "storeys:"]
    for storey in summary["storeys"]:
        lines.append(f"  {printable(storey['name']):<24} {storey['elevation_m']:>9.3f} m {storey['elements']:>6} elements")
    if summary["elements_without_storey"]:
        lines.append(f"  {'(none)':<24} {'':>11} {summary['elements_without_storey']:>6} elements")
    connections = summary["connections"]
    types = ", ".join(f"{printable(t)} {n}" for t, n in connections["types"].items()) or "-"
    lines += ["", f"connections (IfcRelConnectsWithRealizingElements): {connections['count']}  [{types}]"]
    if "inferred_connections" in summary:
        inferred = summary["inferred_connections"]
        lines.append(f"connections inferred from touching geometry (<= {inferred['tolerance_m']} m): {inferred['count']}")
    kg = weights.get("by_source_kg", {})
    by_source = ", ".join(
        f"{source} {n}" + (f" ({kg[source]:,.1f} kg)" if source in kg else "") for source, n in weights["by_source"].items()
    )
    lines.append(
        f"weights: {weights['found']} found, {weights['missing']} missing, {weights['suspect']} suspect  [{by_source}]"
    )
    if summary["suspect_weights"]:
        lines += ["", f"suspect weights ({len(summary['suspect_weights'])}, in the totals above; each one in --json):"]
        for ifc_class, entry in summary.get("suspect_by_class", {}).items():
            implied = entry["implied_kg_m3"]
            density = f", implied {implied[0]:,.1f}-{implied[1]:,.1f} kg/m3" if implied else ""
            lines.append(printable(f"  {ifc_class}: {entry['count']} ({entry['weight_kg']:,.1f} kg{density}), e.g. {entry['example']}"))
    goals = summary.get("goals_from_body") or {}
    if goals.get("count"):
        classes = ", ".join(f"{n} {c}" for c, n in goals["by_class"].items())
        lines += ["", f"placed away from their bodies: {goals['count']} elements ({classes}); their positions are "
                  "taken from their bodies (each one in --json: goals_from_body)"]
    if summary["skipped"]:
        lines += ["", f"skipped ({len(summary['skipped'])} products without a solid body):"]
        for reason, n in Counter((s["class"], s["reason"]) for s in summary["skipped"]).items():
            lines.append(f"  {n} x {reason[0]}: {reason[1]}")
    if "element_list" in summary:
        lines += ["", f"{'GlobalId':<24}{'class':<24}{'weight kg':>11}  {'source':<26}name: how"]
        for e in summary["element_list"]:
            weight = f"{e['weight_kg']:.2f}" if e["weight_kg"] is not None else "-"
            source = "suspect" if e.get("suspect") else e["weight_source"]
            line = f"{e['GlobalId']:<24}{e['class']:<24}{weight:>11}  {source:<26}{e['name']}: {e['weight_basis']}"
            lines.append(printable(line))
    return "\n".join(lines)
