"""How often ``bimrobot build`` reads the IFC file, and how long each stage takes, on one model.

    .venv/bin/python bench/build_reads.py MODEL.ifc [-- BUILD OPTIONS]     # e.g. -- --fleet site-crane
    .venv/bin/python bench/build_reads.py steel-frame            # the thesis' frame, written to a temporary file

Runs ``bimrobot build`` once, in this process, into a temporary folder, with every call of
``ifcopenshell.open`` (a parse of the file), every geometry pass of :func:`bimrobot.bim.reader.load_model`
(one ``ifcopenshell.geom.iterator`` sweep over the products, possibly shared by forked processes) and every
``load_model`` counted (real calls, only counted). Prints, per stage, the parses, geometry passes and
loads made while the stage ran, its wall time (``time.perf_counter``) and CPU time (this process and its
children that ended: forked geometry readers, package workers), then the totals and what the build recorded in
``build.json`` (``ifc_reads``, ``geometry_passes``). Stages are told apart by the ``== N/M stage`` lines
the build prints; ``checks`` is what runs before the first stage, ``report`` the report after the last.

Issue 34 ("one model, read once") asks for one read of the file per build, however many stages use the
model; the before/after figures measured with this script are in docs/conventions.md ("One model, read
once"). The machine this runs on is often shared: compare wall times only between runs of one session.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import re
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import ifcopenshell
import ifcopenshell.geom

import bimrobot.bim.reader as reader

def cpu_seconds() -> float:
    """CPU seconds of this process and of its children that ended (the forked geometry readers and
    package workers)."""
    times = os.times()
    return times.user + times.system + times.children_user + times.children_system


STAGE_LINE = re.compile(r"^== (?:\d+/\d+ (\S+)|(report)):", re.MULTILINE)  # the build's stage lines


class Counter:
    """Counts per stage: parses, geometry passes, loads; the stage is the last ``== N/M name`` printed."""

    def __init__(self):
        self.stage = "checks"
        self.counts: dict[str, dict[str, int]] = defaultdict(lambda: {"parses": 0, "geometry": 0, "loads": 0})
        self.started: dict[str, float] = {"checks": time.perf_counter()}
        self.cpu: dict[str, float] = {"checks": cpu_seconds()}
        self.order = ["checks"]

    def count(self, what: str) -> None:
        self.counts[self.stage][what] += 1

    def enter(self, stage: str) -> None:
        if stage not in self.started:
            self.order.append(stage)
        self.stage = stage
        self.started[stage] = time.perf_counter()
        self.cpu[stage] = cpu_seconds()

    def seconds(self, ended: float, cpu_ended: float) -> dict[str, tuple[float, float]]:
        """(wall, CPU) seconds from each stage's line to the next one's (the last to the end)."""
        walls = [self.started[s] for s in self.order] + [ended]
        cpus = [self.cpu[s] for s in self.order] + [cpu_ended]
        return {stage: (walls[i + 1] - walls[i], cpus[i + 1] - cpus[i]) for i, stage in enumerate(self.order)}


class _Watching(io.TextIOBase):
    """stdout that also tells the counter which stage is running."""

    def __init__(self, stream, counter: Counter):
        self.stream, self.counter = stream, counter

    def write(self, text: str) -> int:
        for match in STAGE_LINE.finditer(text):
            self.counter.enter(match.group(1) or match.group(2))
        return self.stream.write(text)

    def flush(self) -> None:
        self.stream.flush()

    def isatty(self) -> bool:
        return False


def _counted(counter: Counter, what: str, function):
    def call(*args, **kwargs):
        counter.count(what)
        return function(*args, **kwargs)

    return call


@contextlib.contextmanager
def counting(counter: Counter):
    """Count the real calls of ifcopenshell.open, the geometry pass and load_model while the block runs."""
    patched = [(ifcopenshell, "open", "parses"), (reader, "_read_shares", "geometry"), (reader, "load_model", "loads")]
    originals = [getattr(owner, name) for owner, name, _ in patched]
    for (owner, name, what), original in zip(patched, originals):
        setattr(owner, name, _counted(counter, what, original))
    try:
        yield counter
    finally:
        for (owner, name, _), original in zip(patched, originals):
            setattr(owner, name, original)


def run_build(model: Path, extra: list[str], folder: Path) -> tuple[Counter, int, float, dict]:
    """Build ``model`` into ``folder/out``; (counter, exit code, wall seconds, build.json)."""
    from bimrobot.cli import main

    counter = Counter()
    out = folder / "out"
    started = time.perf_counter()
    with counting(counter), contextlib.redirect_stdout(_Watching(sys.stdout, counter)):
        try:
            code = main(["build", str(model), "-o", str(out), *extra])
        except SystemExit as exc:
            code = int(exc.code or 0)
    ended = time.perf_counter()
    counter.ended, counter.cpu_ended = ended, cpu_seconds()
    record = json.loads((out / "build.json").read_text(encoding="utf-8")) if (out / "build.json").is_file() else {}
    return counter, code, ended - started, record


def report(counter: Counter, code: int, seconds: float, record: dict) -> str:
    """The table: per stage parses, geometry passes, loads, wall and CPU seconds; totals; build.json's record."""
    lines = [f"{'stage':<12} {'parses':>6} {'geometry':>8} {'loads':>5} {'wall s':>8} {'CPU s':>8}"]
    per_stage = counter.seconds(counter.ended, counter.cpu_ended)
    total = {"parses": 0, "geometry": 0, "loads": 0}
    for stage in counter.order:
        c = counter.counts[stage]
        for key in total:
            total[key] += c[key]
        wall, cpu = per_stage[stage]
        lines.append(f"{stage:<12} {c['parses']:>6} {c['geometry']:>8} {c['loads']:>5} {wall:>8.1f} {cpu:>8.1f}")
    cpu = sum(c for _, c in per_stage.values())
    lines.append(f"{'total':<12} {total['parses']:>6} {total['geometry']:>8} {total['loads']:>5} {seconds:>8.1f} {cpu:>8.1f}")
    lines.append(f"exit {code}; build.json: ifc_reads {record.get('ifc_reads', 'not recorded')}, "
                 f"geometry_passes {record.get('geometry_passes', 'not recorded')}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", help="an IFC file, or steel-frame for the thesis' frame (`bimrobot example`)")
    parser.add_argument("extra", nargs="*", help="more `bimrobot build` options, after --")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bimrobot-build-reads-") as tmp:
        folder = Path(tmp)
        model = Path(args.model)
        if args.model == "steel-frame":
            from bimrobot.bim.examples import steel_frame

            model = steel_frame(folder / "frame.ifc")
        counter, code, seconds, record = run_build(model, args.extra, folder)
    print(f"\n{model.name}: bimrobot build {' '.join(args.extra)}".rstrip(), file=sys.stderr)
    print(report(counter, code, seconds, record), file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
