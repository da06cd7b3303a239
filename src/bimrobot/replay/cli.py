"""``bimrobot replay``: a build's output folder as a 4D replay in Rerun (registered by bimrobot.cli)."""

from __future__ import annotations

import argparse
import datetime as dt
from pathlib import Path

from bimrobot.core.errors import InputError

REPLAY_EXAMPLES = """examples:
  bimrobot replay out/ -o out/build.rrd              # a `bimrobot build` output folder
  rerun out/build.rrd                                # open it in Rerun's native viewer
  bimrobot replay out/ -o build.rrd --serve          # ... or in the web viewer on 127.0.0.1
  bimrobot replay --serve out/build.rrd              # serve a recording written before, as it is
  bimrobot replay sim/ pkg/ -o sim.rrd               # a `simulate` folder and a `convert --layout yard` package
  bimrobot replay out/ -o build.rrd --start 2026-03-02T07:00   # adds a calendar timeline
  bimrobot replay run/ --model e1.ifc -o e1.rrd      # an `rcan run` folder (report.json, state.db, trajectory)

Timelines: sim_time (seconds of the simulated build) and, with --start, calendar; rcan_time (the RCAN
run's activities) and, from the mujoco backend's trajectory CSV, physics_time (recorded body poses).
docs/replay.md says what is shown.
"""


def register(subparsers) -> None:
    """Add ``bimrobot replay`` to the bimrobot parser."""
    parser = subparsers.add_parser(
        "replay",
        help="4D replay of a simulated build in Rerun: the structure growing, robots, Gantt, states",
        description="Turn a `bimrobot build` output folder (or a `simulate` folder and a `convert --layout yard` "
        "package) into a Rerun recording that opens framed on the building: every element a mesh named by storey, "
        "class and name (its GlobalId a property; on a large model each component a box, grouped by state), the work still to be built ghosted in grey, components "
        "travelling from the yard with their transport robots into place, coloured by the thesis' states, a "
        "per-robot Gantt of bars and the number of components per state over time. With --serve and an existing "
        ".rrd, serve that recording as it is.",
        epilog=REPLAY_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("folders", type=Path, nargs="+", metavar="FOLDER",
                        help="a `bimrobot build` output folder, a `simulate` folder and a `convert` package folder, "
                        "or an `rcan run` folder (its report.json and state database; with --model); with --serve, "
                        "an existing .rrd recording, served as it is (nothing is written)")
    parser.add_argument("-o", "--output", type=Path,
                        help="the .rrd file to write (a new file, or one bimrobot wrote, which is replaced); "
                        "required unless an existing recording is served")
    parser.add_argument("--model", type=Path,
                        help="the IFC file, when it is no longer where the package's report.json says")
    parser.add_argument("--start", type=_date_time, metavar="ISO",
                        help="calendar date-time of the build's start, e.g. 2026-03-02T07:00 (adds a calendar timeline)")
    parser.add_argument("--draw", choices=("auto", "meshes", "boxes"), default="auto",
                        help="the building as each element's mesh, or as each component's box grouped by state "
                        "(few entities: a large model opens in the web viewer in a fraction of the time); auto (default): "
                        "boxes above 100 pieces drawn, an assembly's parts counting as one (docs/replay.md)")
    parser.add_argument("--serve", action="store_true",
                        help="then serve it with Rerun's web viewer on 127.0.0.1 and print the URL (Ctrl-C stops it)")
    parser.add_argument("--web-port", type=int, default=0, metavar="PORT",
                        help="port of the web viewer with --serve (default: a free one)")
    parser.set_defaults(func=replay_command)


def _date_time(text: str) -> dt.datetime:
    try:
        return dt.datetime.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an ISO date-time such as 2026-03-02T07:00, got {text!r}") from None


def replay_command(args, model=None) -> int:
    """``bimrobot replay``. ``model``: the BuildingModel of the build's IFC file, already read (``bimrobot
    build`` reads it once for every stage); None reads the file the package names."""
    from bimrobot.core.errors import require_extra

    require_extra("rerun", "replay")  # before any work: the recording and the viewer are Rerun's
    from bimrobot.replay import write_replay

    if len(args.folders) == 1 and args.folders[0].suffix == ".rrd":
        return _serve_existing(args)
    if args.output is None:
        raise InputError("give the .rrd file to write with -o, e.g. -o build.rrd "
                         "(or an existing recording with --serve, e.g. bimrobot replay --serve build.rrd)")
    if len(args.folders) > 2:
        raise InputError("give one build folder, or one `simulate` folder and one `convert` package folder")
    if not args.output.suffix == ".rrd":
        raise InputError(f"-o {args.output}: a Rerun recording ends in .rrd, e.g. -o build.rrd")
    if not 0 <= args.web_port <= 65535:
        raise InputError(f"--web-port {args.web_port} is not a port number (0-65535; 0 picks a free one)")
    simulation = args.folders[1] if len(args.folders) == 2 else None
    summary = write_replay(args.folders[0], args.output, model=args.model, start=args.start, simulation=simulation,
                           building=model, draw=args.draw)
    last = summary["last_installation_s"]
    if summary["components"]:
        print(f"{args.output}: {summary['pieces']} elements, {summary['components']} components "
              f"({summary['installed']} installed, the last at {'-' if last is None else f'{last:,.1f}'} s), "
              f"{summary['robots']} robots, {summary['nodes']} connection nodes"
              + ("; drawn as boxes by state (--draw meshes for each element's mesh)"
                 if summary.get("drawn") == "boxes by state" else ""))
    else:
        print(f"{args.output}: {summary['pieces']} elements")
    if "rcan_activities" in summary:
        physics = (f"; physics: {summary['physics_components']} components and {summary['physics_robots']} robots "
                   "at their recorded poses (timeline physics_time)" if "physics_components" in summary else "")
        print(f"RCAN run: {summary['rcan_done']} of {summary['rcan_activities']} activities done "
              f"(timeline rcan_time){physics}")
    print(f"open it with: rerun {args.output}")
    if args.serve:
        return _serve(args.output, args.web_port)
    return 0


def _serve_existing(args) -> int:
    """``bimrobot replay --serve build.rrd``: serve a recording as it is, writing nothing."""
    from bimrobot.replay.serve import check_recording

    rrd = args.folders[0]
    if not args.serve:
        raise InputError(f"{rrd} is a recording already: open it with `rerun {rrd}`, or serve it in the web viewer "
                         f"with `bimrobot replay --serve {rrd}`")
    if args.output is not None:
        raise InputError(f"-o {args.output}: {rrd} is served as it is; -o names a new recording, written from a "
                         "build folder")
    for option, value in (("--model", args.model), ("--start", args.start),
                          ("--draw", None if args.draw == "auto" else args.draw)):
        if value is not None:
            raise InputError(f"{option}: {rrd} is served as it was recorded; {option} applies when a recording is "
                             "written from a build folder")
    check_recording(rrd)
    if not 0 <= args.web_port <= 65535:
        raise InputError(f"--web-port {args.web_port} is not a port number (0-65535; 0 picks a free one)")
    return _serve(rrd, args.web_port)


def _serve(rrd: Path, port: int) -> int:
    from bimrobot.replay.serve import serve_until_stopped

    return serve_until_stopped(rrd, port, lambda url: print(f"web viewer: {url}\n(Ctrl-C stops it)", flush=True))
