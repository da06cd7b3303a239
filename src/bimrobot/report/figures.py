"""The key figures of a build, in words: one list shown at the top of ``report.html`` and of ``README.md``.

Every number is the build's own, as its files hold it (the makespan and utilisation exactly as
``simulation/summary.json`` has them); what a file does not say is "unknown".
"""

from __future__ import annotations

import datetime as dt

from bimrobot.report.facts import BuildFacts

UNKNOWN = "unknown"


def seconds_text(seconds: float | None) -> str:
    """``1,642.433 s`` (the number as the build wrote it)."""
    return UNKNOWN if seconds is None else f"{seconds:,.3f}".rstrip("0").rstrip(".") + " s"


def work_text(seconds: float) -> str:
    """A duration of work in the largest sensible units: ``27 min 22 s``, ``7 h 05 min``."""
    seconds = round(seconds)
    hours, rest = divmod(seconds, 3600)
    minutes, secs = divmod(rest, 60)
    if hours:
        return f"{hours} h {minutes:02d} min"
    if minutes:
        return f"{minutes} min {secs:02d} s"
    return f"{secs} s"


def date_text(moment: dt.datetime) -> str:
    """``Mon 30 Nov 2026 07:27``."""
    return f"{moment:%a %d %b %Y %H:%M}"


def makespan_text(facts: BuildFacts) -> tuple[str, str]:
    """The makespan (as summary.json has it) and its working time and calendar dates."""
    if facts.makespan_s is None:
        return UNKNOWN, "no simulation/summary.json"
    days = facts.makespan_s / facts.calendar.day_s
    return (f"{seconds_text(facts.makespan_s)} of work",
            f"{work_text(facts.makespan_s)}, {days:,.2f} working days of {facts.calendar.day_s / 3600:g} h: "
            f"{date_text(facts.work_begins)} to {date_text(facts.finish)}")


def key_figures(facts: BuildFacts) -> list[tuple[str, str, str]]:
    """(label, figure, detail) triples, in the order a planner reads them."""
    built, total = len(facts.built()), len(facts.states)
    path = facts.critical_path
    return [
        ("model", facts.model, f"project {facts.project}" if facts.project else ""),
        ("fleet", facts.fleet, f"{len(facts.robots)} robots" if facts.robots else ""),
        ("site", facts.site, ""),
        ("start", date_text(facts.start), f"t = 0 s of the build; work calendar {facts.calendar}"),
        ("makespan", *makespan_text(facts)),
        ("components assembled", f"{built} of {total}" if facts.states else UNKNOWN, ""),
        ("activities", f"{len(facts.schedule)}" if facts.schedule else UNKNOWN, "simulation/schedule.csv"),
        ("fleet utilisation", UNKNOWN if facts.fleet_utilisation is None else f"{facts.fleet_utilisation:.2%}",
         "the robots' busy time over robots x makespan"),
        ("critical path", f"{len(path.activities)} activities" if path else UNKNOWN,
         critical_text(facts, count=False) if path else ""),
        ("RCAN run", *rcan_text(facts)),
        *([("planners compared", *compared)] if (compared := planners_text(facts)) else []),
    ]


def planners_text(facts: BuildFacts) -> tuple[str, str] | None:
    """When the build was planned by a portfolio (``--planner portfolio``: several planners run, the
    shortest plan kept): the plan it ran (``plan.json``'s ``portfolio_chosen``) with its makespan, and the
    market's gap to it; else None."""
    plan = facts.plan or {}
    makespans, best = plan.get("portfolio_makespans_s"), plan.get("portfolio_chosen")
    if not isinstance(makespans, dict) or best not in makespans:
        return None
    shortest = float(makespans[best])
    figure = f"{best} {shortest:,.3f} s, the shortest of {len(makespans)} plans"
    market = makespans.get("market")
    if market is None:
        return figure, "the market was not among them"
    gap = float(market) - shortest
    return figure, ("the market's plan is as short" if gap <= 0 else
                    f"the market's plan {float(market):,.3f} s, {gap:,.3f} s or {gap / shortest:.1%} longer")


def critical_text(facts: BuildFacts, count: bool = True) -> str:
    """The critical path in one sentence (``count``: starting with its number of activities)."""
    path = facts.critical_path
    if path is None:
        return UNKNOWN
    return ((f"{len(path.activities)} activities: " if count else "")
            + f"{seconds_text(round(path.work_s, 3))} of work and {seconds_text(round(path.waiting_s, 3))} of waiting; "
            f"with every robot always free the predecessors alone would take {seconds_text(round(path.logic_bound_s, 3))}")


def rcan_text(facts: BuildFacts) -> tuple[str, str]:
    """What RCAN executed: status; activities done, escalated and blocked."""
    rcan = facts.rcan
    if rcan is None:
        return UNKNOWN, "no rcan/report.json"
    done, escalated, blocked = (len(rcan.get(k) or []) for k in ("done", "escalations", "blocked"))
    detail = f"{done} activities done, {escalated} escalated, {blocked} blocked"
    executed, planned = rcan.get("makespan_s"), (facts.summary or {}).get("makespan_s")
    if executed is not None and planned:
        # one time model (bimrobot.sco.timing): RCAN's sim robots take the schedule's time, or say why not
        same = abs(float(executed) - float(planned)) <= 0.005 * float(planned)
        detail += (f"; executed in {float(executed):,.3f} s, the schedule's makespan" if same else
                   f"; executed in {float(executed):,.3f} s against the schedule's {float(planned):,.3f} s"
                   + (" (escalated or blocked work)" if escalated or blocked else
                      " (another RCAN backend, or a site rule the schedule does not hold, e.g. idle robots driving to the yard)"))
    return str(rcan.get("status", UNKNOWN)), detail


def markdown(facts: BuildFacts, picture: str | None = None, page: str | None = "report.html") -> str:
    """The key figures as the top of README.md: a table, where the whole report is (``page``; None:
    the page was not written, and how to get it), and the picture (``picture``, when drawn)."""
    lines = ["## Key figures", "", "| | |", "|---|---|"]
    for label, value, detail in key_figures(facts):
        lines.append(f"| {label} | {_cell(value + (f' ({detail})' if detail else ''))} |")
    by_class = ", ".join(f"{name} {built}/{total}" for name, (built, total) in facts.count_by(0).items())
    by_storey = ", ".join(f"{name} {built}/{total}" for name, (built, total) in facts.count_by(2).items())
    lines += [f"| assembled by class | {_cell(by_class or UNKNOWN)} |",
              f"| assembled by storey | {_cell(by_storey or UNKNOWN)} |"]
    robots = ", ".join(f"{r['robot']} {float(r['utilisation']):.2%}" for r in facts.robots)
    lines.append(f"| robots (utilisation) | {_cell(robots or UNKNOWN)} |")
    if page:
        lines += ["", f"The whole report, with the Gantt, the states over time and what was assumed: `{page}` "
                  "(one file, opens offline in any browser)."]
    else:
        lines += ["", "No `report.html` (the Gantt, the states over time, what was assumed): it needs the report "
                  "extra, `pip install 'bimrobot[report]'`, then `bimrobot report` on this folder."]
    if picture:
        lines += ["", f"![The building assembled]({picture})"]
    return "\n".join(lines) + "\n"


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")
