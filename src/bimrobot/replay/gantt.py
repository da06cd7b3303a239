"""The schedule's Gantt chart in the replay: one row of bars per robot, a time cursor over it.

Drawn as 2D boxes (Rerun's ``Boxes2D`` in a 2D view), so that each activity is a bar from its start
to its finish, coloured by what the robot does, with its text on hover: x is time, scaled so that the
whole build spans :func:`chart_width` units; y is the robot's row (first robot on top, 1 unit per
row). The bars are static (the whole plan at a glance); ``/gantt/now``, a vertical line on
``sim_time``, marks the current time.
"""

from __future__ import annotations

import numpy as np

from bimrobot.replay.inputs import BuildRecord

#: Bar colours by activity (RGB): those of the simulation's gantt.png (bimrobot.coordination.report).
ACTIVITY_COLOURS = {"transport": (76, 114, 176), "position": (221, 132, 82), "assemble": (85, 168, 104)}
OTHER_COLOUR = (120, 120, 120)
#: Half height of a bar (row units) and the width of the robot-name column left of x = 0.
BAR_HALF_HEIGHT = 0.35
NAME_COLUMN = 6.0
#: Most positions of the time cursor (it is drawn at each activity start and finish, thinned to this).
MAX_CURSOR_STEPS = 2000


def chart_width(rows: int) -> float:
    """Width of the time axis in chart units: wide enough to read, for any number of rows."""
    return max(16.0, 3.0 * rows)


def bounds(record: BuildRecord) -> tuple[list[float], list[float]]:
    """(x range, y range) of the whole chart, names column and time labels included (chart units)."""
    rows = max(len(record.robots), 1)
    return [-NAME_COLUMN - 0.2, chart_width(rows) + 0.5], [-1.6, rows + 0.2]


def time_label(seconds: float) -> str:
    """A time as a planner reads it: seconds, minutes, hours or days."""
    for unit, size in (("d", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:,.1f} {unit}"
    return f"{seconds:,.0f} s"


def log_gantt(rec, record: BuildRecord) -> int:
    """Log the bars, the robot names, the time ticks and the cursor; returns the number of bars."""
    import rerun as rr

    from bimrobot.replay.record import TIMELINE, entity

    robots = list(record.robots)
    width, end = chart_width(len(robots)), max(record.makespan, 1e-9)
    scale = width / end
    bars = 0
    for row, name in enumerate(robots):
        mine = [r for r in record.schedule if r["Robot"] == name]
        # a label is drawn below its point: the point a little above the row's middle
        rec.log(entity("gantt", "names", name), rr.Points2D(
            [[-0.55 * NAME_COLUMN, row - 0.3]], radii=[0.01], colors=[(255, 255, 255)], labels=[name],
            show_labels=True), static=True)
        if not mine:
            continue
        starts = np.array([r["Start"] for r in mine]) * scale
        finishes = np.array([r["Finish"] for r in mine]) * scale
        rec.log(entity("gantt", name), rr.Boxes2D(
            mins=np.column_stack([starts, np.full(len(mine), row - BAR_HALF_HEIGHT)]),
            sizes=np.column_stack([np.maximum(finishes - starts, 1e-3 * width), np.full(len(mine), 2 * BAR_HALF_HEIGHT)]),
            colors=[ACTIVITY_COLOURS.get(r["Activity"], OTHER_COLOUR) for r in mine],
            labels=[f"{name}: {r['Activity']} {r['Name']} ({r['Start']:,.1f}-{r['Finish']:,.1f} s)" for r in mine],
            show_labels=False), static=True)
        bars += len(mine)
    ticks = np.linspace(0.0, end, 5)
    rec.log(entity("gantt", "axis"), rr.Points2D(
        [[t * scale, -1.4] for t in ticks], radii=[0.05], colors=[(90, 90, 90)],
        labels=[time_label(t) for t in ticks], show_labels=True), static=True)
    times = cursor_times(record)
    strips = [[[t * scale, -0.6], [t * scale, len(robots) - 0.4]] for t in times]
    rec.send_columns(entity("gantt", "now"), indexes=[rr.TimeColumn(TIMELINE, duration=times)],
                     columns=rr.LineStrips2D.columns(strips=strips, colors=[(20, 20, 20)] * len(times),
                                                     radii=[0.04] * len(times)).partition([1] * len(times)))
    return bars


def cursor_times(record: BuildRecord) -> np.ndarray:
    """Where the time cursor is drawn (s): every activity start and finish, 0 and the end, at most
    :data:`MAX_CURSOR_STEPS` of them (evenly thinned)."""
    times = np.unique([0.0, record.makespan] + [r["Start"] for r in record.schedule] + [r["Finish"] for r in record.schedule])
    if len(times) > MAX_CURSOR_STEPS:
        times = np.unique(np.concatenate([times[np.linspace(0, len(times) - 1, MAX_CURSOR_STEPS).astype(int)], [times[-1]]]))
    return times
