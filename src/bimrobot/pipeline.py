"""``bimrobot build``: the main job in one command, from an IFC model to a robot-built structure.

Stages, each one existing sub-command's function called in this process on the output of the stage before,
into one output folder (written atomically and resumable, :func:`bimrobot.core.io.resumable_output_dir`):

========== ============================================================== ===========================
stage      what                                                           sub-command
========== ============================================================== ===========================
simulation market-based build by the fleet: schedule, log, Gantt, states,  ``simulate``
           and the site with the building placed on it (``site.yaml``)
package    Gazebo package of the model, components on the site's yard     ``convert --layout yard``
graph      BOT + DiCon knowledge graph of the model and the schedule      ``graph --schedule``
rcan       the schedule executed through RCAN nodes (sim robots)          ``rcan run --state-db``
replay     the 4D replay (Rerun recording)                                ``replay``
========== ============================================================== ===========================

The simulation comes first: a fleet that cannot build the model is refused before the package is
written. Every stage after it reads the site from ``site.yaml``.

One model, read once (issue 34): the IFC file is parsed once, when the build starts (its selectors are
checked on that parse, in seconds), and the :class:`~bimrobot.bim.model.BuildingModel` is read from that
parse once, with its geometry, selection, assembly units, prebuilt selector and unknown-weight rule, when
the first stage needs it (:class:`BuildModel`). Each stage is its sub-command's own function (``simulate``
``run_simulate``, ``convert`` ``convert_command``, ``graph`` ``graph_command``, ``replay``
``replay_command``) given that model instead of reading the file: the options are the sub-command's, parsed
from the line the build prints, so a sub-command run alone with that line writes the same output. The
graph stage writes the work schedule into the parse itself (``model-with-schedule.ifc``); nothing reads
it afterwards. ``build.json`` records how often the file was parsed and its geometry read (``ifc_reads``,
``geometry_passes``: 1 and 1 for a build that ran every stage).

A stage that finished is recorded in ``.stages.json``; a build killed (SIGKILL, Ctrl-C) and run again
with the same inputs and options skips the finished stages and resumes RCAN from its state database,
so its result equals an uninterrupted build's.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import shlex
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from bimrobot.core.errors import InputError

BUILD_EXAMPLES = """examples:
  bimrobot build frame.ifc -o out/                                  # fleet2 on the thesis' site (fig. 4.11)
  bimrobot build model.ifc --fleet site-crane --prebuilt IfcFooting,IfcSlab,IfcWall -o out/
  bimrobot build model.ifc --fleet my-fleet.yaml --site my-site.yaml --unknown-weight 7850 -o out/
  bimrobot build model.ifc -o out/ --schedule-out plan.xml --start 2027-03-01T07:00   # + out/plan.xml (MS Project)

Killed or interrupted? Run the same command again: finished stages are kept and RCAN resumes.
Open the result: out/README.md says what each file is.
"""

STAGES_FILE = ".stages.json"
WORK_SCHEDULE_IFC = "model-with-schedule.ifc"


class BuildModel:
    """The build's model, read once: ``ifc`` the IFC file parsed when the build starts (its selectors are
    checked on it), :meth:`model` the BuildingModel read from that parse (geometry, selection, assembly
    units, ``--prebuilt``, ``--unknown-weight``) the first time a stage asks for it. Lengths in metres, z up,
    kg."""

    def __init__(self, args: argparse.Namespace):
        from bimrobot.bim.reader import READS, open_ifc

        self.args = args
        self.reads_before = READS.of(args.model)  # (parses, geometry passes) of the file before the build
        self.ifc = open_ifc(args.model)  # the one parse of the file
        self._model = None

    def model(self):
        """The BuildingModel, read from the one parse on the first call."""
        if self._model is None:
            from bimrobot.bim import load_model
            from bimrobot.sco.build import prebuilt_selector

            args = self.args
            if self.ifc is None:
                raise RuntimeError("the build's model is read after its parse was given to the graph stage")
            self._model = load_model(args.model, include=args.include, exclude=args.exclude,
                                     prebuilt=prebuilt_selector(args.prebuilt), unknown_weight=args.unknown_weight,
                                     ifc=self.ifc)
        return self._model

    def reads(self) -> dict[str, int]:
        """How often the build parsed the file and read its geometry: ``{"ifc_reads", "geometry_passes"}``."""
        from bimrobot.bim.reader import READS

        parses, geometry = READS.of(self.args.model)
        return {"ifc_reads": parses - self.reads_before[0], "geometry_passes": geometry - self.reads_before[1]}


def _simulate(sub_args: argparse.Namespace, shared: BuildModel) -> int:
    from bimrobot.coordination.cli import run_simulate

    return run_simulate(sub_args, shared.model())


def _convert(sub_args: argparse.Namespace, shared: BuildModel) -> int:
    from bimrobot.export.cli import convert_command

    return convert_command(sub_args, shared.model())


def _graph(sub_args: argparse.Namespace, shared: BuildModel) -> int:
    """The graph and the IFC work schedule, written into the build's parse of the file (the last reader)."""
    from bimrobot.lbd.cli import graph_command

    model = shared.model()
    ifc, shared.ifc = shared.ifc, None
    return graph_command(sub_args, model, ifc)


