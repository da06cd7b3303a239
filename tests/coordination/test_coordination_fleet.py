"""Fleets (Table 4.1) and sites (fig. 4.11) from YAML, validated; the market's evaluators."""

import dataclasses

import numpy as np
import pytest

from bimrobot.site.fleet import RobotSpec, load_fleet
from bimrobot.site.site import default_site, load_site
from bimrobot.coordination.market import BidProposal, TaskRequest, incapability, make_evaluator, propose
from bimrobot.core.errors import InputError


def test_builtin_fleets_are_table_4_1():
    fleet1, fleet2 = load_fleet("fleet1"), load_fleet("fleet2")
    assert [r.name for r in fleet1.robots] == ["TransportRobot11", "PositioningRobot21", "AssemblyRobot31"]
    assert len(fleet2.robots) == 6
    robots = {r.name: r for r in fleet2.robots}
    assert (robots["TransportRobot11"].speed_m_s, robots["TransportRobot12"].speed_m_s) == (0.5, 0.8)
    assert robots["TransportRobot12"].carry_kg == 300 and robots["TransportRobot12"].platform_m == (4.0, 1.0)
    assert (robots["PositioningRobot21"].time_per_node_s, robots["PositioningRobot22"].time_per_node_s) == (120, 60)
    assert robots["PositioningRobot22"].lift_kg == 300 and robots["PositioningRobot22"].reach_m == 4.0
    assert (robots["AssemblyRobot31"].time_per_point_s, robots["AssemblyRobot32"].time_per_point_s) == (60, 30)
    assert [r.name for r in fleet2.by_activity("assemble")] == ["AssemblyRobot31", "AssemblyRobot32"]


@pytest.mark.parametrize(
    "body, message",
    [
        ("robots: []", "key 'robots' must be a non-empty list"),
        ("robots:\n  - {name: T, kind: crane, speed: 1}", r"robots\[0\] \(T\): key 'kind' must be one of"),
        ("robots:\n  - {name: T, kind: transport, speed: 1, carry_load: 300}", r"robots\[0\] \(T\): missing key 'platform_size'"),
        ("robots:\n  - {name: T, kind: transport, speed: -1, carry_load: 300, platform_size: [4, 1]}", r"line 2: robots\[0\] \(T\): key 'speed' must be >= 0.01 and <= 50 m/s, got -1"),
        ("robots:\n  - {name: A, kind: assembly, speed: 1, reach: 4, time_per_point: 30, payload: 9}", r"unknown key 'payload' for a assembly robot"),
        ("robots:\n  - {name: A, kind: assembly, speed: 1, reach: 4, time_per_point: 30, methods: [glue]}", r"key 'methods' must be a list drawn from"),
        ("robots:\n  - {name: A, kind: assembly, speed: 1, reach: 4, time_per_point: 30}\n  - {name: A, kind: assembly, speed: 1, reach: 4, time_per_point: 30}", "robot name 'A' is used twice"),
        ("robots:\n  - {name: T, kind: transport\n", r"line \d+: not valid YAML"),
    ],
)
def test_bad_fleet_files_name_file_and_key(tmp_path, body, message):
    path = tmp_path / "bad_fleet.yaml"
    path.write_text(body)
    with pytest.raises(InputError, match=message) as error:
        load_fleet(path)
    assert str(path) in str(error.value)


FLEET_LINE = "name: f\nrobots:\n  - name: T\n    kind: transport\n    speed: 1.0\n    carry_load: 300\n    platform_size: [4, 1]\n"


