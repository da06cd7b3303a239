"""How long the replay of the largest shared model takes to open in Rerun's web viewer, against a tiny
recording opened in the same browser in the same run (issue 36: "opens in the web viewer in seconds").

    .venv/bin/python bench/replay_load.py                       # MULTICOM-Prefab, built by the site crane
    .venv/bin/python bench/replay_load.py --work /tmp/prefab --repeats 2 --extra other.rrd

The model (``--model``, default ``../shared/data/ifc/MULTICOM-Prefab.ifc``) is converted
(``convert --layout yard``) and simulated (``simulate --fleet site-crane --prebuilt IfcFooting,IfcPile
--unknown-weight 2400``) once into ``--work`` (kept there for later runs), then replayed
(``write_replay``, timed; ``--draw`` as ``replay --draw``: by default a model this large is drawn as boxes
by state, ``--draw meshes`` times each element's mesh). The reference is a recording that holds none of our data: one box and one
line of two points, with the replay's own layout (blueprint), so the same panels open.

Each recording is served as ``replay --serve`` serves it (:func:`bimrobot.replay.serve.serve_web`) and
opened in a fresh headless Chromium (WebGL through SwiftShader, 1280 x 800, as tests/replay/test_browser.py
does). Seconds from asking for the page until:

- *first data*: the viewer's timeline has a time (its Viewer Control state);
- *timeline end*: its timeline reaches the recording's last time (the Gantt's cursor, written last:
  everything has been received);
- *panels drawn*: the "Components per state" panel shows its lines (coloured pixels in a screenshot,
  taken every 2 s once the timeline end is reached), the last panel to fill.

and the browser's CPU seconds (its renderer, GPU and other processes) until the timeline end and
until the panels are drawn: on a shared machine steadier than wall time.

Printed per recording: what it is made of (MB, chunks, entities, rows, read with Rerun's chunk
reader), the times and CPU seconds (min/median/max over ``--repeats``), and each
as a difference from the reference measured in the same repeat. ``--replay`` times a recording
written before instead of writing one; ``--extra`` adds other recordings of the same build (variants).
Timings depend on the machine and its load; only the differences in one run mean something. Needs
Debian's chromium and chromium-driver and selenium (as the browser test). docs/evidence/replay.md
has the figures.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # tests.replay.test_browser: the browser the tests use

#: The "Components per state" panel in a screenshot of the 1280 x 800 window (x0, y0, x1, y1): the middle of the
#: three panels right of the 3D view.
PLOT_BOX = (785, 215, 1275, 335)
#: Coloured pixels there that make a drawn plot (its axis and grid are grey).
PLOT_PIXELS = 150


def build_inputs(model: Path, work: Path) -> tuple[Path, Path]:
    """The package and simulation folders of ``model`` built by the site crane (reused when present)."""
    from bimrobot.cli import main

    package, simulation = work / "pkg", work / "sim"
    if not (package / "report.json").is_file():
        assert main(["convert", str(model), "-o", str(package), "--layout", "yard", "--no-progress", "--no-preview",
                     "--no-maps", "--unknown-weight", "2400"]) == 0
    if not (simulation / "summary.json").is_file():
        assert main(["simulate", str(model), "--fleet", "site-crane", "-o", str(simulation), "--no-progress",
                     "--no-gantt", "--prebuilt", "IfcFooting,IfcPile", "--unknown-weight", "2400"]) == 0
    return package, simulation


def tiny_recording(rrd: Path) -> float:
    """A recording of none of our data (a box, a line of two points at 0 and 1 s) with the replay's
    layout; returns its last time (s)."""
    import rerun as rr

    from bimrobot.replay.layout import blueprint

    rec = rr.RecordingStream("bimrobot-bench", recording_id="bench-tiny")
    rec.set_log_time_enabled(False)  # as the replay: the viewer opens on sim_time
    rec.save(str(rrd), default_blueprint=blueprint(None))
    rec.log("/building/box", rr.Boxes3D(half_sizes=[[2.0, 1.0, 1.5]], colors=[[67, 160, 71]], fill_mode="solid"),
            static=True)
    rec.log("/progress/Assembled", rr.SeriesLines(colors=[[67, 160, 71]]), static=True)
    for t, value in ((0.0, 0.0), (1.0, 1.0)):
        rec.set_time("sim_time", duration=t)
        rec.log("/progress/Assembled", rr.Scalars(value))
    rec.flush()
    rec.disconnect()
    return 1.0


def recording_stats(rrd: Path) -> str:
    """What a recording is made of, read with Rerun's own chunk reader (``rerun.chunk.RrdReader``, the
    recording store, not the blueprint): MB, chunks, entities, rows, and the rows of element poses
    (``/building`` Transform3D), robot poses and plotted values (Scalars)."""
    from rerun.chunk import RrdReader

    chunks = list(RrdReader(rrd).stream())
    counts = {"element poses": 0, "robot poses": 0, "plotted values": 0}
    for chunk in chunks:
        batch = chunk.to_record_batch()
        top = chunk.entity_path.split("/")[1]
        for name in batch.schema.names:
            column = batch.column(name)
            kind = ("element poses" if top == "building" else "robot poses" if top == "robots" else None) \
                if "Transform3D:translation" in name else "plotted values" if "Scalars:scalars" in name else None
            if kind is not None:
                counts[kind] += len(column) - column.null_count
    entities = {c.entity_path for c in chunks if not c.entity_path.startswith("/__")}
    return (f"{rrd.stat().st_size / 1e6:.2f} MB, {len(chunks)} chunks, {len(entities)} entities, "
            f"{sum(len(c) for c in chunks):,} rows (" + ", ".join(f"{k} {v:,}" for k, v in counts.items()) + ")")


def plot_pixels(image) -> int:
    """Saturated (coloured) pixels in :data:`PLOT_BOX` of a screenshot (H, W, 3 ints)."""
    x0, y0, x1, y1 = PLOT_BOX
    box = image[y0:y1, x0:x1]
    return int(((box.max(axis=2) - box.min(axis=2)) > 60).sum())


def cpu_seconds(root: int) -> float:
    """CPU seconds (user + system) used so far by process ``root``'s descendants (Linux /proc), e.g. the
    browser's renderer and GPU processes under chromedriver: on a shared machine the work a page needs is
    steadier than the wall time it takes."""
    import os

    parents, used = {}, {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            parents[int(entry)] = int(fields[1])
            used[int(entry)] = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def under(pid: int) -> bool:
        while pid > 1:
            pid = parents.get(pid, 0)
            if pid == root:
                return True
        return False

    return sum(t for pid, t in used.items() if under(pid))


def open_once(rrd: Path, end_s: float, timeout_s: float, shots: Path | None = None) -> dict:
    """Serve ``rrd``, open it in a fresh browser and time it (module docstring); None for what did not
    happen within ``timeout_s``."""
    from selenium import webdriver
    from selenium.common.exceptions import TimeoutException

    from bimrobot.replay.serve import serve_web
    from tests.replay.test_browser import _screenshot, _state, chromium_session

    browser = chromium_session(webdriver)
    if browser is None:
        sys.exit("Debian's chromium and chromium-driver are needed (scripts/setup.sh installs them)")
    out = {"first data": None, "timeline end": None, "panels drawn": None}
    driver = browser.service.process.pid
    cpu = {}
    try:
        with serve_web(rrd) as viewer:
            started, cpu_start = time.monotonic(), cpu_seconds(driver)
            browser.get(viewer.url + "&persist=0")
            while time.monotonic() - started < timeout_s and out["panels drawn"] is None:
                now = time.monotonic() - started
                try:
                    end = _state(browser, 3, 2, 3, 2)
                except TimeoutException:  # the page did not answer in time (a busy machine): ask again
                    continue
                if end is not None and out["first data"] is None:
                    out["first data"] = now
                if end is not None and abs(end - end_s) < 0.01 and out["timeline end"] is None:
                    out["timeline end"] = now
                    cpu["browser CPU to timeline end"] = cpu_seconds(driver) - cpu_start
                if out["timeline end"] is not None:
                    try:
                        image = _screenshot(browser)
                    except TimeoutException:
                        continue
                    if plot_pixels(image) > PLOT_PIXELS:
                        out["panels drawn"] = time.monotonic() - started
                        cpu["browser CPU to panels drawn"] = cpu_seconds(driver) - cpu_start
                        if shots is not None:
                            from PIL import Image

                            Image.fromarray(image.astype("uint8")).save(shots / f"{rrd.stem}.png")
                    else:
                        time.sleep(2.0)
                else:
                    time.sleep(0.5)
            if out["panels drawn"] is None and shots is not None:  # what it showed when time ran out
                from PIL import Image

                Image.fromarray(_screenshot(browser).astype("uint8")).save(shots / f"{rrd.stem}-timeout.png")
    finally:
        browser.quit()
    return {**out, "browser CPU to timeline end": cpu.get("browser CPU to timeline end"),
            "browser CPU to panels drawn": cpu.get("browser CPU to panels drawn")}


def _fmt(values: list) -> str:
    known = [v for v in values if v is not None]
    if len(known) < len(values):
        return "not within the timeout" if not known else f"{min(known):.1f} ({len(values) - len(known)} timed out)"
    if len(known) == 1:
        return f"{known[0]:.1f}"
    return f"{min(known):.1f} / {statistics.median(known):.1f} / {max(known):.1f}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=ROOT.parent / "shared" / "data" / "ifc" / "MULTICOM-Prefab.ifc")
    parser.add_argument("--work", type=Path, default=Path("/tmp/bimrobot-bench-replay"),
                        help="where the package, simulation and recordings are written (reused)")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per opening")
    parser.add_argument("--extra", type=Path, nargs="*", default=[],
                        help="other recordings of the same build to time beside it (variants)")
    parser.add_argument("--replay", type=Path, help="time this recording of the build instead of writing one")
    parser.add_argument("--shots", type=Path, help="save each recording's screenshot when its panels are drawn")
    parser.add_argument("--draw", choices=("auto", "meshes", "boxes"), default="auto",
                        help="how the written replay draws the building (as `replay --draw`)")
    args = parser.parse_args(argv)
    import signal

    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # stopped: the browser and the server still stop
    if not args.model.is_file():
        sys.exit(f"{args.model}: no such model (the shared test data lives beside the repository)")
    args.work.mkdir(parents=True, exist_ok=True)
    from bimrobot.replay import write_replay

    package, simulation = build_inputs(args.model, args.work)
    rrd = args.replay or args.work / f"{args.model.stem}.rrd"
    if args.replay is None:
        rrd.unlink(missing_ok=True)
        started = time.monotonic()
        summary = write_replay(package, rrd, simulation=simulation, draw=args.draw)
        print(f"{args.model.name}: {summary['pieces']} elements, {summary['components']} components, drawn as "
              f"{summary['drawn']}; write_replay {time.monotonic() - started:.1f} s")
    from bimrobot.replay.inputs import read_schedule

    makespan = max(row["Finish"] for row in read_schedule(simulation / "schedule.csv"))
    print(f"build {makespan:,.0f} s")
    reference = args.work / "tiny.rrd"
    reference.unlink(missing_ok=True)
    reference_end = tiny_recording(reference)
    recordings = [(reference, reference_end)] + [(r, makespan) for r in [rrd, *args.extra]]
    for path, _ in recordings:
        print(f"{path.name}: {recording_stats(path)}")
    times = {r: [] for r, _ in recordings}
    for repeat in range(args.repeats):
        for path, end_s in recordings:
            times[path].append(open_once(path, end_s, args.timeout, args.shots))
            print(f"  repeat {repeat + 1} {path.name}: " + ", ".join(
                f"{k} {'-' if v is None else f'{v:.1f} s'}" for k, v in times[path][-1].items()), flush=True)
    print("\nseconds from asking for the page (min / median / max):")
    for path, _ in recordings:
        print(f"{path.name} ({path.stat().st_size / 1e6:.2f} MB): " + "; ".join(
            f"{k} {_fmt([t[k] for t in times[path]])}" for k in times[path][0]))
        if path != reference:
            for key in times[path][0]:
                more = [None if t[key] is None or r[key] is None else t[key] - r[key]
                        for t, r in zip(times[path], times[reference])]
                print(f"  {key}: {_fmt(more)} s more than the reference in the same repeat")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