def _rcan(sub_args: argparse.Namespace, shared: BuildModel) -> int:
    return int(sub_args.func(sub_args) or 0)  # RCAN runs from the graph alone: no model


def _replay(sub_args: argparse.Namespace, shared: BuildModel) -> int:
    from bimrobot.replay.cli import replay_command

    return replay_command(sub_args, shared.model())


@dataclass(frozen=True)
class Stage:
    """One step of the build: ``name`` (its output in the folder), ``title``, the sub-command line (its
    options, printed), and ``run``: the sub-command's function called on the parsed line and the build's model."""

    name: str
    title: str
    argv: Callable[[argparse.Namespace, Path], list[str]]
    run: Callable[[argparse.Namespace, BuildModel], int]
    #: exit codes of the sub-command that still finish the stage (rcan: 1 = something escalated)
    accepted: tuple[int, ...] = (0,)


def _selection(args) -> list[str]:
    out = []
    if args.include:
        out += ["--include", args.include]
    if args.exclude is not None:
        out += ["--exclude", args.exclude]
    return out


def _weights(args) -> list[str]:
    return ["--unknown-weight", args.unknown_weight_text]


def _package_name(args) -> str:
    """The ROS package name of the world: from the output folder's name, as `convert` would."""
    from bimrobot.core.names import ros_package_name

    return ros_package_name(args.output.resolve().name)


def _site(args) -> list[str]:
    return ["--site", str(args.site)] if args.site else []


#: The build's site with the building placed on it (``model_offset`` set), written by the simulation stage
#: (the given site, fig. 4.11 or derived) and given to every later stage: one placement, read back, never
#: recomputed.
PLACED_SITE = "site.yaml"


def _placed_site(folder: Path) -> list[str]:
    return ["--site", str(folder / PLACED_SITE)]


def _site_source(folder: Path) -> str:
    """Where the build's site came from (a site file, fig. 4.11, or derived from the building), as the
    simulation stage recorded it."""
    try:
        return str(json.loads((folder / "simulation" / "summary.json").read_text(encoding="utf-8"))["site"])
    except (OSError, ValueError, KeyError, TypeError):
        return "unknown"


def _write_placed_site(folder: Path) -> None:
    """``site.yaml``: the site the simulation stage placed the building on (``simulation/site.yaml``)."""
    tmp = folder / (PLACED_SITE + ".tmp")
    tmp.write_bytes((folder / "simulation" / PLACED_SITE).read_bytes())
    tmp.replace(folder / PLACED_SITE)


