"""Configuration files: impossible numbers are refused with the file, key and line."""

from pathlib import Path

import pytest

from bimrobot.core.config import line_of, parse_yaml
from bimrobot.core.errors import InputError
from bimrobot.core.schema import At, Quantity


@pytest.mark.parametrize(
    "value, words",
    [(".nan", "NaN"), (".inf", "infinite"), ("-.inf", "infinite"), ("1e308", "beyond"), ("1" + "0" * 400, "401-digit")],
)
def test_impossible_numbers_are_refused_with_file_key_and_line(value, words):
    text = f"name: f\nrobots:\n  - name: r1\n    load_time: {value}\n"
    with pytest.raises(InputError) as error:
        parse_yaml(text, "fleet.yaml")
    message = str(error.value)
    assert message.startswith("fleet.yaml line 4: key 'robots[0].load_time'") and words in message
    assert len(message) < 200


def test_mappings_know_their_lines_and_quantities_check_their_ranges():
    data = parse_yaml("a: 1\nspeed: -2\n", "site.yaml")
    assert line_of(data, "speed") == " line 2"
    at = At("site.yaml", where="robot 'x'")
    with pytest.raises(InputError, match=r"^site.yaml line 2: robot 'x': key 'speed' must be > 0 m/s, got -2$"):
        Quantity(0, None, "m/s", low_open=True).read(data["speed"], at.of(data, "speed"))
    assert Quantity(0, 10).read(data["a"], at.of(data, "a")) == 1.0
    with pytest.raises(InputError, match=r"^f.yaml line 1: key 'a' must be a number in kg, got 'fast'$"):
        Quantity(0, 10, "kg").read("fast", At("f.yaml").of(parse_yaml("a: fast\n", "f.yaml"), "a"))


def test_every_declared_robot_range_is_the_range_a_fleet_file_is_held_to():
    """RANGES is read from RobotSpec's declarations: a value at each bound loads, one just beyond is
    refused naming the key, its line, the bound and the unit."""
    from bimrobot.site.fleet import RANGES, fleet_from_dict

    assert RANGES["speed_m_s"] == (0.01, 50.0, "m/s") and RANGES["carry_kg"] == (1.0, 1e6, "kg")
    robot = {"speed_m_s": 1, "carry_kg": 5, "lift_kg": 5, "reach_m": 1, "time_per_node_s": 5, "time_per_point_s": 5}
    for key, (low, high, unit) in RANGES.items():
        for value, ok in ((low, True), (high, True), (high * 1.001, False), (low - max(abs(low), 1) * 0.001, False)):
            entry = {**robot, key: value}
            text = "version: 2\nrobots:\n  - name: M\n    kind: mobile_manipulator\n" + "".join(
                f"    {k}: {v!r}\n" for k, v in entry.items())
            line = 5 + list(entry).index(key)
            if ok:
                assert getattr(fleet_from_dict(parse_yaml(text, "f.yaml"), "f.yaml").robots[0], key) == value
                continue
            with pytest.raises(InputError) as error:
                fleet_from_dict(parse_yaml(text, "f.yaml"), "f.yaml")
            assert str(error.value) == (f"f.yaml line {line}: robots[0] (M): key '{key}' must be >= {low:g} and "
                                        f"<= {high:g} {unit}, got {value:g}")


def test_a_capability_tables_null_coordinates_read_as_absent():
    """Found by replacing every value of a capability table with each hostile value (8,288 files, messages
    compared before/after the schema): ``gripper_opening_m: null`` raised a TypeError."""
    from bimrobot.site.fleet import fleet_from_capability_table

    text = CAPABILITIES + "    gripper_opening_m: null\n    footprint_m: null\n    home: null\n"
    robot = fleet_from_capability_table(parse_yaml(text, "caps.yaml"), "caps.yaml").robots[0]
    assert (robot.gripper_opening_m, robot.footprint_m, robot.home_m) == (None, None, (0.0, 0.0, 0.0))


def test_syntax_errors_name_the_line():
    with pytest.raises(InputError, match=r"bad.yaml line 2: not valid YAML"):
        parse_yaml("a: [1, 2\nb: 3\n", "bad.yaml")


def test_a_key_given_twice_is_refused_not_silently_overwritten():
    with pytest.raises(InputError, match=r"fleet.yaml line 3: not valid YAML \(key 'speed' appears twice \(first on line 2\)\)"):
        parse_yaml("robot:\n  speed: 1\n  speed: 2\n", "fleet.yaml")


# ---------------------------------------------------------------- one reader for every kind of file
FLEET_ROBOT = "robots:\n  - name: T1\n    kind: transport\n    speed: 1\n    carry_load: 500\n    platform_size: [2, 1]\n"
CAPABILITIES = ("robot_types:\n  base:\n    activities: [move_to_component, transport, position_for_picking_up,"
                " position_for_installing, pick_up, install]\nrobots:\n  r1:\n    types: [base]\n    payload_kg: 500\n")
SCENARIO = (Path(__file__).parents[2] / "src/bimrobot/assembly/settings/E1S1.yaml").read_text()


def _with(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new, 1)


