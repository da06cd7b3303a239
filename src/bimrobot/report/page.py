"""``report.html``: the build report as one self-contained page (Jinja2; Plotly charts, plotly.js inlined).

No server and no network: the CSS, plotly.js and the building's picture (a PNG as a data: URL) are
all in the file, which opens from disk in any browser.
"""

from __future__ import annotations

import base64
import re
from collections import Counter
from pathlib import Path

import bimrobot.report.charts as charts  # by module path: the package (report/__init__) imports this page
import bimrobot.report.figures as figures
from bimrobot.report.facts import INSTALLED, BuildFacts

TEMPLATE = "report.html.j2"
#: " (7 parts)" in a reason a product was skipped: left out, so that one reason counts all its products.
PARTS = re.compile(r" \(\d+ parts?\)")


def render(facts: BuildFacts, picture_png: bytes | None, picture_note: str = "") -> str:
    """The page's HTML for ``facts``; ``picture_png``: the assembled building (None: ``picture_note``
    says why there is none)."""
    import jinja2

    from bimrobot.core import io

    environment = jinja2.Environment(
        loader=jinja2.FileSystemLoader(Path(__file__).with_name("templates")),
        autoescape=jinja2.select_autoescape(default=True), undefined=jinja2.StrictUndefined,
        trim_blocks=True, lstrip_blocks=True,
    )
    return environment.get_template(TEMPLATE).render(
        signature=io.signature("build report"), facts=facts, figures=figures.key_figures(facts),
        plotly_js=charts.plotly_js(),
        gantt=charts.figure_div(charts.gantt_figure(facts), charts.GANTT_ID) if facts.schedule else "",
        states_chart=charts.figure_div(charts.states_figure(facts), charts.STATES_ID) if facts.states else "",
        picture=base64.b64encode(picture_png).decode("ascii") if picture_png else None, picture_note=picture_note,
        by_class=facts.count_by(0), by_storey=facts.count_by(2),
        critical_text=figures.critical_text(facts), critical_rows=critical_rows(facts),
        assumed=assumed(facts), refused=refused(facts), escalations=(facts.rcan or {}).get("escalations") or [],
    )


def critical_rows(facts: BuildFacts) -> list[dict]:
    """The critical path's activities as table rows (calendar start and finish, seconds of work)."""
    if facts.critical_path is None:
        return []
    rows = {row["Identification"]: row for row in facts.schedule}
    out = []
    for activity in facts.critical_path.activities:
        row = rows[activity]
        ifc_class, name, _ = facts.components.get(row["GlobalId"], ("", "", ""))
        out.append({"id": activity, "task": row["Activity"], "robot": row["Robot"],
                    "component": " ".join(p for p in (ifc_class, name, row["GlobalId"]) if p),
                    "start": f"{facts.date(row['Start']):%a %d %b %H:%M:%S}",
                    "finish": f"{facts.date(row['Finish'], finish=True):%a %d %b %H:%M:%S}",
                    "work": f"{row['Finish'] - row['Start']:,.1f}"})
    return out


def _listed(items, limit: int = 8) -> str:
    items = [str(i) for i in items]
    more = f" and {len(items) - limit} more" if len(items) > limit else ""
    return ", ".join(items[:limit]) + more


def _named(facts: BuildFacts, component: str) -> str:
    """``IfcBeam 'B12' 3$KOO...``: a component's class and name before its GlobalId, where known."""
    ifc_class, name, _ = facts.components.get(component, ("", "", ""))
    return " ".join(part for part in (ifc_class, f"'{name}'" if name else "", component) if part)


