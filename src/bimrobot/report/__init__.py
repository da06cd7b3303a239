"""The build report: ``report.html`` and the key figures of ``README.md`` of a `bimrobot build` folder.

:func:`write_report` reads the build's outputs (:mod:`bimrobot.report.facts`), draws the assembled
building (:mod:`bimrobot.report.picture`) and writes one self-contained page (:mod:`bimrobot.report.page`:
Jinja2, Plotly with plotly.js inlined, the picture as a data: URL): model, fleet, site, the makespan
with its working-calendar dates (the site's work calendar), components by class and storey,
robots with utilisation, the critical path, what was assumed and what was refused or escalated, a
Gantt per robot and the components per state over time. :func:`readme_figures` gives the same key
figures as Markdown for the top of ``README.md``. A missing stage output is reported as unknown.
"""

from __future__ import annotations

import datetime as dt
import tempfile
from pathlib import Path


#: The report's file names in a build folder.
REPORT_HTML = "report.html"
BUILDING_PNG = "building.png"
#: The Python packages the page needs (the ``report`` extra) and how to install them.
REQUIRED = ("plotly", "jinja2")
INSTALL_HINT = "pip install 'bimrobot[report]' (plotly, jinja2)"


def missing_packages() -> list[str]:
    """The packages of :data:`REQUIRED` that cannot be imported."""
    import importlib.util

    return [name for name in REQUIRED if importlib.util.find_spec(name) is None]


def write_report(build_folder: str | Path, output: str | Path | None = None, *, start: str | dt.datetime | None = None,
                 calendar=None, model: str | Path | None = None, option: str = "-o") -> Path:
    """Write the report of the build in ``build_folder`` to ``output`` (default ``build_folder/report.html``);
    return its path. In the build folder itself the building's picture is also written as
    ``building.png`` (for README.md); elsewhere it is only inside the page.

    ``start``: date-time of the build's t = 0 s (default: the build's own, else today 08:00);
    ``calendar``: a :class:`bimrobot.schedule.ifc.WorkCalendar` (default: the build's site's);
    ``model``: the IFC file, when it is no longer where the build read it. Both files go through
    :mod:`bimrobot.core.io` (atomic; a file bimrobot did not write is never replaced). Raises InputError when ``build_folder`` is not a build folder or the report extra is missing."""
    output = Path(output) if output is not None else Path(build_folder) / REPORT_HTML
    _write(Path(build_folder), output, start, calendar, option, model)
    return output


def write_build_report(build_folder: str | Path, building=None) -> str:
    """For `bimrobot build`: write ``report.html`` and ``building.png`` into the build folder and return
    the key figures as Markdown for its README (one reading of the build for both). ``building``: the
    build's BuildingModel, already read (None: read from the build's IFC file)."""
    from bimrobot.report.figures import markdown

    folder = Path(build_folder)
    facts = _write(folder, folder / REPORT_HTML, None, None, "-o", building=building)
    return markdown(facts, BUILDING_PNG if (folder / BUILDING_PNG).is_file() else None)


def _write(folder: Path, output: Path, start, calendar, option: str, model=None, building=None):
    """Read the build, draw the building, write the page; the build's :class:`~bimrobot.report.facts.BuildFacts`."""
    from bimrobot.core import io
    from bimrobot.core.errors import InputError
    from bimrobot.report import page
    from bimrobot.report.facts import read_build
    from bimrobot.report.picture import draw_building

    missing = missing_packages()
    if missing:
        raise InputError(f"the build report needs {', '.join(missing)}: {INSTALL_HINT}")
    io.check_output(output, folder=False, option=option)
    facts = read_build(folder, start=start, calendar=calendar, model=model, building=building)
    in_build = output.resolve().parent == folder.resolve()
    with tempfile.TemporaryDirectory(prefix="bimrobot-report-") as scratch:
        png = Path(scratch) / BUILDING_PNG
        note = draw_building(folder, png, facts)
        picture = page.picture_bytes(png) if note is None else None
        if picture and in_build:
            with io.atomic_output_file(folder / BUILDING_PNG, option=option) as tmp:
                tmp.write_bytes(picture)
    html = page.render(facts, picture, note or "")
    with io.atomic_output_file(output, option=option) as tmp:
        tmp.write_text(html, encoding="utf-8")
    return facts


def readme_figures(build_folder: str | Path, *, start: str | dt.datetime | None = None,
                   calendar=None, building=None) -> str:
    """The key figures of the build as Markdown for the top of README.md (the same numbers as the page's),
    for a build without the page (the report extra missing). ``building``: the build's BuildingModel,
    already read (None: read from the build's IFC file)."""
    from bimrobot.report.facts import read_build
    from bimrobot.report.figures import markdown

    folder = Path(build_folder)
    facts = read_build(folder, start=start, calendar=calendar, building=building)
    page = REPORT_HTML if (folder / REPORT_HTML).is_file() else None
    return markdown(facts, BUILDING_PNG if (folder / BUILDING_PNG).is_file() else None, page)


__all__ = ["BUILDING_PNG", "REPORT_HTML", "readme_figures", "write_build_report", "write_report"]