@pytest.mark.parametrize(
    "name, text, argv, message",
    [
        ("fleet.yaml", FLEET_ROBOT + "    colour: red\n", ["simulate", "generated:2x1x1", "--fleet", "{path}"],
         "{path} line 7: robots[0] (T1): unknown key 'colour' for a transport robot (allowed: carry_load, home,"),
        ("fleet.yaml", "name: f\ndepot: [0, 0]\n" + FLEET_ROBOT, ["simulate", "generated:2x1x1", "--fleet", "{path}"],
         "{path} line 2: unknown key 'depot' (allowed: name, robots)"),
        ("fleet.yaml", FLEET_ROBOT.replace("speed: 1", "speed: 90"), ["simulate", "generated:2x1x1", "--fleet", "{path}"],
         "{path} line 4: robots[0] (T1): key 'speed' must be >= 0.01 and <= 50 m/s, got 90"),
        ("site.yaml", "yard: [[1, 2]]\nrobot_home: [[3, 4]]\nparking: [[0, 0]]\n",
         ["simulate", "generated:2x1x1", "--site", "{path}"],
         "{path} line 3: unknown key 'parking' (allowed: assembly_points_per_joint, construction_area, idle_robots, model_offset, robot_home, work_calendar, yard)"),
        ("site.yaml", "yard: [[1, 2]]\nconstruction_area: [[0, 0], [1e7, 1]]\n", ["simulate", "generated:2x1x1", "--site", "{path}"],
         "{path} line 2: key 'construction_area[1]' must be >= -1e+06 and <= 1e+06 m, got 1e+07"),
        ("caps.yaml", CAPABILITIES + "    colour: red\n", ["rcan", "capabilities", "--capabilities", "{path}"],
         "{path} line 8: robot 'r1': unknown key 'colour' (allowed: arm_speed_m_s, footprint_m, gripper_opening_m, handling_s, home,"),
        ("caps.yaml", _with(CAPABILITIES, "\nrobots:", "\n    max_load: 3\nrobots:"),
         ["rcan", "capabilities", "--capabilities", "{path}"],
         "{path} line 4: robot_types.base: unknown key 'max_load' (allowed: activities)"),
        ("caps.yaml", CAPABILITIES + "owner: me\n", ["rcan", "capabilities", "--capabilities", "{path}"],
         "{path} line 8: unknown key 'owner' (allowed: robot_types, robots)"),
        ("caps.yaml", CAPABILITIES.replace("payload_kg: 500", "payload_kg: [500"), ["rcan", "capabilities", "--capabilities", "{path}"],
         "{path} line 8: not valid YAML"),
        ("scenario.yaml", _with(SCENARIO, "  target: col3\n", "  target: col3\n  colour: red\n"),
         ["assembly", "validate", "{path}"],
         "{path} line 41: components.col3: unknown key 'colour' (allowed: id, length, prebuilt, start, target, type)"),
        ("scenario.yaml", _with(SCENARIO, "    type: beam\n", "    type: beam\n    weight: 3\n"),
         ["assembly", "validate", "{path}"], "{path} line 32: targets.beam1: unknown key 'weight' (allowed: cells, type)"),
        ("scenario.yaml", _with(SCENARIO, "  y: [3, 7]\n", "  y: [3, 7]\n  w: [0, 1]\n"),
         ["assembly", "validate", "{path}"], "{path} line 21: yard[0]: unknown key 'w' (allowed: x, y, z)"),
    ],
)
def test_a_malformed_file_of_each_kind_is_one_sentence_with_file_and_line(tmp_path, capsys, name, text, argv, message):
    from bimrobot.cli import main

    path = tmp_path / name
    path.write_text(text)
    assert main([a.format(path=path) for a in argv] + (["-o", str(tmp_path / "out")] if argv[0] == "simulate" else [])) == 2
    err = capsys.readouterr().err
    assert message.format(path=path) in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_libyamls_parser_reads_what_the_pure_python_one_reads_with_the_same_lines():
    from bimrobot.core.config import LOADER, PURE_PYTHON_LOADER

    text = ("base: &base {speed: 1.5, reach: 1e-3}\nrobots:\n  - name: r1\n    <<: *base\n    home: [0, 2]\n"
            "  - *base\nflags: [yes, no, ~, 2026-11-23]\n")
    fast, slow = (parse_yaml(text, "f.yaml", loader=loader) for loader in (LOADER, PURE_PYTHON_LOADER))
    assert fast == slow and fast["robots"][0] == {"name": "r1", "speed": 1.5, "reach": 1e-3, "home": [0, 2]}
    assert fast["robots"][0].lines == slow["robots"][0].lines and fast["robots"][0].lines["home"] == 5
    assert fast["robots"][1] is fast["base"]  # an alias is the same mapping, as yaml.load gives it
    for loader in (LOADER, PURE_PYTHON_LOADER):
        with pytest.raises(InputError, match=r"^f.yaml line 3: key 'robots\[0\].speed' is infinite"):
            parse_yaml("robots:\n  - name: r1\n    speed: .inf\n", "f.yaml", loader=loader)