@pytest.mark.parametrize(
    "replace, message",
    [
        # NaN, infinity and absurd magnitudes never reach the simulation (a NaN load time made "makespan nan s")
        (("carry_load: 300", "carry_load: 300\n    load_time: .nan"), r"bad_fleet.yaml line 7: key 'robots\[0\].load_time' is NaN"),
        (("speed: 1.0", "speed: .inf"), r"line 5: key 'robots\[0\].speed' is infinite"),
        (("speed: 1.0", "speed: 51"), r"line 5: robots\[0\] \(T\): key 'speed' must be >= 0.01 and <= 50 m/s, got 51"),
        (("speed: 1.0", "speed: 0"), r"line 5: robots\[0\] \(T\): key 'speed' must be >= 0.01 and <= 50 m/s, got 0"),
        # issue 35: a 1e-300 m/s robot made a 302-digit makespan and a schedule rcan and graph refused
        (("speed: 1.0", "speed: 1.0e-300"), r"line 5: robots\[0\] \(T\): key 'speed' must be >= 0.01 and <= 50 m/s, got 1e-300"),
        (("carry_load: 300", "carry_load: 0"), r"line 6: robots\[0\] \(T\): key 'carry_load' must be >= 1 and <= 1e\+06 kg, got 0"),
        (("carry_load: 300", "carry_load: 2000000"), r"line 6: robots\[0\] \(T\): key 'carry_load' must be >= 1 and <= 1e\+06 kg"),
        (("carry_load: 300", "carry_load: '300'"), r"line 6: robots\[0\] \(T\): key 'carry_load' must be a number in kg, got '300'"),
        (("carry_load: 300", "carry_load: 300\n    unload_time: -5"), r"line 7: robots\[0\] \(T\): key 'unload_time' must be >= 0 and <= 86400 s, got -5"),
        (("platform_size: [4, 1]", "platform_size: [4, 1000]"), r"line 7: robots\[0\] \(T\): key 'platform_size' must be >= 0.1 and <= 100 m, got 1000"),
        (("platform_size: [4, 1]", "platform_size: [4, 1]\n    home: [1.0e+8, 0]"), r"line 8: robots\[0\] \(T\): key 'home' must be >= -1e\+06 and <= 1e\+06 m"),
        (("speed: 1.0", "speed: 1.0e+308"), r"line 5: key 'robots\[0\].speed' is 1e\+308, beyond any physical value"),
    ],
)
def test_fleet_numbers_are_finite_and_physical(tmp_path, replace, message):
    path = tmp_path / "bad_fleet.yaml"
    path.write_text(FLEET_LINE.replace(*replace))
    with pytest.raises(InputError, match=message):
        load_fleet(path)


@pytest.mark.parametrize(
    "body, message",
    [
        ("yard: [[12.5, 4], [1.0e+308, 6]]\n", r"site.yaml line 1: key 'yard\[1\]\[0\]' is 1e\+308, beyond any physical value"),
        ("yard: [[12.5, 4], [5.0e+6, 6]]\n", r"site.yaml line 1: key 'yard\[1\]' must be >= -1e\+06 and <= 1e\+06 m, got 5e\+06"),
        ("robot_home: [[.nan, 4]]\n", r"site.yaml line 1: key 'robot_home\[0\]\[0\]' is NaN"),
        ("construction_area: [[0, 0], [10, true]]\n", r"line 1: key 'construction_area\[1\]' must be a number in m, got True"),
        ("\nmodel_offset: [0, 3.0e+7]\n", r"site.yaml line 2: key 'model_offset' must be >= -2e\+07 and <= 2e\+07 m"),
    ],
)
def test_site_numbers_are_finite_and_physical(tmp_path, body, message):
    path = tmp_path / "site.yaml"
    path.write_text(body)
    with pytest.raises(InputError, match=message):
        load_site(path)


def test_a_yard_kilometres_from_the_building_is_refused_before_simulating(tmp_path):
    from bimrobot.coordination.generate import generated_frame
    from bimrobot.coordination.simulation import ConstructionSimulation
    from bimrobot.sco import build_smart_model

    path = tmp_path / "site.yaml"
    path.write_text("yard: [[12.5, 4], [900000, 6]]\n")
    with pytest.raises(InputError, match=r"site.yaml: yard position \(900000, 6\) is 900.0 km from the building"):
        ConstructionSimulation(build_smart_model(generated_frame(2, 1, 1)), load_fleet("fleet1"), load_site(path))


