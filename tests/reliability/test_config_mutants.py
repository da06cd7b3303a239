"""Mutated configuration files through the real loaders: exit status 0 or 2, never a traceback.

Five families, each from a valid file: a fleet (the built-in ``site-crane``), a site, the built-in RCAN
capability table, an assembly scenario (setting E1S1) and a schedule CSV. A mutant is the file changed
by one to three mutations drawn by Hypothesis (derandomized: CI runs the same 100 mutants per family
every time, BIMROBOT_CHAOS_LONG=1 runs 1,000): a value replaced by a hostile one (huge, tiny, NaN,
infinite, negative, zero, empty, a long or unicode string, control characters, a list, a mapping, a
boolean, null), a key or item deleted, an unknown key added, an item duplicated; at the text level a
line duplicated (a duplicate key), the file truncated, a tab or a byte-order mark or a NUL inserted.

Each mutant is read as its command reads it: loaded (exit 0) or refused with one InputError of one
line (exit 2); anything else is a failure. What loads is checked as well: every robot quantity within
its physical range; a schedule written back reads back the same. Every mutant runs to the end and the
failures are listed together; each family prints ``chaos config <family>: N trials, M failures``, and
all of them ``chaos config: N trials, M failures``.
"""

from __future__ import annotations

import contextlib
import io
import math
import random
import traceback
from importlib import resources
from pathlib import Path

import pytest
import yaml

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from bimrobot.core.errors import InputError  # noqa: E402

from .conftest import CHAOS_LONG, tally  # noqa: E402

pytestmark = pytest.mark.chaos

MUTANTS = 1000 if CHAOS_LONG else 100

HOSTILE = [0, -1, -0.0, 1e308, -1e308, 1e-300, float("nan"), float("inf"), float("-inf"), 10**30, 2**63, 0.5, 7, "",
           "x" * 10_000, "ünïcødé €", "\x00\r\n\x1b[31m", "1e400", "-", "nan", "A1", True, False, None, [], {},
           [1, 2, 3], [[0, 0]], {"a": 1}, ["x", None], {"x": [1, 2], "y": [3, 4]}]
"""Values a mutation puts in place of another one."""

SITE = """\
yard: [[12.5, 4.0], [12.5, 6.0], [12.5, 8.0]]
robot_home: [[18.5, 4.0], [18.5, 6.0]]
construction_area: [[3.0, 1.5], [10.5, 8.0]]
idle_robots: [[20.0, 2.0]]
model_offset: [0.0, 0.0]
"""

SCHEDULE = """\
Identification,Name,PredefinedType,Activity,GlobalId,Robot,Start,Finish,Duration,Predecessors,TargetX,TargetY,TargetZ,Storey
A1,Transport C1,LOGISTIC,transport,COL,Transport 1,0,100,100,,1.0,2.0,0.025,L1
A2,Position C1,INSTALLATION,position,COL,Positioning 1,100,220,120,A1,1.0,2.0,0.025,L1
A3,Assemble PLATE:COL,CONSTRUCTION,assemble,COL,Assembly 1,220,280,60,A2,1.0,2.0,0.025,L1
A4,Transport B1,LOGISTIC,transport,BEAM,Transport 1,100,200,100,,3.5,0,4.0,L2
"""

CELLS = ["", "nan", "inf", "-1", "1e400", "1e9", "1000000001", "0", "A1", "A4", "COL", "transport", "weld", "ü",
         "\r", "\x00", "a b", '"', ",", "1e308", "-0", "A1 A2", "A9", "LOGISTIC", "INSTALLATION ", "x" * 200_000]
"""Cells a schedule mutation writes."""


def _builtin(package: str, name: str) -> str:
    return resources.files(package).joinpath(name).read_text(encoding="utf-8")


def _paths(node, prefix=()) -> list[tuple]:
    """Every path (keys and indices) to a value in the parsed YAML ``node``, ``()`` for the root."""
    found = [prefix]
    if isinstance(node, dict):
        for key, value in node.items():
            found += _paths(value, prefix + (key,))
    elif isinstance(node, list):
        for index, value in enumerate(node):
            found += _paths(value, prefix + (index,))
    return found


