"""The build report (report.html, the README's key figures) of a steel-frame build: a page that needs no
network, a Gantt with one bar per scheduled activity, key figures equal to summary.json's, dates on the
work calendar, a critical path that explains the makespan, and a page that still renders when a stage's
output is missing."""

from __future__ import annotations

import base64
import csv
import datetime as dt
import json
import re
import shutil
from html.parser import HTMLParser

import numpy as np
import pytest

from bimrobot.cli import main

from .conftest import START

#: Attributes through which a page loads a resource.
RESOURCE_ATTRIBUTES = {"src", "href", "data", "poster", "srcset", "action", "formaction", "background"}


class _Resources(HTMLParser):
    """Every resource reference of a page: (tag, attribute, value), CSS url(...) and @import included."""

    def __init__(self):
        super().__init__()
        self.references: list[tuple[str, str, str]] = []
        self.scripts_with_src = 0
        self._tag = None

    def handle_starttag(self, tag, attrs):
        self._tag = tag
        for name, value in attrs:
            if name in RESOURCE_ATTRIBUTES and value:
                self.references.append((tag, name, value))
            if name == "style" and value:
                self.references += [(tag, "style", url) for url in _css_urls(value)]
        self.scripts_with_src += tag == "script" and any(name == "src" for name, _ in attrs)

    def handle_data(self, data):
        if self._tag == "style":
            self.references += [("style", "css", url) for url in _css_urls(data)]


def _css_urls(css: str) -> list[str]:
    return re.findall(r"url\(\s*['\"]?([^'\")]+)", css) + re.findall(r"@import\s+['\"]([^'\"]+)", css)


def _page(folder) -> str:
    return (folder / "report.html").read_text(encoding="utf-8")


def _plot_data(html: str, div_id: str) -> list[dict]:
    """The traces Plotly is given for the div ``div_id`` (the JSON of its ``Plotly.newPlot`` call)."""
    match = re.search(r'Plotly\.newPlot\(\s*"' + re.escape(div_id) + r'",\s*', html)
    assert match, f"no Plotly chart {div_id!r} in the page"
    data, _ = json.JSONDecoder().raw_decode(html, match.end())
    return data


def _numbers(value) -> list[float]:
    """A Plotly data array: a JSON list, or a typed array ({dtype, bdata}) as plotly.py 6+ writes numpy arrays."""
    if isinstance(value, dict) and "bdata" in value:
        return np.frombuffer(base64.b64decode(value["bdata"]), dtype=np.dtype(value["dtype"])).tolist()
    return list(value)


