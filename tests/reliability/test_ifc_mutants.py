"""Mutated real IFC files through ``bimrobot convert`` (reading and conversion): exit status 0 or 2, never
a traceback.

Each mutant is a real file of ../shared/data/ifc changed at the text level by one to three mutations
(numbers made huge, tiny, negative or zero; lines deleted; an entity id defined twice; references
pointed elsewhere or nowhere; attributes emptied; strings mangled; the file truncated; another schema
named). Hypothesis draws them, derandomized: CI runs the same 60 mutants every time,
BIMROBOT_CHAOS_LONG=1 runs 1,000. Every mutant is run to the end and the failures are listed together.
"""

from __future__ import annotations

import contextlib
import io
import logging
import random
import re
import tempfile
import traceback
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from .conftest import CHAOS_LONG, SHARED_IFC, tally  # noqa: E402

pytestmark = pytest.mark.chaos

MUTANTS = 1000 if CHAOS_LONG else 60
# small files first and more often: a mutant costs one conversion (0.4-3 s here)
SOURCES = [
    "column-extruded-solid.ifc",  # IFC4X3_ADD2, one extruded column
    "construction-scheduling-task.ifc",  # IFC4X3_ADD2 in inches, walls, slab, a work schedule
    "column-extruded-solid.ifc",
    "construction-scheduling-task.ifc",
    "IfcOpenHouse_IFC4.ifc",  # IFC4 in mm, a tiny house
    "ifcColumn.ifc",  # IFC4 (Revit), a column, plate, bolt and welds
]
HUGE = ["1.E20", "-1.E20", "1.E308", "-1.E308", "1.E-300", "0.", "-0.", "1.E200"]
SCHEMAS = ["IFC2X3", "IFC4", "IFC4X3_ADD2", "IFC4X3", "IFC5", "IFC2X2_FINAL", ""]
_ENTITY = re.compile(r"^#(\d+)\s*=", re.M)
_NUMBER = re.compile(r"(?<![#\w.])-?\d+\.\d*(?:E[-+]?\d+)?", re.I)
_REFERENCE = re.compile(r"#\d+")
_STRING = re.compile(r"'(?:[^']|'')*'")


def _data_lines(lines: list[str]) -> list[int]:
    return [i for i, line in enumerate(lines) if _ENTITY.match(line)]


def _replace_one(pattern: re.Pattern, line: str, rng: random.Random, new) -> str:
    """``line`` with one match of ``pattern`` (chosen by ``rng``) replaced by ``new(match text)``."""
    found = list(pattern.finditer(line))
    if not found:
        return line
    m = rng.choice(found)
    return line[: m.start()] + new(m.group(0)) + line[m.end():]


def _in_body(line: str, rng: random.Random, pattern: re.Pattern, new) -> str:
    """As :func:`_replace_one`, but never in the ``#id=`` part before the entity's name."""
    head, _, body = line.partition("=")
    return f"{head}={_replace_one(pattern, body, rng, new)}"


def mutate(text: str, operator: str, rng: random.Random) -> str:
    """``text`` (an IFC-SPF file) changed by one mutation ``operator``, its place chosen by ``rng``."""
    lines = text.splitlines(keepends=True)
    data = _data_lines(lines)
    if operator == "truncate":
        cut = rng.randrange(len(text) or 1)
        tail = "" if rng.random() < 0.5 else "\nENDSEC;\nEND-ISO-10303-21;\n"
        return text[:cut] + tail
    if operator == "schema":
        return re.sub(r"FILE_SCHEMA\s*\(\s*\('[^']*'", f"FILE_SCHEMA(('{rng.choice(SCHEMAS)}'", text, count=1)
    pattern = {"number": _NUMBER, "negative": _NUMBER, "reference": _REFERENCE, "string": _STRING}.get(operator)
    if pattern is not None:  # a line with something to change
        data = [j for j in data if pattern.search(lines[j].partition("=")[2])]
    if not data:  # an earlier mutation cut every entity away
        return text
    i = rng.choice(data)
    if operator == "number":
        lines[i] = _in_body(lines[i], rng, _NUMBER, lambda _: rng.choice(HUGE))
    elif operator == "negative":
        lines[i] = _in_body(lines[i], rng, _NUMBER, lambda n: n[1:] if n.startswith("-") else f"-{n}")
    elif operator == "delete":
        del lines[i]
    elif operator == "duplicate-id":
        other = lines[rng.choice(data)]
        lines.insert(i + 1, f"{lines[i].split('=', 1)[0]}={other.split('=', 1)[1]}")
    elif operator == "reference":
        ids = [_ENTITY.match(lines[j]).group(1) for j in data]
        lines[i] = _in_body(lines[i], rng, _REFERENCE, lambda _: f"#{rng.choice(ids + ['999999'])}")
    elif operator == "null":
        lines[i] = _in_body(lines[i], rng, re.compile(r"(?<=[(,])[^(),]+(?=[,)])"), lambda _: "$")
    elif operator == "string":
        lines[i] = _in_body(lines[i], rng, _STRING, lambda _: rng.choice(["''", "'\\X\\00'", "'a''b'", "'" + "x" * 5000 + "'"]))
    return "".join(lines)