def assumed(facts: BuildFacts) -> list[tuple[str, str]]:
    """What the build took as given, with where it came from: (label, text)."""
    unknown = figures.UNKNOWN
    counts = facts.package.get("counts") or {}
    entries = facts.package.get("converted") or []
    smart = facts.summary.get("smart_components") or {}
    rule = (facts.summary.get("unknown_weight") or facts.package.get("unknown_weight") or {}).get("rule")
    sources = counts.get("weight_sources") or {}
    suspect = sum(1 for e in entries if isinstance(e, dict) and e.get("weight_suspect"))
    rows = [
        ("calendar", f"{facts.calendar}, {facts.calendar.day_s / 3600:g} h a working day, from {facts.calendar_source}; "
                     f"t = 0 s at {figures.date_text(facts.start)}"),
        ("site", facts.site),
        ("weights by source", _listed([f"{source}: {n} elements" for source, n in sources.items()]) or unknown),
        ("total mass", f"{mass:,.1f} kg" if isinstance(mass := counts.get("total_mass_kg"), (int, float)) else unknown),
        ("unknown weights", f"{rule}" if rule else unknown),
        ("weights the model gives that are implausible (kept as given)", f"{suspect} elements" if entries else unknown),
    ]
    if smart:
        inferred = smart.get("inferred_joints") or []
        source = str(smart.get("connection_source", unknown))
        rows += [
            ("joints", f"{smart.get('joints', unknown)} joints ({source}"
                       + (")" if "inferred" in source else f"; {len(inferred)} inferred from geometry)")),
            ("assembly points", f"{smart.get('assembly_points', unknown)} at {smart.get('connection_nodes', unknown)} "
                                f"connection nodes; methods: {', '.join(smart.get('assembly_methods') or []) or unknown}"),
            ("connectors", str(smart.get("role_rule") or unknown)),
            ("work of others (prebuilt)", f"{len(smart.get('prebuilt') or [])} components"),
            ("assembly units", f"{smart.get('assembly_units', unknown)}"),
        ]
    if facts.summary:
        summary = facts.summary
        rows += [("market", f"evaluator {summary.get('evaluator', unknown)}, work {summary.get('work', unknown)}")]
    return rows


def refused(facts: BuildFacts) -> list[tuple[str, str]]:
    """What was left out, not built, broke down or was escalated: (label, text); empty when nothing."""
    rows = []
    skipped = [s for s in facts.package.get("skipped") or [] if isinstance(s, dict)]
    if skipped:
        reasons = Counter(f"{s.get('ifc_class')}: {PARTS.sub('', str(s.get('reason')))}" for s in skipped)
        listed = _listed(f"{n} x {reason}" for reason, n in reasons.most_common())
        rows.append(("products without a model of their own in the package", f"{len(skipped)} ({listed})"))
    smart = facts.summary.get("smart_components") or {}
    for key, label in (("unconnected_components", "components without a joint"),
                       ("duplicates_not_built", "duplicates not built"),
                       ("components_without_weight", "components without a weight"),
                       ("assemblies_with_parts_without_weight", "assemblies with parts without a weight")):
        if smart.get(key):
            rows.append((label, f"{len(smart[key])} ({_listed(_named(facts, c) for c in smart[key])})"))
    if smart.get("internal_connections_not_built"):
        rows.append(("joints inside assembly units (not built on site)", str(smart["internal_connections_not_built"])))
    not_built = [c for c in facts.states if facts.final_state(c) != INSTALLED]
    if not_built:
        listed = _listed(_named(facts, c) for c in not_built)
        rows.append(("components not assembled at the end of the simulation", f"{len(not_built)} ({listed})"))
    if facts.summary.get("aborted_activities"):
        rows.append(("activities aborted (breakdowns)", str(facts.summary["aborted_activities"])))
    for breakdown in facts.summary.get("breakdowns") or []:
        rows.append(("breakdown", f"{breakdown.get('robot')} at {breakdown.get('time_s')} s "
                                  f"(repair {breakdown.get('repair_s')} s)"))
    rcan = facts.rcan or {}
    if rcan.get("escalations"):
        rows.append(("RCAN escalated", f"{len(rcan['escalations'])} activities (below)"))
    if rcan.get("blocked"):
        rows.append(("RCAN blocked", f"{len(rcan['blocked'])} activities ({_listed(rcan['blocked'])})"))
    for warning in facts.package.get("warnings") or []:
        rows.append(("package warning", str(warning)))
    return rows


def picture_bytes(path: Path) -> bytes | None:
    try:
        return Path(path).read_bytes()
    except OSError:
        return None