def test_site_crane_fleet_handles_20_t_and_15_m():
    fleet = load_fleet("site-crane")
    assert {r.kind for r in fleet.robots} == {"transport", "positioning", "assembly"}
    for robot in fleet.by_activity("transport"):
        assert robot.carry_kg == 20000 and robot.platform_m == (15.0, 15.0)
        assert incapability(robot, _request(weight_kg=20000, size=(15.0, 3.0))) is None
    for robot in fleet.by_activity("position"):
        assert incapability(robot, _request(activity="position", weight_kg=20000, reach_needed=15.0)) is None
    for robot in fleet.by_activity("assemble"):
        assert incapability(robot, _request(activity="assemble", reach_needed=15.0, methods=frozenset({"bolt", "weld"}))) is None
    # cranes and crews are slower than Table 4.1's robots: walking pace with a suspended load
    assert all(r.speed_m_s <= 1.0 for r in fleet.robots)


def test_unknown_fleet_name_is_refused():
    with pytest.raises(InputError, match="neither a built-in fleet"):
        load_fleet("fleet3")


def test_site_file_overrides_defaults_and_is_validated(tmp_path):
    path = tmp_path / "site.yaml"
    path.write_text("yard: [[20, 0], [20, 2]]\nmodel_offset: [1.5, 2]\n")
    site = load_site(path)
    assert site.yard == ((20.0, 0.0), (20.0, 2.0)) and site.model_offset == (1.5, 2.0)
    assert site.robot_home == default_site().robot_home
    path.write_text("yard: [[20, 0], [20]]\n")
    with pytest.raises(InputError, match=r"site.yaml line 1: key 'yard\[1\]' must be a pair of numbers"):
        load_site(path)
    path.write_text("idle_robots: home\n")
    with pytest.raises(InputError, match="key 'idle_robots' must be 'stay' or 'yard', got 'home'"):
        load_site(path)
    path.write_text("depot: [0, 0]\n")
    with pytest.raises(InputError, match="unknown key 'depot'"):
        load_site(path)


def test_default_site_centres_the_building_in_the_construction_area():
    offset = default_site().offset_for(np.array([0.0, 0.0]), np.array([3.5, 2.846]))
    assert offset == pytest.approx([6.75 - 1.75, 4.75 - 1.423])


def _request(**kw):
    values = dict(id="R1", activity="transport", component_id="C", start=np.array([12.5, 4.0]), end=np.array([6.0, 4.0]), floor=0, priority=(0,))
    values.update(kw)
    return TaskRequest(**values)


def test_capability_filtering_by_payload_platform_reach_and_method():
    fleet = {r.name: r for r in load_fleet("fleet2").robots}
    assert incapability(fleet["TransportRobot11"], _request(weight_kg=289.8, size=(3.98, 0.25))) is None
    assert "carry load 300 kg < 301.0 kg" in incapability(fleet["TransportRobot11"], _request(weight_kg=301.0, size=(1, 1)))
    assert "platform 4 x 1 m" in incapability(fleet["TransportRobot11"], _request(weight_kg=100, size=(4.47, 0.31)))
    assert "reach 4 m < 4.20 m" in incapability(fleet["PositioningRobot21"], _request(activity="position", weight_kg=100, reach_needed=4.2))
    assert "does not transport" in incapability(fleet["AssemblyRobot31"], _request())


def test_proposal_cost_is_travel_plus_handling():
    robot = load_fleet("fleet2").robots[1]  # TransportRobot12, 0.8 m/s
    proposal = propose(robot, np.array([18.5, 4.0]), 100.0, True, _request())
    assert proposal.distance == pytest.approx(6.0)
    assert proposal.travel_time == pytest.approx(6.0 / 0.8)
    assert proposal.handling_time == pytest.approx(6.5 / 0.8)
    assert proposal.finish_time == pytest.approx(100.0 + 12.5 / 0.8)


def test_evaluators_pick_by_cost_finish_distance_or_seeded_chance():
    proposals = [
        BidProposal("slow-near", "R1", distance=1.0, travel_time=1.0, handling_time=120.0, finish_time=121.0, idle=True),
        BidProposal("fast-far", "R1", distance=20.0, travel_time=20.0, handling_time=60.0, finish_time=80.0, idle=True),
        BidProposal("fast-busy", "R1", distance=2.0, travel_time=2.0, handling_time=60.0, finish_time=70.0, idle=False),
    ]
    assert make_evaluator("least-cost").choose(proposals[:2]).robot == "fast-far"
    assert make_evaluator("quickest-finish").choose(proposals).robot == "fast-busy"
    assert make_evaluator("greedy-nearest").choose(proposals[:2]).robot == "slow-near"
    picks = [make_evaluator("random", seed=5).choose(proposals[:2]).robot for _ in range(2)]
    assert picks[0] == picks[1]
    with pytest.raises(InputError, match="unknown evaluator 'cheapest'"):
        make_evaluator("cheapest")


