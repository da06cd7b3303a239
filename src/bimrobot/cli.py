"""The one ``bimrobot`` command. Thin: parse, call the library, print.

Each part of the platform registers its own sub-commands from ``bimrobot.<part>.cli.register``;
:data:`COMMANDS` says which part owns each command and its one-line help, so that ``bimrobot --help``
lists every command without importing any part, and a command imports only its own part (adding a
command means one line there; ``tests/core/test_cli_imports.py`` checks the table against the parts).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from bimrobot import __version__
from bimrobot.core.errors import BimrobotError
from bimrobot.core.signals import Stopped, stop_behind, stop_signals_unwind, stopped_status

COMMANDS = {
    "example": ("bimrobot.bim.cli", "write a built-in example building (IFC4, metres)"),
    "inspect": ("bimrobot.bim.cli", "summarise what an IFC model holds"),
    "split": ("bimrobot.bim.cli", "write one IFC file per assembly or building element"),
    "convert": ("bimrobot.export.cli", "convert an IFC model into a Gazebo package (worlds, models, launch files, maps)"),
    "simulate": ("bimrobot.coordination.cli",
                 "market-based multi-robot construction simulation of a building (thesis ch. 4)"),
    "allocators": ("bimrobot.coordination.cli", "compare the market with greedy, random and optimal (CP-SAT) allocation"),
    "fleet": ("bimrobot.site.fleet_cli", "list the built-in fleets; convert an older fleet file"),
    "graph": ("bimrobot.lbd.cli",
              "build the construction knowledge graph (BOT + DiCon + schedule + states) of an IFC model"),
    "query": ("bimrobot.lbd.cli", "run a SPARQL query on a construction graph"),
    "rcan": ("bimrobot.rcan.cli", "RCAN: drive robots from construction activities (thesis ch. 5)"),
    "assembly": ("bimrobot.assembly.cli",
                 "DRL assembly-planning benchmark: optimal returns, animated episodes, scenario validation"),
    "rl": ("bimrobot.rl.cli", "DRL assembly planning: train, evaluate, benchmark (thesis ch. 6)"),
    "build": ("bimrobot.pipeline",
              "the whole pipeline in one command: package, simulation, graph and RCAN run of an IFC model"),
    "replay": ("bimrobot.replay.cli",
               "4D replay of a simulated build in Rerun: the structure growing, robots, Gantt, states"),
    "report": ("bimrobot.report.cli", "the build report (report.html) of a `bimrobot build` output folder"),
    "plan": ("bimrobot.planning.cli", "assembly planning: the planning problem as data"),
}
"""Every sub-command: the module whose ``register(subparsers)`` adds it, and its line in ``--help``."""

PART_CLIS = list(dict.fromkeys(module for module, _ in COMMANDS.values()))
"""The modules that register sub-commands, in the order of ``--help``."""

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


def build_parser(parts: list[str] | None = None) -> argparse.ArgumentParser:
    """The ``bimrobot`` parser with the sub-commands of ``parts`` (modules of :data:`PART_CLIS`;
    default: all of them). Every other command stands as its one-line entry of :data:`COMMANDS`: enough
    for ``--help`` and for refusing an unknown command, without importing its part."""
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
        if parts is None or module_name in parts:
            importlib.import_module(module_name).register(subparsers)
        else:
            for name, (owner, help_line) in COMMANDS.items():
                if owner == module_name:
                    subparsers.add_parser(name, help=help_line, add_help=False)
    return parser


def command_word(argv: list[str]) -> str | None:
    """The sub-command named in ``argv`` (the first word that is not an option; bimrobot's own options
    take no value), or None."""
    for word in argv:
        if word == "--":
            return None
        if not word.startswith("-"):
            return word
    return None


def parser_for(argv: list[str]) -> argparse.ArgumentParser:
    """The parser for ``argv``, with only the part of its command imported (none for ``--help``)."""
    command = command_word(argv)
    return build_parser([COMMANDS[command][0]] if command in COMMANDS else [])


def _generated_models(args) -> None:
    """Issue 38: an argument ``generated:KIND:...`` (a generated building, :mod:`bimrobot.site.generated`)
    names its IFC file, written once into the cache, so that every command reads it like a user's model.
    The in-memory frame ``generated:NXxNYxFLOORS`` is left to the commands that know it."""
    from pathlib import Path

    def resolved(value):
        if isinstance(value, list):
            return [resolved(v) for v in value]
        text = str(value) if isinstance(value, (str, Path)) else ""
        if text.startswith("generated:"):
            from bimrobot.site.generated import is_generated, model_path

            return type(value)(model_path(text)) if is_generated(text) else value
        return value

    for name, value in vars(args).items():
        setattr(args, name, resolved(value))


def main(argv: list[str] | None = None) -> int:
    """Run one command; the exit status: 0 done, 1 no command, 2 bad input (one sentence, no traceback),
    130 / 143 / 129 stopped by SIGINT (Ctrl-C) / SIGTERM / SIGHUP, 141 output pipe closed.

    From its first line, SIGTERM and SIGHUP stop it as Ctrl-C does (:class:`Stopped`), and the
    command's temporary files live in a folder of its own that is removed however it ends
    (:func:`bimrobot.core.cores.private_temp_folder`)."""
    command = None
    argv = sys.argv[1:] if argv is None else argv
    try:
        with stop_signals_unwind():
            parser = parser_for(argv)  # imports the command's part: a moment in which a signal may come
            args = parser.parse_args(argv)
            command = args.command
            _generated_models(args)
            if not getattr(args, "func", None):
                parser.print_help()
                return 1
            import logging

            from bimrobot.core.cores import private_temp_folder

            logging.basicConfig(
                level=[logging.WARNING, logging.INFO, logging.DEBUG][min(args.verbose, 2)],
                format="%(levelname)s %(name)s: %(message)s",
            )
            with private_temp_folder():
                return int(args.func(args) or 0)
    except BimrobotError as exc:
        print(f"bimrobot {command}: error: {exc}", file=sys.stderr)
        return 2
    except Stopped as stop:
        return stopped_status(stop, command)
    except KeyboardInterrupt:
        return 130
    except SystemError as error:  # a stop raised inside a C extension's call back into Python
        stop = stop_behind(error)
        if stop is None:
            raise
        return stopped_status(stop, command)
    except BrokenPipeError:
        # The reader of our output went away (e.g. `| head`): stop quietly, as Unix tools do.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    sys.exit(main())