def _parent(document, path):
    for step in path[:-1]:
        document = document[step]
    return document


def mutate_yaml(text: str, operator: str, rng: random.Random) -> str:
    """``text`` (YAML) changed by one mutation ``operator`` at a place chosen by ``rng``."""
    lines = text.splitlines(keepends=True)
    if operator == "duplicate-line" and lines:
        i = rng.randrange(len(lines))
        lines.insert(i + 1, lines[i])
        return "".join(lines)
    if operator == "truncate":
        return text[: rng.randrange(len(text) + 1)]
    if operator == "tab" and lines:
        i = rng.randrange(len(lines))
        lines[i] = "\t" + lines[i]
        return "".join(lines)
    if operator == "bom":
        return "\ufeff" + text
    if operator == "nul":
        cut = rng.randrange(len(text) + 1)
        return text[:cut] + "\x00" + text[cut:]
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError:  # an earlier text mutation broke it: leave it broken
        return text
    paths = [p for p in _paths(document) if p]
    if not paths:
        document = rng.choice(HOSTILE)
    else:
        path = rng.choice(paths)
        parent, last = _parent(document, path), path[-1]
        if operator == "replace":
            parent[last] = rng.choice(HOSTILE)
        elif operator == "delete":
            del parent[last]
        elif operator == "add-key" and isinstance(parent, dict):
            parent[rng.choice(["extra", "Speed", "robots ", "names", "ünknown"])] = rng.choice(HOSTILE)
        elif operator == "duplicate-item" and isinstance(parent, list):
            parent.insert(last, parent[last])
        elif operator == "wrap":
            parent[last] = [parent[last]]
    return yaml.safe_dump(document, allow_unicode=True, sort_keys=False)


def mutate_csv(text: str, operator: str, rng: random.Random) -> str:
    """``text`` (a schedule CSV) changed by one mutation ``operator`` at a place chosen by ``rng``."""
    lines = text.splitlines(keepends=True)
    if not lines:
        return text
    i = rng.randrange(len(lines))
    cells = lines[i].rstrip("\r\n").split(",")
    if operator == "replace":
        cells[rng.randrange(len(cells))] = rng.choice(CELLS)
    elif operator == "delete":
        del cells[rng.randrange(len(cells))]
    elif operator == "add-key":
        cells.insert(rng.randrange(len(cells) + 1), rng.choice(CELLS))
    elif operator in ("duplicate-item", "duplicate-line"):
        lines.insert(i, lines[i])
        return "".join(lines)
    elif operator == "truncate":
        return text[: rng.randrange(len(text) + 1)]
    elif operator in ("bom", "tab", "nul"):
        return {"bom": "\ufeff", "tab": "\t", "nul": "\x00"}[operator] + text
    elif operator == "wrap":
        cells[rng.randrange(len(cells))] = '"' + rng.choice(CELLS).replace('"', '""') + '"'
    lines[i] = ",".join(cells) + "\n"
    return "".join(lines)


OPERATORS = ["replace", "replace", "replace", "delete", "add-key", "duplicate-item", "wrap", "duplicate-line",
             "truncate", "tab", "bom", "nul"]


def _check_fleet(path: Path) -> None:
    from bimrobot.site.fleet import PLATFORM_RANGE_M, RANGES, load_fleet

    fleet = load_fleet(path)
    for robot in fleet.robots:
        for key, (low, high, _) in RANGES.items():
            value = getattr(robot, key)
            if value or key in ("speed_m_s",):  # keys a kind does not use stay 0
                assert low <= value <= high, f"{robot.name}.{key} = {value!r} outside [{low}, {high}]"
        for size in robot.platform_m or ():
            assert size == 0 or PLATFORM_RANGE_M[0] <= size <= PLATFORM_RANGE_M[1], robot.platform_m


def _check_site(path: Path) -> None:
    from bimrobot.site.site import load_site

    site = load_site(path)
    for x, y in [*site.yard, *site.robot_home, *site.construction_area]:
        assert math.isfinite(x) and math.isfinite(y), site