# ---------------------------------------------------------------- one fleet format (issue 34)
V1_FLEET2 = """name: fleet2
robots:
  - {name: TransportRobot11, kind: transport, speed: 0.5, carry_load: 300, platform_size: [4.0, 1.0]}
  - {name: TransportRobot12, kind: transport, speed: 0.8, carry_load: 300, platform_size: [4.0, 1.0]}
  - {name: PositioningRobot21, kind: positioning, speed: 1.0, payload: 300, reach: 4.0, time_per_node: 120}
  - {name: PositioningRobot22, kind: positioning, speed: 1.0, payload: 300, reach: 4.0, time_per_node: 60}
  - {name: AssemblyRobot31, kind: assembly, speed: 1.0, reach: 4.0, time_per_point: 60}
  - {name: AssemblyRobot32, kind: assembly, speed: 1.0, reach: 4.0, time_per_point: 30}
"""


def test_a_version_1_fleet_reads_as_the_same_robots_with_one_warning(tmp_path, caplog):
    path = tmp_path / "old.yaml"
    path.write_text(V1_FLEET2)
    with caplog.at_level("WARNING", logger="bimrobot.site.fleet"):
        old = load_fleet(path)
    assert old.robots == load_fleet("fleet2").robots  # every number the same, so every makespan
    [warning] = [r.getMessage() for r in caplog.records]
    assert str(path) in warning and "version-1 fleet" in warning
    assert "carry_load -> carry_kg" in warning and "speed -> speed_m_s" in warning and "time_per_node -> time_per_node_s" in warning


@pytest.mark.parametrize(
    "robot, message",
    [
        ("{name: T, kind: transport, speed_m_s: 1, carry_kg: 300}", r"robots\[0\] \(T\): missing key 'platform_m' \(a transport robot needs carry_kg, platform_m, speed_m_s\)"),
        ("{name: T, kind: transport, speed: 1, carry_kg: 300, platform_m: [4, 1]}", r"line 3: robots\[0\] \(T\): unknown key 'speed' for a transport robot"),
        ("{name: P, kind: positioning, speed_m_s: 1, lift_kg: 0, reach_m: 4, time_per_node_s: 60}", r"key 'lift_kg' must be >= 1 and <= 1e\+06 kg, got 0"),
        ("{name: A, kind: assembly, speed_m_s: 1, reach_m: 4, time_per_point_s: 30, rcan_activities: [weld]}", r"key 'rcan_activities': unknown construction activity 'weld'"),
        ("{name: A, kind: assembly, speed_m_s: 1, reach_m: 4, time_per_point_s: 30, gripper_opening_m: [0.3, 0.1]}", r"key 'gripper_opening_m' must be \[min, max\] with min <= max"),
        ("{name: A, kind: assembly, speed_m_s: 1, reach_m: 4, time_per_point_s: 30, home_m: [1, 2, 3, 4]}", r"key 'home_m' must be \[x, y\] or \[x, y, z\] in metres"),
    ],
)
def test_version_2_fleet_files_are_validated_naming_the_key(tmp_path, robot, message):
    path = tmp_path / "fleet.yaml"
    path.write_text(f"version: 2\nrobots:\n  - {robot}\n")
    with pytest.raises(InputError, match=message) as error:
        load_fleet(path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)