def _schedule(folder) -> list[dict]:
    with open(folder / "simulation" / "schedule.csv", newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def _readme_figures(folder) -> dict[str, str]:
    """The README's key-figure table: label -> value."""
    text = (folder / "README.md").read_text(encoding="utf-8")
    table = text.split("## Key figures", 1)[1].split("\n\n", 2)[1]
    return {cells[1].strip(): cells[2].strip() for cells in (line.split("|") for line in table.splitlines()[2:])}


def test_page_is_one_file_that_loads_nothing_from_the_network(frame_build):
    html = _page(frame_build)
    assert "written by bimrobot" in html[:65536]  # the output policy recognises it as bimrobot's
    parser = _Resources()
    parser.feed(html)
    remote = [ref for ref in parser.references if re.match(r"\s*(https?:)?//", ref[2], re.I)]
    assert remote == [], f"the page would load these from the network: {remote[:5]}"
    assert parser.scripts_with_src == 0, "every script is inlined"
    assert "Plotly.newPlot" in html and "window.Plotly" in html  # plotly.js itself is in the page
    assert any(ref[2].startswith("data:image/png;base64,") for ref in parser.references), "the building's picture is inlined"
    assert (frame_build / "building.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_gantt_has_one_bar_per_activity_at_its_robot_and_times(frame_build):
    schedule = _schedule(frame_build)
    traces = _plot_data(_page(frame_build), "gantt")
    bars = [(robot, start, width, task) for trace in traces
            for robot, start, width in zip(trace["y"], _numbers(trace["base"]), _numbers(trace["x"]))
            for task in [trace["name"]]]
    assert len(bars) == len(schedule) > 0
    expected = sorted((row["Robot"], float(row["Start"]), float(row["Finish"]) - float(row["Start"]), row["Activity"])
                      for row in schedule)
    for got, want in zip(sorted(bars), expected):
        assert got[0] == want[0] and got[3] == want[3]
        assert got[1] == pytest.approx(want[1], abs=1e-6) and got[2] == pytest.approx(want[2], abs=1e-6)
    hover = " ".join(" ".join(trace["customdata"]) for trace in traces)
    assert all(row["GlobalId"] in hover for row in schedule), "hovering a bar names its component"


def test_key_figures_are_summary_json_s(frame_build):
    summary = json.loads((frame_build / "simulation" / "summary.json").read_text())
    states = json.loads((frame_build / "simulation" / "states.json").read_text())
    rcan = json.loads((frame_build / "rcan" / "report.json").read_text())
    figures = _readme_figures(frame_build)

    makespan = re.match(r"([\d,.]+) s of work", figures["makespan"])
    assert float(makespan.group(1).replace(",", "")) == summary["makespan_s"]
    utilisation = re.match(r"([\d.]+)%", figures["fleet utilisation"])
    assert float(utilisation.group(1)) / 100 == pytest.approx(summary["fleet_utilisation"], abs=5e-7)
    assert figures["activities"].startswith(f"{summary['activities']} ")
    assembled = sum(history[-1][1] == "Assembled" for history in states.values())
    assert figures["components assembled"] == f"{assembled} of {len(states)}" == f"{len(states)} of {len(states)}"
    assert figures["RCAN run"].startswith(f"completed ({len(rcan['done'])} activities done, 0 escalated")
    assert figures["fleet"].startswith("fleet2")
    for robot in summary["robots"]:
        assert f"{robot['robot']} {robot['utilisation']:.2%}" in figures["robots (utilisation)"]
    # the page shows the same figures as the README
    html = _page(frame_build)
    for label in ("makespan", "fleet utilisation", "components assembled", "activities"):
        card = re.search(rf'data-figure="{label}"><div class="label">[^<]*</div><div class="value">([^<]*)</div>', html)
        assert card and figures[label].startswith(card.group(1)), label


def test_dates_are_on_the_work_calendar(frame_build):
    """Started on a Friday at 15:50, the build works 10 minutes, stops at 16:00 and goes on on Monday at 07:00."""
    makespan = json.loads((frame_build / "simulation" / "summary.json").read_text())["makespan_s"]
    start = dt.datetime.fromisoformat(START)
    friday_left = (dt.datetime(2027, 3, 5, 16) - start).total_seconds()
    assert 600 < makespan < 600 + 9 * 3600  # the frame's build fits in one more working day
    finish = dt.datetime(2027, 3, 8, 7) + dt.timedelta(seconds=makespan - friday_left)
    figures = _readme_figures(frame_build)
    assert figures["start"].startswith("Fri 05 Mar 2027 15:50")
    assert f"Fri 05 Mar 2027 15:50 to {finish:%a %d %b %Y %H:%M}" in figures["makespan"]
    assert "Monday-Friday 07:00-16:00" in figures["start"]
    assert json.loads((frame_build / "build.json").read_text())["start"] == START


def test_critical_path_explains_the_makespan(frame_build):
    from bimrobot.report.facts import read_build

    facts = read_build(frame_build, with_model=False)
    rows = {row["Identification"]: row for row in facts.schedule}
    chain = [rows[a] for a in facts.critical_path.activities]
    assert chain[0]["Start"] == 0.0
    assert chain[-1]["Finish"] == pytest.approx(facts.makespan_s, abs=1e-6)
    for before, after in zip(chain, chain[1:]):
        assert before["Identification"] in after["Predecessors"] or before["Robot"] == after["Robot"]
        assert before["Finish"] <= after["Start"] + 0.01
    path = facts.critical_path
    assert path.work_s + path.waiting_s == pytest.approx(facts.makespan_s, abs=1e-6)
    assert 0 < path.logic_bound_s <= facts.makespan_s  # robots, not the predecessors, set this build's length


def test_page_renders_without_rcan_and_package(frame_build, tmp_path, capsys):
    copy = tmp_path / "build"
    shutil.copytree(frame_build, copy, ignore=shutil.ignore_patterns("*.rrd", "*.ttl", "*.ifc", "rcan", "package"))
    assert main(["report", str(copy)]) == 0
    html = _page(copy)
    assert "no rcan/report.json" in html and "rcan/report.json (absent)" in html
    assert "No picture: the build has no package" in html
    bars = sum(len(trace["y"]) for trace in _plot_data(html, "gantt"))
    assert bars == len(_schedule(copy))


def test_a_portfolio_build_shows_the_markets_gap_to_the_shortest_plan(frame_build, tmp_path):
    """Issue 36: the market's gap to the best planner, when one ran. The frame's simulation planned
    again by the portfolio (every planner run, the shortest plan kept, plan.json): the README's key
    figures and the page name the shortest plan and how much longer the market's was; a build planned
    by the market alone shows no such figure."""
    from bimrobot.report import readme_figures

    assert "planners compared" not in _readme_figures(frame_build)
    copy = tmp_path / "build"
    shutil.copytree(frame_build, copy, ignore=shutil.ignore_patterns("*.rrd", "*.ttl", "simulation"))
    assert main(["simulate", str(frame_build.parent / "frame.ifc"), "--fleet", "fleet2", "--planner", "portfolio",
                 "-o", str(copy / "simulation"), "--no-gantt", "--no-progress"]) == 0
    makespans = json.loads((copy / "simulation" / "plan.json").read_text())["portfolio_makespans_s"]
    best = min(makespans, key=makespans.get)
    gap = makespans["market"] - makespans[best]
    line = next(line for line in readme_figures(copy).splitlines() if line.startswith("| planners compared |"))
    assert f"{best} {makespans[best]:,.3f} s, the shortest of {len(makespans)} plans" in line
    assert (f"the market's plan {makespans['market']:,.3f} s, {gap:,.3f} s or {gap / makespans[best]:.1%} longer" in line
            if gap > 0
            else "the market's plan is as short" in line)
    assert main(["report", str(copy)]) == 0
    assert 'data-figure="planners compared"' in _page(copy)


def test_report_command_refuses_what_is_not_a_build_and_keeps_foreign_files(frame_build, tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 2
    error = capsys.readouterr().err
    assert "is not a `bimrobot build` output folder" in error and "Traceback" not in error
    foreign = tmp_path / "mine.html"
    foreign.write_text("<p>my own page</p>")
    assert main(["report", str(frame_build), "-o", str(foreign)]) == 2
    assert "bimrobot did not write" in capsys.readouterr().err
    assert foreign.read_text() == "<p>my own page</p>"
    assert main(["report", str(frame_build), "--start", "Friday"]) == 2
    assert "--start 'Friday' is not an ISO date-time" in capsys.readouterr().err


def test_critical_path_counts_the_wait_of_a_late_start():
    """D waits 15 s after its predecessor A (a crane's set-up the schedule does not show): the path is
    A, D with 15 s of work and 15 s of waiting; the predecessors alone take 15 s."""
    from bimrobot.report.facts import critical_path

    def row(ident, robot, start, finish, predecessors=()):
        return {"Identification": ident, "Robot": robot, "Start": start, "Finish": finish, "Predecessors": list(predecessors)}

    schedule = [row("A", "r1", 0, 10), row("B", "r2", 0, 5), row("C", "r1", 10, 20, ["B"]), row("D", "r2", 25, 30, ["A"])]
    path = critical_path(schedule)
    assert path.activities == ["A", "D"]
    assert (path.work_s, path.waiting_s, path.logic_bound_s) == (15, 15, 15)
    assert (path.logic_edges, path.robot_edges) == (2, 2)


def test_without_the_report_extra_the_build_still_gives_its_key_figures(frame_build, tmp_path, monkeypatch, capsys):
    """plotly missing (as bimrobot.report sees it): the build's README keeps the figures and says how to get
    the page; `bimrobot report` refuses in one sentence naming the install command."""
    from bimrobot import pipeline, report

    copy = tmp_path / "build"
    shutil.copytree(frame_build, copy, ignore=shutil.ignore_patterns("*.rrd", "*.ttl", "report.html", "building.png"))
    monkeypatch.setattr(report, "missing_packages", lambda: ["plotly"])
    figures = pipeline._build_report(copy)
    assert "pip install 'bimrobot[report]'" in capsys.readouterr().err
    assert not (copy / "report.html").exists()
    summary = json.loads((copy / "simulation" / "summary.json").read_text())
    makespan = re.search(r"\| makespan \| ([\d,.]+) s of work", figures)
    assert float(makespan.group(1).replace(",", "")) == summary["makespan_s"]
    assert "No `report.html`" in figures and "pip install 'bimrobot[report]'" in figures
    assert main(["report", str(copy)]) == 2
    assert "the build report needs plotly: pip install 'bimrobot[report]'" in capsys.readouterr().err


def test_dates_follow_the_calendar_of_the_build_s_site(frame_build, tmp_path):
    """A site working Monday-Saturday 06:00-18:00 (its site.yaml): the Friday 15:50 start finishes the same day."""
    copy = tmp_path / "build"
    shutil.copytree(frame_build, copy, ignore=shutil.ignore_patterns("*.rrd", "*.ttl", "*.ifc"))
    site = (copy / "site.yaml").read_text()
    assert "work_calendar:" in site
    site = site[:site.index("work_calendar:")] + (
        "work_calendar: {days: [Monday, Tuesday, Wednesday, Thursday, Friday, Saturday], hours: ['06:00', '18:00']}\n")
    (copy / "site.yaml").write_text(site)
    assert main(["report", str(copy)]) == 0
    makespan = json.loads((copy / "simulation" / "summary.json").read_text())["makespan_s"]
    finish = dt.datetime.fromisoformat(START) + dt.timedelta(seconds=makespan)
    html = _page(copy)
    assert f"Fri 05 Mar 2027 15:50 to {finish:%a %d %b %Y %H:%M}" in html
    assert "Monday-Saturday 06:00-18:00" in html and "site.yaml of this build" in html