OPERATORS = ["number", "negative", "delete", "duplicate-id", "reference", "null", "string", "truncate", "schema"]


def _convert(path: Path, out: Path) -> tuple[object, str]:
    """``bimrobot convert path -o out`` in this process: (exit status, or the uncaught exception, and stderr)."""
    from bimrobot.cli import main

    errors = io.StringIO()
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(errors):
            status = main(["convert", str(path), "-o", str(out)])
    except SystemExit as exit:  # argparse, or a deliberate exit
        status = exit.code
    except Exception as exc:  # a traceback: the failure this suite looks for
        status = f"{type(exc).__name__}: {exc}".splitlines()[0][:300] + " at " + _where(exc)
    return status, errors.getvalue()


def _where(exc: BaseException) -> str:
    frame = traceback.extract_tb(exc.__traceback__)[-1]
    return f"{Path(frame.filename).name}:{frame.lineno} ({frame.name})"


@pytest.mark.slow
@pytest.mark.timeout(7200 if CHAOS_LONG else 600)
def test_mutated_ifc_files_give_exit_status_0_or_2_and_no_traceback():
    sources = {name: (SHARED_IFC / name) for name in dict.fromkeys(SOURCES)}
    missing = [str(p) for p in sources.values() if not p.exists()]
    if missing:
        pytest.skip(f"{missing[0]} is absent: the shared test data lives beside the repository, not in it")
    texts = {name: path.read_text(encoding="latin-1") for name, path in sources.items()}
    failures: list[str] = []
    trials = 0

    @settings(max_examples=MUTANTS, derandomize=True, deadline=None, database=None, print_blob=False,
              suppress_health_check=list(HealthCheck))
    @given(source=st.sampled_from(SOURCES),
           mutations=st.lists(st.tuples(st.sampled_from(OPERATORS), st.integers(0, 2**32 - 1)), min_size=1, max_size=3))
    def one_mutant(source, mutations):
        nonlocal trials
        trials += 1
        text = texts[source]
        for operator, seed in mutations:
            text = mutate(text, operator, random.Random(seed))
        with tempfile.TemporaryDirectory(prefix="bimrobot-mutant-") as folder:
            path = Path(folder) / f"mutant-{source}"
            path.write_text(text, encoding="latin-1")
            status, stderr = _convert(path, Path(folder) / "out")
        if status not in (0, 2) or "Traceback" in stderr:
            failures.append(f"{source} {mutations}: {status} {stderr[-300:]!r}")

    logging.disable(logging.WARNING)  # the mutants' warnings would flood the log
    try:
        one_mutant()
    finally:
        logging.disable(logging.NOTSET)
        tally("ifc mutants", trials, len(failures))
    assert not failures, f"{len(failures)} of {trials} mutants failed:\n" + "\n".join(failures[:20])


def _one_wall_moved(tmp_path, x: str) -> Path:
    """construction-scheduling-task.ifc with wall #1's placement ``x`` inches along x (skips when absent)."""
    source = SHARED_IFC / "construction-scheduling-task.ifc"
    if not source.exists():
        pytest.skip(f"{source} is absent: the shared test data lives beside the repository, not in it")
    text = source.read_text(encoding="latin-1")
    moved = text.replace("#359= IFCCARTESIANPOINT((0.,0.,6.));", f"#359= IFCCARTESIANPOINT(({x},0.,6.));")
    assert moved != text
    path = tmp_path / "moved.ifc"
    path.write_text(moved, encoding="latin-1")
    return path


