"""Assembly scenarios: the voxel site, its components and targets, loaded from YAML and validated.

A scenario is pure data. The grid is a box of unit cells indexed ``(x, y, z)`` with z up; ``z = 0`` is
the ground (foundations live there) and components occupy cells with ``z >= 1``. A component is a
straight run of ``length`` cells between two end nodes (node1 -> node2).

:func:`load_scenario` reads and validates a YAML file; :func:`benchmark_scenario` returns one of the 16
benchmark settings ("E1S1" .. "E4S4") shipped in ``settings/``. :func:`compile_scenario` turns a scenario
into the lookup tables the environment, the batched simulator and the planner share.

The pieces live in their own modules and are all importable from here: the parts, the :class:`Scenario`
and the file rules in :mod:`bimrobot.assembly.scenario_model`, the whole-scenario checks in
:mod:`bimrobot.assembly.scenario_rules`, the lookup tables and reset draws in :mod:`bimrobot.assembly.compiled`.
This module reads files and the shipped settings.
"""

from __future__ import annotations

import functools
from dataclasses import replace
from pathlib import Path
from typing import Any

from bimrobot.assembly.compiled import (MAX_LAYOUT_ATTEMPTS, CompiledScenario, compile_scenario,  # noqa: F401
                                        sample_layout, sample_prebuilt_slots)
from bimrobot.assembly.scenario_model import (COMPONENT_LENGTHS, MAX_COMPONENT_LENGTH, MAX_ENTRIES,  # noqa: F401
                                              MAX_GRID_CELLS, MAX_REWARD, MAX_TIME_LIMIT, Box, Cell, Component,
                                              ComponentEntry, Reward, Scenario, Target, TargetEntry, _mapping,
                                              beam_supports, lifted_pose, run_axis, run_cells)
from bimrobot.assembly.scenario_rules import validate_scenario
from bimrobot.core.config import check_keys, parse_yaml, read_yaml_file
from bimrobot.core.errors import InputError
from bimrobot.core.schema import At, keys_of, read_key

SETTINGS_DIR = Path(__file__).with_name("settings")
#: The benchmark settings ("E1S1" .. "E4S4"): the scenario files of ``settings/``, sorted. A file added
#: there is a setting (and, through :mod:`bimrobot.assembly`, a Gymnasium environment).
SETTINGS = sorted(path.stem for path in SETTINGS_DIR.glob("*.yaml"))


# --------------------------------------------------------------------------------------------- loading


def benchmark_scenario(setting: str) -> Scenario:
    """One of the 16 benchmark settings, e.g. ``benchmark_scenario("E2S2")``."""
    if setting not in SETTINGS:
        raise InputError(f"unknown assembly setting '{setting}': expected one of {', '.join(SETTINGS)}")
    return _cached_benchmark(setting)


@functools.lru_cache(maxsize=None)
def setting_time_limit(setting: str) -> int:
    """The episode length of a benchmark setting, steps: its file's ``time_limit``, read without building
    the scenario (Gymnasium's TimeLimit gets it when :mod:`bimrobot.assembly` registers the settings).

    Only the file's top-level ``time_limit:`` line is parsed (the whole file, 16 times, added about 0.1 s
    to ``import bimrobot.assembly``); a file without one is read whole."""
    if setting not in SETTINGS:
        raise InputError(f"unknown assembly setting '{setting}': expected one of {', '.join(SETTINGS)}")
    path = SETTINGS_DIR / f"{setting}.yaml"
    text = path.read_text(encoding="utf-8")
    line = next((n for n, line in enumerate(text.splitlines()) if line.startswith("time_limit:")), None)
    data = parse_yaml(text if line is None else "\n" * line + text.splitlines()[line], str(path))  # same line number
    return read_key(data, "time_limit", Scenario, At(str(path), path=True), 100)


@functools.lru_cache(maxsize=None)
def _cached_benchmark(setting: str) -> Scenario:
    return load_scenario(SETTINGS_DIR / f"{setting}.yaml")


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file (see docs/assembly.md for the format)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: scenario file not found")
    data = _read_yaml(path)
    if not isinstance(data, dict):
        raise InputError(f"{path}: a scenario file must be a YAML mapping")
    data.setdefault("name", path.stem)
    return parse_scenario(data, source=str(path))


def _read_yaml(path: Path) -> Any:
    return read_yaml_file(path, "scenario file")


def parse_scenario(data: dict[str, Any], source: str = "<memory>") -> Scenario:
    """Build a :class:`Scenario` from a plain mapping (the YAML content) and validate it.

    Each key is read by the rule :class:`Scenario` declares for it (:mod:`bimrobot.core.schema`), the grid
    first: every number is checked against its range as it is read, and every coordinate against the
    grid, so nothing grid-sized is allocated before the whole file is known to fit (:data:`MAX_GRID_CELLS`
    per axis). Messages name the file, the line (when the mapping comes from
    :func:`bimrobot.core.config.parse_yaml`) and the key.
    """
    import copy

    data = copy.deepcopy(data)  # keeps parse_yaml's line numbers (LineDict survives deepcopy)
    at = At(source, path=True)
    _mapping(data, replace(at, key="the file"))
    check_keys(data, keys_of(Scenario), source)
    at = replace(at, context=read_key(data, "grid", Scenario, at, [15, 15, 9]))
    defaults = {"time_limit": 100, "interchangeable": False, "layout": "fixed", "name": "scenario", "description": ""}
    values = {key: read_key(data, key, Scenario, at, defaults.get(key))
              for key in ("reward", "time_limit", "targets", "components", "interchangeable", "foundations", "layout",
                          "obstacles", "yard", "construction_area", "name", "description")}
    if values["interchangeable"] is True:  # every type (and, through the cells, every beam axis) is one group
        groups = (tuple(t.id for t in values["targets"] if t.type == ttype) for ttype in COMPONENT_LENGTHS)
        values["interchangeable"] = tuple(group for group in groups if len(group) > 1)
    scenario = Scenario(grid=at.context, source=source, **values)
    validate_scenario(scenario)
    return scenario
