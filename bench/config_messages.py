"""What the configuration readers say about broken files, recorded to compare two versions of the code.

    .venv/bin/python bench/config_messages.py record before.json        # on the old code (a worktree)
    .venv/bin/python bench/config_messages.py record after.json
    .venv/bin/python bench/config_messages.py compare before.json after.json

Every value of a valid file (a version-2 fleet: the built-in site-crane; a version-1 fleet; an RCAN
capability table; a site; the E1S1 scenario) is replaced in turn by each hostile value of
tests/reliability/test_config_mutants.py, or deleted, and the file is loaded as its command loads it.
Recorded per file: ``OK`` and what loaded, ``ERR`` and the message, or ``EXC`` and the exception (a bug).
``compare`` prints the files whose outcome differs and the count; a refactoring of the readers (issue 37's
one schema layer) should change none. Record on the old code with ``PYTHONPATH=<worktree>/src``.
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import logging
import sys
from dataclasses import replace
from importlib import resources
from pathlib import Path
from tempfile import TemporaryDirectory

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests.reliability, for its hostile values

V1_FLEET = """name: old
robots:
  - {name: T1, kind: transport, speed: 0.5, carry_load: 300, platform_size: [4.0, 1.0], load_time: 10, home: [1, 2]}
  - {name: P1, kind: positioning, speed: 1.0, payload: 300, reach: 4.0, time_per_node: 60}
  - {name: A1, kind: assembly, speed: 1.0, reach: 4.0, time_per_point: 30, methods: [bolt]}
"""
CAPABILITIES = """robot_types:
  base: {activities: [move_to_component, transport]}
  arm: {activities: [position_for_picking_up, position_for_installing, pick_up, install]}
robots:
  r1: {types: [base, arm], payload_kg: 500, reach_m: 3.0, speed_m_s: 1.2, arm_speed_m_s: 0.4,
       handling_s: {pick_up: 3, install: 5}, gripper_opening_m: [0.02, 0.3], home: [1.0, 2.0, 0.0],
       footprint_m: [1.0, 0.8]}
"""
SITE = """yard: [[12.5, 4.0], [12.5, 6.0]]
robot_home: [[18.5, 4.0]]
construction_area: [[3.0, 1.5], [10.5, 8.0]]
model_offset: [0.0, 0.0]
idle_robots: yard
assembly_points_per_joint: 4
work_calendar: {days: [Monday], hours: ['07:00', '16:00']}
"""


def _load(kind: str, path: Path) -> str:
    if kind == "site":
        from bimrobot.site.site import load_site, site_to_dict

        return json.dumps(site_to_dict(load_site(path)), sort_keys=True)
    if kind == "scenario":
        from bimrobot.assembly.scenario import load_scenario

        s = load_scenario(path)
        return repr((s.grid, s.time_limit, s.reward, s.components, s.targets, s.obstacles, s.yard, s.layout))
    from bimrobot.site.fleet import load_fleet

    robots = [replace(r, rcan_activities=r.rcan_activities and tuple(sorted(r.rcan_activities)))  # a frozenset prints
              for r in load_fleet(path).robots]                                                  # in hash order
    return repr(robots)


def record(out: str) -> None:
    import yaml

    from bimrobot.core.errors import InputError
    from tests.reliability.test_config_mutants import HOSTILE, _parent, _paths

    logging.disable(logging.CRITICAL)
    files = {"fleet-v2": ("fleet", resources.files("bimrobot.site").joinpath("fleets/site-crane.yaml").read_text()),
             "fleet-v1": ("fleet", V1_FLEET), "capabilities": ("fleet", CAPABILITIES), "site": ("site", SITE),
             "scenario": ("scenario", resources.files("bimrobot.assembly").joinpath("settings/E1S1.yaml").read_text())}
    results: dict[str, list[str]] = {}
    with TemporaryDirectory() as folder:
        path = Path(folder) / "file.yaml"
        for family, (kind, text) in files.items():
            document, rows = yaml.safe_load(text), []
            for where in (p for p in _paths(document) if p):
                for value in [*HOSTILE, "<deleted>"]:
                    mutant = copy.deepcopy(document)
                    parent = _parent(mutant, where)
                    if value == "<deleted>":
                        del parent[where[-1]]
                    else:
                        parent[where[-1]] = value
                    path.write_bytes(yaml.safe_dump(mutant, allow_unicode=True).encode("utf-8", "surrogatepass"))
                    try:
                        with contextlib.redirect_stderr(io.StringIO()):
                            rows.append("OK " + _load(kind, path))
                    except InputError as exc:
                        rows.append("ERR " + str(exc).replace(folder, "<tmp>"))
                    except Exception as exc:  # noqa: BLE001 - a traceback is what this looks for
                        rows.append(f"EXC {type(exc).__name__}: {exc}")
            results[family] = rows
            print(f"{family}: {len(rows)} files, {sum(r.startswith('ERR') for r in rows)} refused, "
                  f"{sum(r.startswith('EXC') for r in rows)} exceptions")
    Path(out).write_text(json.dumps(results, indent=0))


def compare(before: str, after: str) -> int:
    old, new = (json.loads(Path(p).read_text()) for p in (before, after))
    total = differ = 0
    for family in old:
        for index, (a, b) in enumerate(zip(old[family], new.get(family, []))):
            total += 1
            if a != b:
                differ += 1
                print(f"{family} #{index}\n  before: {a[:300]}\n  after:  {b[:300]}")
    print(f"{total} files compared, {differ} differ")
    return 1 if differ else 0


if __name__ == "__main__":
    command = sys.argv[1:2]
    if command == ["record"] and len(sys.argv) == 3:
        record(sys.argv[2])
    elif command == ["compare"] and len(sys.argv) == 4:
        raise SystemExit(compare(sys.argv[2], sys.argv[3]))
    else:
        raise SystemExit(__doc__)
