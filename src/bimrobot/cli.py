"""The one ``bimrobot`` command. Thin: parse, call the library, print.

Each part of the platform registers its own sub-commands from ``bimrobot.<part>.cli.register``, so
adding a part means adding one module to :data:`PART_CLIS`.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import logging
import os
import signal
import sys
import threading

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
    "bimrobot.report.cli",
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


class Stopped(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised where Ctrl-C raises KeyboardInterrupt, so that a command stopped by
    ``kill``, ``timeout`` or a closed terminal unwinds the same way: every ``finally`` and context
    manager runs (children stopped, temporary files removed, resumable work kept) before it exits."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = int(signum)


STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
"""Signals that stop a command like Ctrl-C does (SIGINT is Python's KeyboardInterrupt already)."""


def _raise_stopped(signum: int, frame) -> None:
    raise Stopped(signum)


@contextlib.contextmanager
def _stop_signals_unwind():
    """While a command runs, SIGTERM and SIGHUP raise :class:`Stopped` (in the main thread only, where
    Python delivers signals). A signal the caller ignores (``nohup``) stays ignored; the previous
    handlers are back afterwards (main may be called in-process, by a test)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}
    for signum, handler in previous.items():
        if handler is not signal.SIG_IGN:
            signal.signal(signum, _raise_stopped)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler if handler is not None else signal.SIG_DFL)


def main(argv: list[str] | None = None) -> int:
    """Run one command; the exit status: 0 done, 1 no command, 2 bad input (one sentence, no traceback),
    130 / 143 / 129 stopped by SIGINT (Ctrl-C) / SIGTERM / SIGHUP, 141 output pipe closed."""
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
        with _stop_signals_unwind():
            return int(args.func(args) or 0)
    except BimrobotError as exc:
        print(f"bimrobot {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except Stopped as stop:
        print(f"bimrobot {args.command}: stopped by {signal.Signals(stop.signum).name}", file=sys.stderr)
        return 128 + stop.signum
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        # The reader of our output went away (e.g. `| head`): stop quietly, as Unix tools do.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    sys.exit(main())