STAGES = (  # the simulation first: it refuses a fleet that cannot build the model before the package is written
    Stage("simulation", "build simulation (market, SimPy)",
          lambda a, d: ["simulate", str(a.model), "--fleet", str(a.fleet), "-o", str(d / "simulation"),
                        "--prebuilt", a.prebuilt, *(["--by-element"] if a.by_element else []),
                        *_site(a), *_selection(a), *_weights(a), *_planner(a)], _simulate),
    Stage("package", "Gazebo package (components on the yard)",
          lambda a, d: ["convert", str(a.model), "-o", str(d / "package"), "--layout", "yard",
                        "--package-name", _package_name(a), *_placed_site(d), *_selection(a), *_weights(a)],
          _convert),
    Stage("graph", "knowledge graph (BOT + DiCon + schedule, joints, pick-up positions) and the IFC work schedule",
          lambda a, d: ["graph", str(a.model), "--schedule", str(d / "simulation" / "schedule.csv"),
                        "-o", str(d / "graph.ttl"), "--package", str(d / "package"), "--prebuilt", a.prebuilt,
                        "--fleet", str(a.fleet),
                        *(["--by-element"] if a.by_element else []), *_work_schedule(a, d), *_selection(a), *_weights(a)],
          _graph),
    Stage("rcan", "RCAN run generated from the graph (the fleet's robots, simulated)",
          lambda a, d: ["rcan", "run", "--graph", str(d / "graph.ttl"), "--backend", a.backend,
                        "--capabilities", str(a.fleet), "--state-db", str(d / "rcan" / "state.db"), "-q",
                        "--report", str(d / "rcan" / "report.json"), "--graph-out", str(d / "rcan" / "graph-after-rcan.ttl"),
                        "--time-scale", repr(a.time_scale), *_placed_site(d)],
          _rcan, accepted=(0, 1)),
    Stage("replay", "4D replay of the build in Rerun (build.rrd)",
          lambda a, d: ["replay", str(d), "-o", str(d / "build.rrd"), "--model", str(a.model),
                        *(["--start", a.start] if a.start else [])], _replay),
)


def _planner(args) -> list[str]:
    """``--planner NAME`` for the simulation stage (issue 38); CP-SAT plans per joint. None: the market."""
    if getattr(args, "planner", None) is None:
        return []
    return ["--planner", args.planner, *(["--per-joint"] if args.planner == "cp-sat" else [])]


def _planner_text(args) -> str:
    return "" if getattr(args, "planner", None) is None else f" --planner {args.planner}"


def _planned_by(args) -> str:
    """The README's line on who planned the build (issue 38); nothing for the default market."""
    if getattr(args, "planner", None) in (None, "market"):
        return ""
    return f"\nPlanned by `{args.planner}` (`simulation/plan.json`: planning time and decisions)."


def _work_schedule(args, folder: Path) -> list[str]:
    """``--ifc-out`` for the model with its simulated schedule as an IfcWorkSchedule (an IFC2X3 model's
    copy is migrated to IFC4, which has IfcTaskTime), ``--schedule-out`` for its scheduler export in the
    output folder, and the site whose work calendar the times are laid onto."""
    return ["--ifc-out", str(folder / WORK_SCHEDULE_IFC), *(["--start", args.start] if args.start else []),
            *(["--schedule-out", str(folder / args.schedule_out)] if args.schedule_out else []), *_placed_site(folder)]


def _check_schedule_out(args) -> None:
    """``build --schedule-out``: a file name (.xml or .p6.xml) written into the output folder."""
    from bimrobot.schedule.ifc import schedule_export_kind

    if args.schedule_out is None:
        return
    schedule_export_kind(args.schedule_out)
    name = Path(args.schedule_out)
    if name.name != str(args.schedule_out) or name.name in (WORK_SCHEDULE_IFC, "README.md", "build.json", "graph.ttl"):
        raise InputError(f"--schedule-out {args.schedule_out}: give a new file name such as plan.xml, without a folder; "
                         "it is written into the output folder")


