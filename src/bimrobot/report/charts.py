"""The report's interactive charts (Plotly): the Gantt per robot and the components per state over time.

Both share a working-time axis: x is seconds of work from the start of the build (the schedule's own
numbers), labelled with the site's calendar dates of the
:class:`~bimrobot.schedule.ifc.WorkCalendar`, so nights and days off take no room and a bar's
length is its working time. (Plotly's date-axis rangebreaks would do the same but draw no horizontal
bar with a base: plotly.js 3.) Each chart is returned as an HTML ``<div>`` without plotly.js (the page
inlines plotly.js once).
"""

from __future__ import annotations

import datetime as dt

from bimrobot.report.facts import STATES, BuildFacts, state_counts

#: Bar colours by task kind (the simulation's gantt.png colours).
TASK_COLOURS = {"transport": "#4C72B0", "position": "#DD8452", "assemble": "#55A868"}
#: State colours, OnYard (grey) to Assembled (green).
STATE_COLOURS = dict(zip(STATES, ("#bdbdbd", "#9ecae1", "#6baed6", "#3182bd", "#fdae6b", "#e6550d",
                                  "#c7b3e0", "#9467bd", "#2ca02c")))
#: Element id of the Gantt's div (the browser test finds the chart by it).
GANTT_ID = "gantt"
#: Gap between the Gantt's rows, as a fraction of a row.
BAR_GAP = 0.25
STATES_ID = "states"


#: Tick spacings of the time axis (seconds of work).
TICK_STEPS_S = (10, 30, 60, 120, 300, 600, 900, 1800, 3600, 7200, 10800)