def _check_capabilities(path: Path) -> None:
    from bimrobot.rcan.generation import load_capabilities

    table = load_capabilities(path)
    for robot in table.robots:  # payload and reach default to 0 (none), the speed to 1 m/s
        assert all(math.isfinite(v) and v >= 0 for v in (robot.payload_kg, robot.reach_m)), robot
        assert math.isfinite(robot.speed_m_s) and robot.speed_m_s > 0, robot


def _check_scenario(path: Path) -> None:
    from bimrobot.assembly.scenario import load_scenario

    load_scenario(path)


def _check_schedule(path: Path) -> None:
    from bimrobot.schedule.csv import load_schedule_csv, write_schedule_csv

    schedule = load_schedule_csv(path)
    again = load_schedule_csv(write_schedule_csv(schedule, path.with_name("written.csv")))
    assert [(a.id, a.global_id, a.start, a.finish, a.predecessors, a.target) for a in again] == \
        [(a.id, a.global_id, a.start, a.finish, a.predecessors, a.target) for a in schedule]


FAMILIES = {
    "fleet": (lambda: _builtin("bimrobot.site", "fleets/site-crane.yaml"), "fleet.yaml", mutate_yaml, _check_fleet),
    "site": (lambda: SITE, "site.yaml", mutate_yaml, _check_site),
    "capabilities": (lambda: _builtin("bimrobot.site", "fleets/rcan-robots.yaml"), "robots.yaml", mutate_yaml, _check_capabilities),
    "scenario": (lambda: _builtin("bimrobot.assembly", "settings/E1S1.yaml"), "E1S1.yaml", mutate_yaml, _check_scenario),
    "schedule": (lambda: SCHEDULE, "schedule.csv", mutate_csv, _check_schedule),
}


def run_mutant(check, path: Path) -> str | None:
    """Load ``path`` with ``check``: None when it loads (exit 0) or is refused in one line (exit 2), else
    what went wrong (a traceback's last line and where, a message of several lines, a failed check)."""
    errors = io.StringIO()
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(errors):
            check(path)
    except InputError as exc:
        message = str(exc)
        if "\n" in message or "\r" in message or not message.strip():
            return f"InputError not in one line: {message[:300]!r}"
        return None
    except Exception as exc:  # noqa: BLE001 - a traceback: the failure this suite looks for
        frame = traceback.extract_tb(exc.__traceback__)[-1]
        return f"{type(exc).__name__}: {str(exc)[:300]!r} at {Path(frame.filename).name}:{frame.lineno} ({frame.name})"
    if "Traceback" in errors.getvalue():
        return f"a traceback on stderr: {errors.getvalue()[-300:]!r}"
    return None


@pytest.mark.parametrize("family", list(FAMILIES))
def test_mutated_configuration_files_load_or_are_refused_in_one_sentence(family, tmp_path):
    base, name, mutate, check = FAMILIES[family]
    original = base()
    assert run_mutant(check, _write(tmp_path / "base", name, original)) is None  # the unmutated file loads
    failures: list[str] = []
    trials = 0

    @settings(max_examples=MUTANTS, derandomize=True, deadline=None, database=None, print_blob=False,
              suppress_health_check=list(HealthCheck))
    @given(mutations=st.lists(st.tuples(st.sampled_from(OPERATORS), st.integers(0, 2**32 - 1)), min_size=1, max_size=3))
    def one_mutant(mutations):
        nonlocal trials
        trials += 1
        text = original
        for operator, seed in mutations:
            text = mutate(text, operator, random.Random(seed))
        problem = run_mutant(check, _write(tmp_path / f"m{trials}", name, text))
        if problem:
            failures.append(f"{mutations}: {problem}")

    try:
        one_mutant()
    finally:
        tally(f"config {family}", trials, len(failures))
        tally("config", trials, len(failures))
    assert not failures, f"{len(failures)} of {trials} {family} mutants failed:\n" + "\n".join(failures[:20])


def _write(folder: Path, name: str, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    return path
