"""``bimrobot report``: (re)write the build report of a `bimrobot build` output folder."""

from __future__ import annotations

import argparse
from pathlib import Path

EXAMPLES = """examples:
  bimrobot report out/                                  # out/report.html (and out/building.png) again
  bimrobot report out/ -o ~/reports/frame.html          # the same page elsewhere (one self-contained file)
  bimrobot report out/ --start 2027-03-01T07:00         # dates from another start (on the site's work calendar)

The page needs no server and no network: open it in any browser.
"""


def register(subparsers) -> None:
    """Add ``bimrobot report`` to the bimrobot parser."""
    parser = subparsers.add_parser(
        "report", help="the build report (report.html) of a `bimrobot build` output folder",
        description="Write the report of a build: one self-contained HTML page with the key figures (model, fleet, "
        "site, makespan with its working-calendar dates, components built, robot utilisation, critical path), "
        "what was assumed and what was refused or escalated, an interactive Gantt per robot, the components "
        "per state over time and a picture of the building assembled. `bimrobot build` writes it at the end.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("build", type=Path, help="a `bimrobot build` output folder")
    parser.add_argument("-o", "--output", type=Path,
                        help="the HTML file to write (default BUILD/report.html; a file bimrobot wrote is replaced)")
    parser.add_argument("--model", type=Path,
                        help="the IFC file, when it is no longer where the build read it (for the building's picture "
                        "and the names of assemblies)")
    parser.add_argument("--start", metavar="ISO",
                        help="date-time of t = 0 s of the build, e.g. 2027-03-01T07:00 (default: the build's own, "
                        "else today 08:00)")
    parser.set_defaults(func=report_command)


def report_command(args: argparse.Namespace) -> int:
    from bimrobot.core import io
    from bimrobot.core.errors import InputError
    from bimrobot.report import write_report
    from bimrobot.report.facts import parse_start

    if args.start is not None:
        try:
            parse_start(args.start)
        except ValueError:
            raise InputError(f"--start {args.start!r} is not an ISO date-time such as 2027-03-01T07:00") from None
    path = write_report(args.build, args.output, start=args.start, model=args.model)
    print(f"{io.printable(str(path))}: the build report; open it in a browser (no network needed)")
    return 0
