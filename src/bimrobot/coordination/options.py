"""The options of ``bimrobot simulate`` (and the building options ``allocators`` shares), defined once below
the command: the command registers them (:mod:`bimrobot.coordination.cli`), and
:func:`bimrobot.planning.dispatch.simulate_problem` parses them to read a problem exactly as ``simulate``
does. Times in seconds, lengths in metres."""

from __future__ import annotations

import argparse
import math

from bimrobot.core.config import MAX_SECONDS


def breakdown(text: str) -> tuple[str, float, float | None]:
    """ROBOT@SECONDS (for good) or ROBOT@SECONDS+REPAIR_SECONDS; times finite, >= 0 and > 0 s."""
    name, sep, when = text.rpartition("@")
    at, plus, repair = when.partition("+")
    try:
        seconds = float(at)
        repair_s = float(repair) if plus else None
    except ValueError:
        seconds = None
    if not sep or not name or seconds is None:
        raise argparse.ArgumentTypeError(
            f"expected ROBOT@SECONDS or ROBOT@SECONDS+REPAIR, e.g. AssemblyRobot32@600+900, got {text!r}"
        )
    if not (0 <= seconds <= MAX_SECONDS):
        raise argparse.ArgumentTypeError(f"the breakdown time must be >= 0 and <= {MAX_SECONDS:g} s, got {at!r} in {text!r}")
    if repair_s is not None and not (0 < repair_s <= MAX_SECONDS):
        raise argparse.ArgumentTypeError(f"the repair time must be > 0 and <= {MAX_SECONDS:g} s, got {repair!r} in {text!r}")
    return name, seconds, repair_s


def ranged(kind, low: float, high: float, unit: str, low_inclusive: bool = True):
    """An argparse ``type``: a finite ``kind`` (int or float) in [low, high] (or (low, high])."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            value = None
        ok = value is not None and math.isfinite(value) and (value >= low if low_inclusive else value > low) and value <= high
        if not ok:
            what = "a whole number" if kind is int else "a number"
            raise argparse.ArgumentTypeError(
                f"expected {what} {'>=' if low_inclusive else '>'} {low:g} and <= {high:g}{' ' + unit if unit else ''}, got {text!r}"
            )
        return value

    return parse


def add_building_options(parser: argparse.ArgumentParser) -> None:
    """The options that say which building, fleet and site (shared by ``simulate`` and ``allocators``)."""
    from bimrobot.bim.selection import add_prebuilt_option, add_selection_options
    from bimrobot.bim.unknown_weight import add_unknown_weight_option
    from bimrobot.sco.build import MAX_TOLERANCE_M

    parser.add_argument("model", help="IFC file (.ifc, .ifczip), or generated:NXxNYxFLOORS for a generated steel frame")
    parser.add_argument(
        "--fleet", default="fleet2",
        help="fleet1, fleet2 (thesis Table 4.1), site-crane (carries, positions and assembles anything up to "
        "20 t and 15 m) or a fleet YAML file (default fleet2)",
    )
    parser.add_argument("--site", help="site YAML: yard, robot_home, construction_area, model_offset (default: fig. 4.11 when the building fits its 7.5 x 6.5 m area, else a site derived from the building; 'thesis' forces fig. 4.11)")
    parser.add_argument(
        "-o", "--output", required=True,
        help="output folder: a new or empty folder, or one bimrobot wrote (replaced atomically)",
    )
    add_prebuilt_option(parser)  # a selector, like --include (bimrobot.bim.selection)
    parser.add_argument(
        "--tolerance", type=ranged(float, 0.0, MAX_TOLERANCE_M, "m", low_inclusive=False), default=0.01,
        help=f"metres, > 0 and <= {MAX_TOLERANCE_M:g}; bodies this close count as touching when connections "
        "are inferred (default 0.01)",
    )
    parser.add_argument(
        "--by-element", action="store_true",
        help="build element by element even when the model groups them into assemblies "
        "(by default an IfcElementAssembly is one component, lifted and placed as a unit)",
    )
    add_selection_options(parser, built=True)
    add_unknown_weight_option(parser)


def add_simulate_options(parser: argparse.ArgumentParser) -> None:
    """``simulate``'s own options (evaluator, planner, breakdowns, mode, per node or per joint, ...)."""
    from bimrobot.coordination.market import EVALUATORS

    parser.add_argument("--evaluator", default="least-cost", choices=EVALUATORS, help="how the winning bid is chosen (default least-cost; greedy-nearest and random are baselines)")
    parser.add_argument("--seed", type=ranged(int, 0, 2**32 - 1, ""), default=0, help="seed of the random allocator (default 0)")
    parser.add_argument(  # issue 38: bimrobot.planning.planners
        "--planner", metavar="NAME",
        help="who plans the build (default: the market with --evaluator): market, market:quickest-finish, "
        "rule:most-successors, rule:longest-path, rule:nearest, rule:shortest-handling, rule:completes-joints, portfolio "
        "(the shortest of those seven), rollout (the portfolio's best improved by rollouts), cp-sat (with --per-joint), learned (the shipped "
        "policy with a search of 400 rollouts), learned:greedy (the policy alone), or a policy file PATH.zip; plan.json "
        "says what planning cost",
    )
    parser.add_argument("--breakdown", type=breakdown, action="append", default=[], metavar="ROBOT@SECONDS[+REPAIR]", help="the robot breaks down at that time, for good or for REPAIR seconds (repeatable)")
    parser.add_argument("--no-gantt", action="store_true", help="skip the Gantt chart (faster on big buildings)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--mode", choices=("event", "thesis"), default="event",
        help="event (default): SimPy discrete-event simulation, how fast the fleet can build; thesis: the "
        "thesis' step-synchronous loop (Listing 4.1), per-node tasks, to compare with its Table 4.2",
    )
    work = parser.add_mutually_exclusive_group()
    work.add_argument(
        "--per-node", dest="per_joint", action="store_const", const=False,
        help="event mode (the default): position and assemble each connection node as its own task, released "
        "as in the thesis (a node once its joint's components have arrived; a footing's anchor bolts with the "
        "column's foot node); --mode thesis always works per node",
    )
    work.add_argument(
        "--per-joint", dest="per_joint", action="store_const", const=True,
        help="event mode: position each component as one task (all its nodes) and assemble each joint "
        "as one task (both sides of a connection), as `bimrobot allocators` and its CP-SAT optimum do",
    )
    parser.add_argument(
        "--step-time", choices=("awarded", "finished", "phase", "per-kind"), default=None,
        help="--mode thesis only: how one step's time is formed: the longest task awarded in the step "
        "(default, Listing 4.2's 'total work time'), finished in it, the longest phase, or the longest "
        "task awarded per kind summed over kinds; every rule's total is printed",
    )
    parser.set_defaults(per_joint=None)  # None: per node


def simulate_parser() -> argparse.ArgumentParser:
    """A parser of ``bimrobot simulate``'s arguments (without the command word), for reading a problem as
    ``simulate`` reads it."""
    parser = argparse.ArgumentParser(prog="bimrobot simulate")
    add_building_options(parser)
    add_simulate_options(parser)
    return parser