def test_one_robot_type_for_simulate_and_rcan(tmp_path, caplog):
    """RCAN's robots are the fleet's robots: the built-in rcan-robots, a fleet and an older RCAN capability
    table all read as bimrobot.site.fleet.RobotSpec, with RCAN's views derived from it."""
    import bimrobot.rcan.generation as generation
    from bimrobot.site.fleet import RobotSpec
    from bimrobot.rcan.activities import ActivityKind as K
    from bimrobot.rcan.generation import load_capabilities

    assert not hasattr(generation, "CapabilityTable") and getattr(generation, "RobotSpec", RobotSpec) is RobotSpec
    husky = load_capabilities().by_name["husky_ur5"]
    assert isinstance(husky, RobotSpec) and husky.home_m == (-3.0, 0.0, 0.0)
    assert (husky.payload_kg, husky.reach_m, husky.arm_speed, husky.handling_s) == (5.0, 0.85, 0.5, {"pick_up": 3.0, "install": 5.0})
    assert husky.can_grip((0.05, 0.1)) and not husky.can_grip((0.2, 0.3))
    carrier = load_capabilities("fleet2").by_name["TransportRobot11"]
    assert (carrier.payload_kg, carrier.reach_m, carrier.arm_speed) == (300.0, 2.0, 0.5)  # loads over its 4 m platform
    assert carrier.times.arm_speed_m_s == float("inf")  # Table 4.1's handling times include the arm's motions
    table = tmp_path / "capabilities.yaml"
    table.write_text("robot_types:\n  base: {activities: [move_to_component, transport]}\n"
                     "robots:\n  cart: {types: [base], payload_kg: 50, speed_m_s: 0.4, home: [1, 2, 0]}\n")
    with caplog.at_level("WARNING", logger="bimrobot.site.fleet"):
        cart = load_capabilities(table, model_offset=(100.0, 100.0)).by_name["cart"]
    assert "RCAN capability table" in caplog.text and "payload_kg -> carry_kg" in caplog.text
    assert cart.home_m == (1.0, 2.0, 0.0)  # a capability table's homes are in the model frame already
    assert cart.performs(K.TRANSPORT) and not cart.performs(K.PICK_UP) and cart.payload_kg == 50.0


def test_fleet_list_and_convert(tmp_path, capsys):
    from bimrobot.cli import main

    assert main(["fleet", "list"]) == 0
    out = capsys.readouterr().out
    assert [line.split()[0] for line in out.splitlines()] == ["fleet1", "fleet2", "rcan-robots", "site-crane"]
    assert main(["fleet", "keys"]) == 0  # from the declaration that validates: every key, its range, who needs it
    lines = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    assert list(lines) == [f.name for f in dataclasses.fields(RobotSpec)]
    assert "0.01 to 50 m/s" in lines["speed_m_s"] and lines["carry_kg"].endswith("needed by transport, mobile_manipulator")
    assert "each 0.1 to 100 m" in lines["platform_m"] and lines["platform_m"].endswith("needed by transport")
    old = tmp_path / "old.yaml"
    old.write_text(V1_FLEET2)
    new = tmp_path / "new.yaml"
    assert main(["fleet", "convert", str(old), "-o", str(new)]) == 0
    assert "version: 2" in new.read_text() and "carry_kg: 300.0" in new.read_text()
    assert load_fleet(new).robots == load_fleet("fleet2").robots
    assert main(["fleet", "convert", str(old), "-o", str(old)]) == 2  # never overwrites a user's file
    assert "speed: 0.5" in old.read_text()
    capsys.readouterr()
    table = tmp_path / "caps.yaml"  # an RCAN gripper that lifts nothing: no version-2 robot carries 0 kg
    table.write_text("robot_types:\n  g: {activities: [pick_up, install]}\nrobots:\n  arm: {types: [g], reach_m: 1}\n")
    assert main(["fleet", "convert", str(table), "-o", str(tmp_path / "caps2.yaml")]) == 2
    assert "cannot be written in the version-2 keys" in capsys.readouterr().err and not (tmp_path / "caps2.yaml").exists()


def test_a_mobile_manipulator_without_a_platform_carries_what_it_holds(tmp_path):
    path = tmp_path / "mm.yaml"
    path.write_text("version: 2\nrobots:\n  - {name: M, kind: mobile_manipulator, speed_m_s: 1, carry_kg: 500, lift_kg: 500,"
                    " reach_m: 6, time_per_node_s: 60, time_per_point_s: 30}\n")
    robot = load_fleet(path).robots[0]
    assert robot.platform_m is None
    assert incapability(robot, _request(weight_kg=400, size=(12.0, 0.5))) is None  # any length, in its gripper
    assert incapability(robot, _request(weight_kg=600, size=(1.0, 0.5))) == "carry load 500 kg < 600.0 kg"