def register(subparsers) -> None:
    """Add ``bimrobot build`` to the bimrobot parser."""
    from bimrobot.bim.selection import add_prebuilt_option, add_selection_options
    from bimrobot.bim.unknown_weight import add_unknown_weight_option

    parser = subparsers.add_parser(
        "build",
        help="the whole pipeline in one command: package, simulation, graph and RCAN run of an IFC model",
        description="Take an IFC model to a robot-built structure in one run: convert it into a Gazebo package "
        "with the components on the yard, simulate the build by the fleet, build the knowledge graph of the "
        "model and its schedule, and execute the schedule through RCAN. Everything goes into one output folder "
        "(with a README.md saying what each file is); a killed build resumes when run again.",
        epilog=BUILD_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("model", type=Path, help="the IFC file (.ifc or .ifczip)")
    parser.add_argument("-o", "--output", type=Path, required=True,
                        help="output folder: a new or empty folder, or one bimrobot wrote (replaced at the end)")
    parser.add_argument("--fleet", default="fleet2",
                        help="fleet1, fleet2 (thesis Table 4.1), site-crane, or a fleet YAML file (default fleet2)")
    parser.add_argument("--site", type=Path,
                        help="site YAML: yard, robot_home, construction_area, model_offset, idle_robots "
                        "(default: fig. 4.11 when the building fits its 7.5 x 6.5 m area, else a site derived from the building; 'thesis' forces fig. 4.11)")
    add_prebuilt_option(parser)
    parser.add_argument("--by-element", action="store_true",
                        help="build element by element even when the model groups them into assemblies")
    parser.add_argument("--start", metavar="ISO",
                        help="date-time of t = 0 s of the build for the IFC work schedule, e.g. 2027-03-01T07:00 "
                        "(default: today 08:00); the work is laid onto the site's work_calendar from there")
    parser.add_argument("--schedule-out", metavar="NAME.xml",
                        help="also write the work schedule for a scheduler into the output folder, through ifc4d: "
                        "NAME.xml Microsoft Project XML, NAME.p6.xml Primavera P6 XML")
    parser.add_argument("--backend", default="sim", choices=("sim", "mujoco"),
                        help="RCAN's executor backend: sim (kinematic robots, the default) or mujoco (the robots act "
                        "physically in MuJoCo; rcan/state.db.trajectory.csv holds their trajectories)")
    parser.add_argument("--time-scale", type=_non_negative, default=0.0, metavar="S",
                        help="RCAN's sim robots: real seconds slept per simulated second (default 0, as fast as possible)")
    parser.add_argument("--planner", metavar="NAME",
                        help="who plans the build, as simulate --planner (default the market): market, "
                        "market:quickest-finish, rule:NAME, portfolio, rollout, cp-sat (per joint), learned, learned:greedy or PATH.zip")
    add_selection_options(parser, built=True)
    add_unknown_weight_option(parser)
    parser.set_defaults(func=build_command)


def _non_negative(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0.0 <= value <= 1000.0:
        raise argparse.ArgumentTypeError(f"expected seconds per simulated second between 0 and 1000, got {text!r}")
    return value


def _inputs(args) -> list[Path]:
    from bimrobot.site.fleet import BUILTIN_FLEETS

    files = [args.model]
    if str(args.fleet) not in BUILTIN_FLEETS:
        files.append(Path(args.fleet))
    if args.site and str(args.site) != "thesis":
        files.append(args.site)
    return files


def _fingerprint(args) -> dict:
    """What makes two builds the same: the options and the inputs' contents (SHA-256)."""
    from bimrobot.core.io import file_digest as digest

    options = {key: str(getattr(args, key)) for key in
               ("fleet", "site", "prebuilt", "by_element", "include", "exclude", "unknown_weight_text", "start",
                "backend", "schedule_out")}
    if getattr(args, "planner", None) is not None:  # issue 38; absent by default, so earlier builds still match
        options["planner"] = str(args.planner)
    return {"options": options, "inputs": {str(p.resolve()): digest(p) for p in _inputs(args)}}


def _check_inputs(args) -> BuildModel:
    """Refuse what the stages would refuse, before anything is written: a missing model, fleet or site,
    a selector or prebuilt class the model cannot match (parsed without geometry: seconds, not the
    minutes the stages take). A fleet that cannot build the model is refused by the first stage.
    Returns the build's model: the one parse of the file, which the stages' BuildingModel is read from."""
    from bimrobot.bim.selection import check_selection
    from bimrobot.site.fleet import load_fleet
    from bimrobot.site.site import load_site

    _check_extras(args)
    if not args.model.is_file():
        raise InputError(f"model file {str(args.model)!r} does not exist")
    load_fleet(args.fleet)
    load_site(args.site)
    _check_schedule_out(args)
    if getattr(args, "planner", None) is not None:  # issue 38: a wrong planner name, refused before the stages
        from bimrobot.planning.planners import check_planner

        check_planner(args.planner, per_node=args.planner != "cp-sat")
    shared = BuildModel(args)
    check_selection(args.model, args.include, args.exclude, args.prebuilt, ifc=shared.ifc)
    return shared


def _check_extras(args) -> None:
    """Name a missing extra the stages need with its install command before any work (issue 36): the
    replay (rerun) always, the physics (mujoco) with ``--backend mujoco``. The report's extra is not
    needed: without it the build writes the README's key figures, so it is named here (one line on
    stderr) and the build goes on."""
    from bimrobot import report
    from bimrobot.core.errors import require_extra

    require_extra("rerun", "replay")
    if getattr(args, "backend", None) == "mujoco":
        require_extra("mujoco", "physics")
    if report.missing_packages():
        print(f"report: report.html will not be written (only the README's key figures): {report.INSTALL_HINT}",
              file=sys.stderr, flush=True)


def _run_stage(stage: Stage, args, folder: Path, shared: BuildModel) -> int:
    """Run one stage's sub-command function in this process on the build's model; its exit code
    (InputError propagates)."""
    from bimrobot.core import io
    from bimrobot.cli import parser_for

    argv = stage.argv(args, folder)
    sub_args = parser_for(argv).parse_args(argv)  # only the stage's part is imported and registered
    shown = shlex.join(argv).replace(str(folder), str(args.output).rstrip("/"))
    print(f"$ bimrobot {io.printable(shown)}", flush=True)
    # The stage writes into the build's partial folder, renamed to the output at the end: its lines name
    # the output folder, where the user will find the files.
    with contextlib.redirect_stdout(_Renaming(sys.stdout, str(folder), str(args.output).rstrip("/"))):
        code = int(stage.run(sub_args, shared) or 0)
    if code not in stage.accepted:
        raise InputError(f"stage {stage.name} ({stage.title}) failed with exit code {code}; see its output above")
    return code


class _Renaming:
    """A text stream that writes to ``stream`` with every ``old`` replaced by ``new``."""

    def __init__(self, stream, old: str, new: str):
        self.stream, self.old, self.new = stream, old, new

    def write(self, text: str) -> int:
        return self.stream.write(text.replace(self.old, self.new))

    def flush(self) -> None:
        self.stream.flush()

    def __getattr__(self, name: str):  # isatty, encoding, fileno ...: those of the stream
        return getattr(self.stream, name)


def build_command(args: argparse.Namespace) -> int:
    """``bimrobot build``: run the stages into one resumable output folder; 1 when RCAN escalated work."""
    from bimrobot.core import io

    args.unknown_weight_text = _unknown_weight_text(args)
    shared = _check_inputs(args)
    started = time.monotonic()
    codes: dict[str, int] = {}
    with io.resumable_output_dir(args.output, kind="build", fingerprint=_fingerprint(args),
                                 inputs=_inputs(args)) as (folder, resumed):
        done = _read_stages(folder) if resumed else {}
        for number, stage in enumerate(STAGES, start=1):
            print(f"\n== {number}/{len(STAGES)} {stage.name}: {stage.title}", flush=True)
            if stage.name in done:
                print(f"   done in an earlier run (exit {done[stage.name]['exit']}), kept", flush=True)
                codes[stage.name] = done[stage.name]["exit"]
                continue
            stage_started = time.monotonic()
            codes[stage.name] = _run_stage(stage, args, folder, shared)
            if stage.name == "simulation":
                _write_placed_site(folder)
            done[stage.name] = {"exit": codes[stage.name], "seconds": round(time.monotonic() - stage_started, 2)}
            _write_stages(folder, done)
        (folder / STAGES_FILE).unlink()
        building = shared.model()  # read already unless every stage was kept from an earlier run; the report draws it
        reads = shared.reads()
        print(f"\nmodel: {io.printable(args.model.name)} parsed {_times(reads['ifc_reads'])} and its geometry read "
              f"{_times(reads['geometry_passes'])} for the {len(STAGES)} stages and the report (build.json ifc_reads)",
              flush=True)
        (folder / "build.json").write_text(json.dumps({
            "generator": io.signature("build"), "model": str(args.model.resolve()), "fleet": str(args.fleet),
            "site": _site_source(folder), "backend": args.backend, "stages": done,
            "resumed": resumed, "start": _start_text(args), **reads}, indent=2), encoding="utf-8")
        figures = _build_report(folder, building)
        (folder / "README.md").write_text(readme(args, folder, done, figures), encoding="utf-8")
    print(f"\nbuild: {io.printable(str(args.output))}/ in {time.monotonic() - started:.1f} s"
          f"{' (resumed)' if resumed else ''}; README.md says what each file is; "
          f"see the build with: rerun {io.printable(str(Path(args.output) / 'build.rrd'))}")
    if codes.get("rcan", 0) != 0:
        print("build: RCAN escalated activities; see rcan/report.json", file=sys.stderr)
        return 1
    return 0


def _times(count: int) -> str:
    return {0: "never", 1: "once", 2: "twice"}.get(count, f"{count} times")


def _unknown_weight_text(args) -> str:
    """The --unknown-weight rule as command-line text for the stages (which parse it again): auto, refuse
    or the density (UnknownWeightRule.text)."""
    return args.unknown_weight.text


def _read_stages(folder: Path) -> dict:
    try:
        return json.loads((folder / STAGES_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def _write_stages(folder: Path, done: dict) -> None:
    tmp = folder / (STAGES_FILE + ".tmp")
    tmp.write_text(json.dumps(done, indent=2), encoding="utf-8")
    tmp.replace(folder / STAGES_FILE)


def _work_schedule_row(args) -> str:
    from bimrobot.bim.reader import header_schema

    migrated = " (migrated from IFC2X3 to IFC4, which has IfcTaskTime)" if header_schema(args.model) == "IFC2X3" else ""
    row = (f"| `{WORK_SCHEDULE_IFC}` | the model with the simulated schedule as an IfcWorkSchedule{migrated}: summary "
           "tasks per storey and assembly unit with one IfcTask per activity nested in them, times in working time "
           "on the site's IfcWorkCalendar, IfcRelSequence, outputs on the parts with a body | Bonsai's 4D sequencing; "
           "ifcopenshell |\n")
    if args.schedule_out:
        from bimrobot.schedule.ifc import SCHEDULE_EXPORTS

        kind = SCHEDULE_EXPORTS[".p6.xml" if str(args.schedule_out).lower().endswith(".p6.xml") else ".xml"]
        program = "Primavera P6 (Import, P6 XML)" if kind.startswith("Primavera") else "Microsoft Project"
        row += f"| `{args.schedule_out}` | the same work schedule as {kind}, written through ifc4d | {program} |\n"
    return row


def _trajectory_row(folder: Path) -> str:
    """The README row of the mujoco backend's trajectory file, when the run wrote one."""
    if not (folder / "rcan" / "state.db.trajectory.csv").exists():
        return ""
    return ("| `rcan/state.db.trajectory.csv` | `--backend mujoco`: every body's pose at 20 Hz of simulated time "
            "(`time_s, body, x, y, z, qw, qx, qy, qz`; bodies are GlobalIds and `<robot>/<link>`) | a spreadsheet; "
            "`bimrobot replay` |\n")


def readme(args, folder: Path, done: dict, figures: str = "") -> str:
    """out/README.md: the build's key figures (``figures``, Markdown from :func:`_build_report`), then
    what each file is and how to open it."""
    from bimrobot.core import io

    seconds = ", ".join(f"{name} {info['seconds']:.1f} s" for name, info in done.items() if "seconds" in info)
    return f"""<!-- {io.signature("build README")} -->
# Build of {args.model.name}

`bimrobot build {args.model.name} --fleet {args.fleet}{' --site ' + str(args.site) if args.site else ''}{_planner_text(args)}` ({seconds}).
Fleet: `{args.fleet}`; site: {_site_source(folder)} (`site.yaml`). Units: metres, z up, kg, seconds.{_planned_by(args)}

{figures}
## Files

| path | what | open it with |
|---|---|---|
{_report_rows(folder)}| `package/` | Gazebo Sim package: `worlds/`, one model per element (`models/<GlobalId>/`), the components on the yard, `launch/`, `maps/` (Nav2 occupancy maps), `report.json` | `ros2 launch package/launch/gz_sim.launch.py`; `package/README.md` |
| `site.yaml` | the site (yard, robot homes, construction area, work calendar) with the building placed on it (`model_offset`): the simulation chose it, every later stage used this one placement | a text editor; `--site` of any command |
| `simulation/schedule.csv` | the simulated schedule: one row per activity (transport, position, assemble), robot, start, finish, predecessors (docs/conventions.md) | a spreadsheet; `bimrobot rcan run --schedule` |
| `simulation/events.log` | the build step by step, in the thesis' Listing 4.2 words | a text editor |
| `simulation/gantt.png` | Gantt chart of the robots' work | an image viewer |
| `simulation/summary.json`, `robots.csv`, `states.json` | makespan, utilisation, per-robot steps and busy time (Table 4.2 layout), state history per component | `jq`, a spreadsheet |
| `graph.ttl` | knowledge graph: BOT topology, joints and connection nodes with provenance, DiCon activities of the schedule with their robots, component states and pick-up positions; RCAN is generated from it | `bimrobot query graph.ttl rcan_ready_activities`; any RDF tool |
| `rcan/report.json` | the RCAN run: each activity with its robot, result and times; escalated and blocked work | `jq` |
| `rcan/state.db` | RCAN's state database (journal, component states); the build resumes from it | `sqlite3` |
| `rcan/graph-after-rcan.ttl` | the graph with the states after the RCAN run | `bimrobot query` |
{_trajectory_row(folder)}{_work_schedule_row(args)}| `build.rrd` | 4D replay: the structure growing, components travelling from the yard with their robots, states, a Gantt you can scrub (docs/replay.md) | `rerun build.rrd`, or `bimrobot replay --serve build.rrd` for the web viewer (serves it as it is, writes nothing) |
| `build.json` | the inputs, options, the time of each stage, and how often the build parsed the IFC file and read its geometry (`ifc_reads`, `geometry_passes`: once each) | `jq` |
"""


# --- the build report (bimrobot.report, issue 36): report.html, building.png, the README's key figures ---

def _start_text(args) -> str:
    """The build's t = 0 s as ISO text: ``--start``, else today 08:00 (as the IFC work schedule's)."""
    from bimrobot.report.facts import parse_start

    try:
        return parse_start(args.start).isoformat(timespec="minutes")
    except ValueError:
        return str(args.start)


def _build_report(folder: Path, building=None) -> str:
    """Write ``report.html`` and ``building.png`` (drawn from the build's model) into the build folder;
    return the key figures as Markdown for the README. Without the report extra (plotly, jinja2) the page
    is left out, with a line saying so."""
    from bimrobot import report

    print("\n== report: report.html (key figures, Gantt, states over time, the building assembled)", flush=True)
    if report.missing_packages():
        print(f"report: report.html not written: {report.INSTALL_HINT}", file=sys.stderr, flush=True)
        return report.readme_figures(folder, building=building)
    started = time.monotonic()
    figures = report.write_build_report(folder, building=building)
    print(f"report.html, building.png and the README's key figures in {time.monotonic() - started:.1f} s", flush=True)
    return figures


def _report_rows(folder: Path) -> str:
    """The README rows of the report's files, when the build wrote them."""
    rows = ""
    if (folder / "report.html").exists():
        rows += ("| `report.html` | the build report: key figures, the building assembled, a Gantt per robot, components "
                 "per state over time, critical path, what was assumed, refused or escalated (one file, no network) | "
                 "a web browser; `bimrobot report out/` writes it again |\n")
    if (folder / "building.png").exists():
        rows += "| `building.png` | the building assembled (every element at its installed pose) | an image viewer |\n"
    return rows
