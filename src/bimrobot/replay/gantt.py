"""Gantt charts in the replay: one row of bars per robot, a time cursor over them.

Drawn as 2D boxes (Rerun's ``Boxes2D`` in a 2D view), so that each activity is a bar from its start
to its finish, coloured by what the robot does, with its text on hover: x is time, scaled so that the
whole chart spans :func:`chart_width` units; y is the robot's row (first robot on top, 1 unit per
row). The bars are static (the whole plan at a glance); ``<root>/now``, a vertical line on the
chart's timelines, marks the current time.

Two charts use it: the simulated schedule's (``/gantt`` on ``sim_time``,
:func:`bimrobot.replay.record.log_gantt`) and what RCAN executed (``/rcan_gantt`` on ``rcan_time``, and
``physics_time`` with the mujoco backend, whose activity times are the scene's seconds;
bimrobot.replay.record_rcan).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bimrobot.replay.elements import entity
from bimrobot.replay.inputs import BuildRecord

#: Bar colours by activity (RGB): those of the simulation's gantt.png (bimrobot.coordination.report).
ACTIVITY_COLOURS = {"transport": (76, 114, 176), "position": (221, 132, 82), "assemble": (85, 168, 104)}
OTHER_COLOUR = (120, 120, 120)
#: Half height of a bar (row units) and the width of the robot-name column left of x = 0.
BAR_HALF_HEIGHT = 0.35
NAME_COLUMN = 6.0
#: Most positions of the time cursor (it is drawn at each activity start and finish, thinned to this).
MAX_CURSOR_STEPS = 2000


@dataclass(frozen=True)
class Bar:
    """One activity of a robot: ``start_s`` to ``finish_s`` (seconds on the chart's timeline),
    ``activity`` one of :data:`ACTIVITY_COLOURS`' keys (else drawn grey), ``text`` shown on hover."""

    robot: str
    start_s: float
    finish_s: float
    activity: str
    text: str


def chart_width(rows: int) -> float:
    """Width of the time axis in chart units: wide enough to read, for any number of rows."""
    return max(16.0, 3.0 * rows)


def chart_bounds(rows: int) -> tuple[list[float], list[float]]:
    """(x range, y range) of a chart of ``rows`` robots, names column and time labels included (chart units)."""
    rows = max(rows, 1)
    return [-NAME_COLUMN - 0.2, chart_width(rows) + 0.5], [-1.6, rows + 0.2]


def bounds(record: BuildRecord) -> tuple[list[float], list[float]]:
    """(x range, y range) of the schedule's chart (chart units)."""
    return chart_bounds(len(record.robots))


def time_label(seconds: float) -> str:
    """A time as a planner reads it: seconds, minutes, hours or days."""
    for unit, size in (("d", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:,.1f} {unit}"
    return f"{seconds:,.0f} s"


def schedule_bars(record: BuildRecord) -> list[Bar]:
    """The simulated schedule's rows as bars, in schedule order."""
    return [Bar(r["Robot"], r["Start"], r["Finish"], r["Activity"],
                f"{r['Robot']}: {r['Activity']} {r['Name']} ({r['Start']:,.1f}-{r['Finish']:,.1f} s)")
            for r in record.schedule]


def log_chart(rec, root: str, robots: list[str], bars: list[Bar], end_s: float, timelines: tuple[str, ...]) -> int:
    """Log a chart under ``/<root>``: per robot its bars (``/<root>/<robot>``), the robots' names
    (``/<root>/names``, one point per row), the time ticks (``/<root>/axis``), all static, and the cursor
    (``/<root>/now``) on each of ``timelines``. ``end_s``: the time at the chart's right edge (s).
    Returns the number of bars."""
    import rerun as rr

    width, end = chart_width(len(robots)), max(end_s, 1e-9)
    scale = width / end
    count = 0
    # a label is drawn below its point: each point a little above its row's middle
    rec.log(entity(root, "names"), rr.Points2D(
        [[-0.55 * NAME_COLUMN, row - 0.3] for row in range(len(robots))], radii=[0.01], colors=[(255, 255, 255)],
        labels=robots, show_labels=True), static=True)
    for row, name in enumerate(robots):
        mine = [b for b in bars if b.robot == name]
        if not mine:
            continue
        starts = np.array([b.start_s for b in mine]) * scale
        finishes = np.array([b.finish_s for b in mine]) * scale
        rec.log(entity(root, name), rr.Boxes2D(
            mins=np.column_stack([starts, np.full(len(mine), row - BAR_HALF_HEIGHT)]),
            sizes=np.column_stack([np.maximum(finishes - starts, 1e-3 * width), np.full(len(mine), 2 * BAR_HALF_HEIGHT)]),
            colors=[ACTIVITY_COLOURS.get(b.activity, OTHER_COLOUR) for b in mine],
            labels=[b.text for b in mine], show_labels=False), static=True)
        count += len(mine)
    ticks = np.linspace(0.0, end, 5)
    rec.log(entity(root, "axis"), rr.Points2D(
        [[t * scale, -1.4] for t in ticks], radii=[0.05], colors=[(90, 90, 90)],
        labels=[time_label(t) for t in ticks], show_labels=True), static=True)
    times = cursor_times([0.0, end_s] + [b.start_s for b in bars] + [b.finish_s for b in bars])
    strips = [[[t * scale, -0.6], [t * scale, len(robots) - 0.4]] for t in times]
    rec.send_columns(entity(root, "now"), indexes=[rr.TimeColumn(timeline, duration=times) for timeline in timelines],
                     columns=rr.LineStrips2D.columns(strips=strips, colors=[(20, 20, 20)] * len(times),
                                                     radii=[0.04] * len(times)).partition([1] * len(times)))
    return count


def cursor_times(times) -> np.ndarray:
    """Where the time cursor is drawn (s): the given times (every activity start and finish, 0 and the
    end), at most :data:`MAX_CURSOR_STEPS` of them (evenly thinned, the last kept)."""
    times = np.unique(np.asarray(times, dtype=float))
    if len(times) > MAX_CURSOR_STEPS:
        times = np.unique(np.concatenate([times[np.linspace(0, len(times) - 1, MAX_CURSOR_STEPS).astype(int)], [times[-1]]]))
    return times