def time_axis(facts: BuildFacts, end_s: float, ticks: int = 10) -> dict:
    """A Plotly x axis over ``[0, end_s]`` seconds of work with about ``ticks`` ticks labelled by
    calendar: clock times within a day (the date where a day begins), or working days for longer builds."""
    day = facts.calendar.day_s
    end_s = max(end_s, 1.0)
    values: list[float] = []
    if end_s > 2 * day:
        every = max(1, round(end_s / day / ticks))
        values = [k * day for k in range(0, int(end_s // day) + 1, every)]
        texts = [f"{facts.date(v):%a %d %b}" for v in values]
    else:
        step = next((s for s in TICK_STEPS_S if end_s / s <= ticks), TICK_STEPS_S[-1])
        values = [k * step for k in range(int(end_s // step) + 1)]
        texts, shown_day = [], None
        for v in values:
            moment = facts.date(v)
            texts.append(f"{moment:%H:%M}" + ("" if moment.date() == shown_day else f"<br>{moment:%a %d %b}"))
            shown_day = moment.date()
    return {"tickmode": "array", "tickvals": values, "ticktext": texts, "range": [0, end_s * 1.01], "zeroline": False,
            "title": {"text": f"working time ({facts.calendar}; nights and days off left out)", "font": {"size": 12}}}


def day_breaks(facts: BuildFacts, end_s: float, most: int = 60) -> list[dict]:
    """Dashed vertical lines where one working day ends and the next begins (seconds of work), at most ``most``."""
    first = _first_day_left(facts)
    breaks = []
    moment = first
    while moment < end_s and len(breaks) < most:
        breaks.append({"type": "line", "xref": "x", "yref": "paper", "x0": moment, "x1": moment, "y0": 0, "y1": 1,
                       "line": {"color": "#777", "width": 1, "dash": "dash"}, "layer": "between"})
        moment += facts.calendar.day_s
    return breaks


def _first_day_left(facts: BuildFacts) -> float:
    """Seconds of work left in the first working day after the start (to the second), found from the calendar's
    date arithmetic alone (bisection: the last second of work that still ends on the first day)."""
    day = facts.work_begins.date()
    low, high = 0.0, facts.calendar.day_s
    while high - low > 1e-3:
        middle = (low + high) / 2
        if facts.date(middle).date() == day:
            low = middle
        else:
            high = middle
    return float(round(high))  # a line on a chart: to the second


def gantt_figure(facts: BuildFacts):
    """One horizontal bar per activity of the schedule, one row per robot, coloured by task kind; the
    critical path outlined in black. Hover: activity, component (class, name, GlobalId, storey),
    the calendar start and finish and the duration in seconds of work."""
    import plotly.graph_objects as go

    robots = [r["robot"] for r in facts.robots]
    robots += sorted({_robot(row) for row in facts.schedule} - set(robots))
    end_s = max((row["Finish"] for row in facts.schedule), default=0.0)
    figure = go.Figure()
    for task, colour in TASK_COLOURS.items():
        rows = [row for row in facts.schedule if row["Activity"] == task]
        if not rows:
            continue
        starts = [facts.date(row["Start"]) for row in rows]
        finishes = [facts.date(row["Finish"], finish=True) for row in rows]
        figure.add_trace(go.Bar(
            name=task, orientation="h", y=[_robot(row) for row in rows],
            base=[row["Start"] for row in rows], x=[row["Finish"] - row["Start"] for row in rows],
            marker={"color": colour, "line": {"color": "#fff", "width": 0.5}},
            customdata=[_hover(facts, row, s, f) for row, s, f in zip(rows, starts, finishes)],
            hovertemplate="%{customdata}<extra></extra>",
        ))
    figure.update_layout(
        barmode="overlay", bargap=BAR_GAP, height=160 + 34 * max(len(robots), 1),
        margin={"l": 10, "r": 10, "t": 30, "b": 10},
        legend={"orientation": "h", "yanchor": "bottom", "y": 1.0, "x": 0},
        yaxis={"categoryorder": "array", "categoryarray": robots, "autorange": "reversed", "title": None},
        xaxis=time_axis(facts, end_s),
        template="plotly_white", shapes=day_breaks(facts, end_s) + _critical_outlines(facts, robots),
    )
    return figure


def _robot(row: dict) -> str:
    return row["Robot"] or "(no robot)"


def _critical_outlines(facts: BuildFacts, robots: list[str]) -> list[dict]:
    """A black frame around each bar of the critical path (layout shapes, so the bars stay one per
    activity), the first one with a legend entry."""
    if facts.critical_path is None:
        return []
    rows = {row["Identification"]: row for row in facts.schedule}
    half = (1 - BAR_GAP) / 2  # half a bar's height, in rows
    shapes = []
    for activity in facts.critical_path.activities:
        row, index = rows[activity], robots.index(_robot(rows[activity]))
        shapes.append({"type": "rect", "xref": "x", "yref": "y", "x0": row["Start"], "x1": row["Finish"],
                       "y0": index - half, "y1": index + half, "line": {"color": "#000", "width": 2},
                       "fillcolor": "rgba(0,0,0,0)", "layer": "above", "name": "critical path",
                       "legendgroup": "critical path", "showlegend": not shapes})
    return shapes


def _hover(facts: BuildFacts, row: dict, start: dt.datetime, finish: dt.datetime) -> str:
    ifc_class, name, storey = facts.components.get(row["GlobalId"], ("", "", ""))
    component = " ".join(part for part in (ifc_class, f"'{name}'" if name else "") if part)
    on_path = facts.critical_path is not None and row["Identification"] in facts.critical_path.activities
    critical = "<br><b>on the critical path</b>" if on_path else ""
    return (f"<b>{_html(row['Identification'])} {_html(row['Activity'])}</b> by {_html(row['Robot'])}<br>"
            f"{_html(component)} {_html(row['GlobalId'])}<br>storey {_html(storey)}<br>"
            f"{start:%a %d %b %H:%M:%S} - {finish:%a %d %b %H:%M:%S} ({row['Finish'] - row['Start']:,.1f} s of work)"
            f"{critical}")


def _html(text) -> str:
    import html

    return html.escape(str(text or ""))


def states_figure(facts: BuildFacts):
    """Components per state over time, stacked (a step chart: counts change at the state changes)."""
    import plotly.graph_objects as go

    times, series = state_counts(facts.states)
    end_s = max(times[-1] if times else 0.0, facts.makespan_s or 0.0)
    if times and times[-1] < end_s:  # the counts hold until the end of the build
        times = times + [end_s]
        series = {state: counts + counts[-1:] for state, counts in series.items()}
    dates = [f"{facts.date(t):%a %d %b %H:%M:%S}" for t in times]
    figure = go.Figure()
    for state, counts in series.items():
        if not any(counts):
            continue
        figure.add_trace(go.Scatter(
            name=state, x=times, y=counts, mode="lines",
            line={"shape": "hv", "width": 0.5, "color": STATE_COLOURS.get(state)},
            stackgroup="states", customdata=dates,
            hovertemplate=f"%{{customdata}}<br>{state}: %{{text}} components<extra></extra>", text=counts,
        ))
    figure.update_layout(
        height=340, margin={"l": 10, "r": 10, "t": 30, "b": 10}, hovermode="closest",
        legend={"orientation": "h", "yanchor": "bottom", "y": 1.0, "x": 0}, template="plotly_white",
        xaxis=time_axis(facts, end_s), yaxis={"title": "components", "rangemode": "tozero"}, shapes=day_breaks(facts, end_s),
    )
    return figure


def figure_div(figure, div_id: str) -> str:
    """The figure as an HTML ``<div>`` with its script, plotly.js left out (the page inlines it once)."""
    import plotly.io as pio

    return pio.to_html(figure, include_plotlyjs=False, full_html=False, div_id=div_id,
                       config={"displaylogo": False, "responsive": True})


def plotly_js() -> str:
    """plotly.js itself, to inline in the page (no network needed to show the charts)."""
    from plotly.offline import get_plotlyjs

    return get_plotlyjs()