@pytest.mark.parametrize("x, sentence", [
    # issue 35: the occupancy map was sized from it (OverflowError after the "far from origin" warning)
    ("1.E20", "IfcWall 'Wall #1' (26tmERtwL8G8UQn5BoglEh) lies 2.54e+18 m from the origin, farther than the 2e+07 m"),
    # 10 km away: on Earth, but no site is that large (the site layout and maps would be sized from it)
    ("4.E5", "the elements span 1.02e+04 m, more than the 10000 m a site may: IfcWall 'Wall #1' (26tmERtwL8G8UQn5BoglEh) lies farthest"),
])
def test_an_element_placed_absurdly_far_is_refused_in_one_sentence(tmp_path, x, sentence):
    path = _one_wall_moved(tmp_path, x)
    status, stderr = _convert(path, tmp_path / "pkg")
    assert status == 2, stderr
    line = stderr.strip().splitlines()[-1]
    assert line.startswith(f"bimrobot convert: error: {path}: {sentence}"), line
    assert "Traceback" not in stderr and not (tmp_path / "pkg").exists()
    tally("ifc mutants")


def test_an_occupancy_map_too_large_to_draw_is_refused_in_one_sentence():
    # the maps' own guard, for extents the reader lets through (a 10 km site at 5 cm: 4e10 cells)
    from bimrobot.core.errors import InputError
    from bimrobot.export.gazebo.navmap import grid_frame

    with pytest.raises(InputError, match=r"the occupancy maps would be 2e\+05 x 2e\+05 cells \(x 0 \.\. 10000 m, "
                                         r"y 0 \.\. 10000 m plus 1 m around it, at 0\.05 m per cell\), more than the 1e\+08"):
        grid_frame([[0.0, 0.0], [10_000.0, 10_000.0]], 1.0, 0.05)
    with pytest.raises(InputError, match="not finite"):
        grid_frame([[0.0, 0.0], [float("inf"), 1.0]], 1.0, 0.05)
    assert grid_frame([[0.0, 0.0], [10.0, 5.0]], 1.0, 0.05) == ((-1.0, -1.0), (140, 240))
    tally("ifc mutants")


# Mutants the long form found (BIMROBOT_CHAOS_LONG=1, 1,000 mutants: 8 tracebacks of these two kinds),
# kept as cases: references of the wrong type, which IfcOpenShell does not check
FOUND = [
    # IfcShapeRepresentation.Items -> an IfcUnitAssignment: AttributeError 'RepresentationType'
    ("column-extruded-solid.ifc", [("reference", 595)], "an entity refers to an IfcUnitAssignment where an entity with 'RepresentationType' belongs"),
    # the column's type -> an IfcDirection (an id deleted, another defined twice): AttributeError 'HasPropertySets'
    ("column-extruded-solid.ifc", [("delete", 6488623), ("duplicate-id", 865), ("delete", 865)],
     "IfcColumn #210 refers to an IfcDirection where an entity with 'HasPropertySets' belongs"),
]


@pytest.mark.parametrize("source, mutations, sentence", FOUND)
def test_mutants_the_long_form_found_are_refused_in_one_sentence(tmp_path, source, mutations, sentence):
    if not (SHARED_IFC / source).exists():
        pytest.skip(f"{SHARED_IFC / source} is absent: the shared test data lives beside the repository, not in it")
    text = (SHARED_IFC / source).read_text(encoding="latin-1")
    for operator, seed in mutations:
        text = mutate(text, operator, random.Random(seed))
    path = tmp_path / "mutant.ifc"
    path.write_text(text, encoding="latin-1")
    status, stderr = _convert(path, tmp_path / "pkg")
    assert status == 2 and "Traceback" not in stderr, stderr
    assert stderr.strip().splitlines()[-1].startswith(f"bimrobot convert: error: {path}: {sentence} (a reference of the wrong type")
    tally("ifc mutants")
