"""The one ``bimrobot`` command. Thin: parse, call the library, print.

Each part of the platform registers its own sub-commands from ``bimrobot.<part>.cli.register``, so
adding a part means adding one module to :data:`PART_CLIS`.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys

from bimrobot import __version__
from bimrobot.errors import BimrobotError

PART_CLIS = [
    "bimrobot.bim.cli",
    "bimrobot.world.cli",
    "bimrobot.coordination.cli",
    "bimrobot.lbd.cli",
    "bimrobot.rcan.cli",
    "bimrobot.assembly.cli",
    "bimrobot.rl.cli",
    "bimrobot.pipeline",
    "bimrobot.replay.cli",
]

EPILOG = """examples:
  bimrobot example steel-frame -o frame.ifc      # the thesis' chapter-4 frame, authored with IfcOpenShell
  bimrobot build frame.ifc -o out/               # the whole pipeline: package, simulation, graph, RCAN run
  bimrobot inspect frame.ifc                     # what the model holds
  bimrobot convert frame.ifc -o frame_pkg/       # a Gazebo package (world, models, launch, maps)
  bimrobot simulate frame.ifc --fleet fleet2 -o sim/
  bimrobot rcan run --experiment 1 --backend sim
  bimrobot assembly optimum --setting all
  bimrobot rl train --setting E3S2 --algo ppo --timesteps 1e6 -o runs/
"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="bimrobot",
        description="From an IFC building model to robot worlds, construction simulation, RCAN and DRL assembly planning.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"bimrobot {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module_name in PART_CLIS:
        module = importlib.import_module(module_name)
        module.register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=[logging.WARNING, logging.INFO, logging.DEBUG][min(args.verbose, 2)],
        format="%(levelname)s %(name)s: %(message)s",
    )
    if not getattr(args, "func", None):
        parser.print_help()
        return 1
    try:
        return int(args.func(args) or 0)
    except BimrobotError as exc:
        print(f"bimrobot {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        # The reader of our output went away (e.g. `| head`): stop quietly, as Unix tools do.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    sys.exit(main())
