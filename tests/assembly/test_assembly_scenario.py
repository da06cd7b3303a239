"""Scenario data and YAML validation: the 16 settings load, bad files get one sentence naming the entry."""

from __future__ import annotations

import copy
import re
from pathlib import Path

import pytest
import yaml

from bimrobot.assembly.scenario import (
    SETTINGS,
    SETTINGS_DIR,
    benchmark_scenario,
    load_scenario,
    parse_scenario,
    setting_time_limit,
)
from bimrobot.core.errors import InputError


def e2s2_data() -> dict:
    return yaml.safe_load((SETTINGS_DIR / "E2S2.yaml").read_text())


def write(tmp_path: Path, data: dict, name: str = "site.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def test_sixteen_settings_match_the_specification():
    counts = {"E1": (2, 1), "E2": (3, 0), "E3": (8, 0), "E4": (13, 0)}
    limits = {"E1": 100, "E2": 100, "E3": 300, "E4": 600}
    assert len(SETTINGS) == 16 and SETTINGS == sorted(p.stem for p in SETTINGS_DIR.glob("*.yaml"))  # the folder is the registry
    for setting in SETTINGS:
        sc = benchmark_scenario(setting)
        env, scen = setting[:2], setting[2:]
        assert (len(sc.handled), len(sc.prebuilt)) == counts[env]
        assert sc.time_limit == limits[env] == setting_time_limit(setting)  # what Gymnasium's TimeLimit is given
        assert sc.layout == ("random" if scen in ("S1", "S3") else "fixed")
        assert bool(sc.interchangeable) == (scen != "S1")
        assert bool(sc.obstacles) == (scen == "S4")
        assert (sc.reward.r0, sc.reward.epsilon, sc.reward.completion_bonus) == (-1.0, 15, 10.0)
        # columns always come before beams in handling order
        types = [c.type for c in sc.handled]
        assert types == sorted(types, key=lambda t: t != "column")


def test_env4_targets_and_beam_supports():
    sc = benchmark_scenario("E4S2")
    beam11 = sc.target("beam11")
    assert beam11.cells == [(6, 9, 4), (7, 9, 4), (8, 9, 4)]
    from bimrobot.assembly.scenario import beam_supports

    assert set(beam_supports(sc, beam11)) == {"col9", "col2"}
    assert set(beam_supports(sc, sc.target("beam7"))) == {"col4", "col5"}


def test_custom_yaml_round_trip(tmp_path):
    sc = load_scenario(write(tmp_path, e2s2_data()))
    assert sc.name == "E2S2"
    assert [c.id for c in sc.handled] == ["col2", "col3", "beam1"]
    assert sc.handled[0].start == ((7, 3, 1), (4, 3, 1))


def bad(tmp_path, mutate, match: str):
    data = e2s2_data()
    mutate(data)
    with pytest.raises(InputError, match=match) as err:
        load_scenario(write(tmp_path, data))
    message = str(err.value)
    assert "site.yaml" in message and "\n" not in message
    return message


def test_overlapping_start_poses_name_both_components(tmp_path):
    def mutate(d):
        d["components"][1]["start"] = [[6, 3, 1], [3, 3, 1]]  # col3 onto col2's cells

    bad(tmp_path, mutate, r"components\.col3: start overlaps components\.col2 at \(4, 3, 1\)")


def test_target_outside_grid(tmp_path):
    def mutate(d):
        d["targets"]["beam1"]["cells"] = [[9, 13, 4], [9, 15, 4]]

    bad(tmp_path, mutate, r"site.yaml line \d+: targets\.beam1\.cells: cell \(9, 15, 4\) is outside the grid")


def test_unknown_component_type(tmp_path):
    def mutate(d):
        d["components"][2]["type"] = "slab"

    bad(tmp_path, mutate, r"components\.beam1: unknown component type 'slab'")


def test_unsupported_beam(tmp_path):
    def mutate(d):
        d["targets"]["beam1"]["cells"] = [[9, 10, 3], [9, 12, 3]]  # one below the column tops

    bad(tmp_path, mutate, r"targets\.beam1: unsupported beam")


def test_beam_handled_before_its_columns(tmp_path):
    def mutate(d):
        d["components"] = [d["components"][2], d["components"][0], d["components"][1]]

    bad(tmp_path, mutate, r"components\.beam1: .*columns must come before the beams they support")


def test_impossible_random_layout(tmp_path):
    def mutate(d):
        d["layout"] = "random"
        d["yard"] = [{"x": [3, 3], "y": [3, 3]}]  # one node1 cell for three components

    bad(tmp_path, mutate, r"impossible random layout")


def test_pick_up_that_cannot_get_free(tmp_path):
    def mutate(d):
        d["obstacles"] = [{"x": [7, 7], "y": [3, 3], "z": [2, 8]}]  # above col2's node1

    bad(tmp_path, mutate, r"components\.col2: the crane cannot lift it")


def test_unknown_key_and_bad_yaml(tmp_path):
    bad(tmp_path, lambda d: d.update(colour="red"), r"unknown key 'colour'")
    path = tmp_path / "broken.yaml"
    path.write_text("grid: [15, 15\n")
    with pytest.raises(InputError, match=r"broken.yaml line \d+: not valid YAML"):
        load_scenario(path)
    with pytest.raises(InputError, match="scenario file not found"):
        load_scenario(tmp_path / "missing.yaml")


def test_unknown_setting():
    with pytest.raises(InputError, match="unknown assembly setting 'E5S1'"):
        benchmark_scenario("E5S1")


def test_parse_does_not_mutate_input():
    data = e2s2_data()
    before = copy.deepcopy(data)
    parse_scenario(data)
    assert data == before


def test_custom_scenario_with_explicit_groups_and_a_prebuilt_column(tmp_path):
    """A user's own site: Env2's frame with one prebuilt column and an explicit slot group."""
    from bimrobot.assembly.env import AssemblyEnv
    from bimrobot.assembly.planner import plan

    data = e2s2_data()
    data["name"] = "two-slot"
    data["interchangeable"] = [["col2", "col3"]]
    data["components"][0] = {"id": "col2", "type": "column", "target": "col2", "prebuilt": True}
    sc = load_scenario(write(tmp_path, data))
    assert [c.id for c in sc.handled] == ["col3", "beam1"] and sc.is_stochastic
    env = AssemblyEnv(scenario=sc)
    returns = set()
    for seed in range(8):
        env.reset(seed=seed)
        best = plan(env)
        total = sum(env.step(a)[1] for a in best.actions)
        assert total == pytest.approx(best.return_)
        returns.add(round(best.return_, 6))
    # col3 goes to whichever column slot is free: two different optima over the seeds
    assert returns == {-3.0, 1.0}
    with pytest.raises(InputError, match=r"interchangeable: unknown target 'col7'"):
        data["interchangeable"] = [["col2", "col7"]]
        load_scenario(write(tmp_path, data))


E2S2_TEXT = (SETTINGS_DIR / "E2S2.yaml").read_text()
COL2_CELLS = "cells: [[9, 9, 1], [9, 9, 4]]"


@pytest.mark.parametrize(
    "old,new,message",
    [
        ("r0: -1.0", "r0: .nan", r"line 9: key 'reward\.r0' is NaN; expected a finite number"),
        ("completion_bonus: 10.0", "completion_bonus: -.inf", r"line 11: key 'reward\.completion_bonus' is infinite"),
        ("r0: -1.0", "r0: -1.0e308", r"line 9: key 'reward\.r0' is -1e\+308, beyond any physical value"),
        ("time_limit: 100", "time_limit: 1" + "0" * 400, r"line 7: key 'time_limit' is a 401-digit number"),
        (COL2_CELLS, "cells: [[9, 9, 1], [9, 9, 1" + "0" * 50 + "]]", r"line 21: key 'targets\.col2\.cells\[1\]\[2\]' is a 51-digit"),
        (COL2_CELLS, "cells: [[9, 9, 1], [9, 9, 1000000000]]",
         r"line 21: targets\.col2\.cells: cell \(9, 9, 1000000000\) is outside the grid \(0 <= x < 15"),
        ("grid: [15, 15, 9]", "grid: [100000, 100000, 9]",
         r"line 6: grid: \[100000, 100000, 9\] must be 2 to 64 cells along every axis"),
        ("layout: fixed", "layout: random\nyard: [{x: [0, 900000000], y: [0, 3]}]",
         r"line 13: yard\[0\]: x range \[0, 900000000\] leaves the grid \(0 <= x < 15\)"),
        ("time_limit: 100", "time_limit: 1000000000", r"line 7: time_limit: must be an integer from 1 to 100000"),
        ("r0: -1.0", "r0: 2", r"line 9: reward\.r0: must be a finite number >= -1e\+06 and < 0, got 2"),
        ("epsilon: 15", "epsilon: -1", r"line 10: reward\.epsilon: must be an integer from 0 to 100000, got -1"),
        ("  target: col3\n", "  target: col3\n  length: 40\n",
         r"components\.col3\.length: must be an integer from 1 to 4, got 40"),
        ("  target: col3\n", "  target: col3\n  prebuilt: 'no'\n", r"components\.col3\.prebuilt: expected true or false"),
        ("targets:\n  col2:\n    type: column\n", "targets:\n  col2: 5\n  colx:\n    type: column\n",
         r"line 19: targets\.col2: expected a mapping"),
    ],
)
def test_impossible_numbers_and_shapes_exit_2_with_one_sentence(tmp_path, capsys, old, new, message):
    """Through the command line: the file, the line and the key, exit status 2, no traceback, and it is
    refused before anything grid-sized is allocated (a 10**9 coordinate used to build a 10**9-cell list)."""
    from bimrobot.cli import main

    assert old in E2S2_TEXT
    path = tmp_path / "site.yaml"
    path.write_text(E2S2_TEXT.replace(old, new, 1))
    assert main(["assembly", "validate", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith(f"bimrobot assembly: error: {path}")
    assert re.search(message, captured.err), captured.err
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err and captured.out == ""


@pytest.mark.parametrize(
    "old,new",
    [
        (COL2_CELLS, "cells: [[9, 9, 1], [9, 9, 1000000000]]"),  # a 10**9-cell run
        ("layout: fixed", "layout: random\nyard: [{x: [0, 999999999], y: [0, 999999999]}]"),  # a 10**18-cell yard
        ("grid: [15, 15, 9]", "grid: [1000000, 1000000, 1000]"),
    ],
)
def test_huge_coordinates_are_refused_before_any_allocation(tmp_path, old, new):
    """Measured before the fix: 104 MB per million cells of a target run, so a 10**9 coordinate needed ~100 GB."""
    import tracemalloc

    path = tmp_path / "site.yaml"
    path.write_text(E2S2_TEXT.replace(old, new, 1))
    tracemalloc.start()
    try:
        with pytest.raises(InputError):
            load_scenario(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 10_000_000  # bytes: the YAML text and its parse, nothing grid-sized
