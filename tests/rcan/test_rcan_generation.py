"""The fleet RCAN runs with (Table 5.2), task allocator and node generator."""

from __future__ import annotations

import pytest

from bimrobot.core.errors import InputError
from bimrobot.rcan.activities import ActivityKind as K, Pose, RcanActivity
from bimrobot.rcan.generation import NodeGenerator, TaskAllocator, load_capabilities, parse_capabilities



def test_builtin_table_is_table_5_2():
    from bimrobot.rcan.fleet import TABLE_5_2, activities_of

    assert TABLE_5_2["mobile_base"] == {K.MOVE_TO_COMPONENT, K.TRANSPORT}
    assert TABLE_5_2["manipulator"] == {K.POSITION_FOR_PICKING_UP, K.POSITION_FOR_INSTALLING}
    assert TABLE_5_2["gripper"] == {K.PICK_UP, K.INSTALL}
    husky = load_capabilities().by_name["husky_ur5"]
    assert husky.payload_kg == 5.0 and husky.reach_m == 0.85
    assert activities_of(husky) == set(K)
    assert husky.times.load_s == 3.0 and husky.times.per_point_s == 5.0 and husky.times.arm_speed_m_s == 0.5


def test_allocator_matches_type_and_payload(table_5_2):
    TABLE_5_2 = table_5_2
    table = parse_capabilities({"robot_types": TABLE_5_2, "robots": {
        "base_only": {"types": ["mobile_base"], "payload_kg": 100},
        "light_arm": {"types": ["manipulator", "gripper"], "payload_kg": 5, "reach_m": 1},
        "heavy_arm": {"types": ["manipulator", "gripper"], "payload_kg": 500, "reach_m": 3},
    }})
    allocator = TaskAllocator(table)
    heavy_pick = RcanActivity("A.1", "BEAM", K.PICK_UP, Pose(0, 0, 0), weight_kg=120.0)
    assert allocator.choose(heavy_pick) == "heavy_arm"
    light_pick = RcanActivity("B.1", "PLATE", K.PICK_UP, Pose(0, 0, 0), weight_kg=2.0)
    assert {r.name for r in table.capable_robots(K.PICK_UP, 2.0)} == {"light_arm", "heavy_arm"}
    move = RcanActivity("C.1", "PLATE2", K.MOVE_TO_COMPONENT, Pose(0, 0, 0))
    assert allocator.choose(move) == "base_only"
    too_heavy = RcanActivity("D.1", "SLAB", K.INSTALL, Pose(0, 0, 0), weight_kg=900.0)
    with pytest.raises(InputError, match=r"no robot can take 'Install' of component SLAB \(activity D.1, 900.0 kg\)"):
        allocator.choose(too_heavy)
    assert allocator.choose(light_pick) in {"light_arm", "heavy_arm"}


def test_committed_robot_keeps_the_component_and_schedule_robot_is_preferred(cranes):
    allocator = TaskAllocator(cranes)
    first = RcanActivity("A.1", "COL", K.MOVE_TO_COMPONENT, Pose(0, 0, 0), robot="crane_b")
    assert allocator.allocate(first).name == "crane_b"
    later = RcanActivity("A.2", "COL", K.PICK_UP, Pose(0, 0, 0), robot="crane_a")
    assert allocator.choose(later) == "crane_b"  # it holds the column
    other = RcanActivity("B.1", "BEAM", K.MOVE_TO_COMPONENT, Pose(0, 0, 0))
    assert allocator.choose(other, exclude=allocator.committed_robots()) == "crane_a"
    allocator.release("COL")
    assert allocator.committed_robots() == set()


def test_node_generator_instantiates_node_with_component_activity_robot_pose_backend():
    generator = NodeGenerator(TaskAllocator(load_capabilities()), backend="sim")
    activity = RcanActivity("E1.3", "267VPu8ab9991QBA3MI3UN", K.PICK_UP, Pose(0.0, -0.75, 0.45), 2.0)
    node = generator.instantiate(activity)
    assert (node.node_id, node.component_id, node.kind, node.robot, node.backend) == (
        "rcan/E1.3", "267VPu8ab9991QBA3MI3UN", K.PICK_UP, "husky_ur5", "sim")
    assert node.target.as_tuple() == (0.0, -0.75, 0.45)
    assert type(node).from_message(node.to_message()) == node.__class__(
        node.node_id, RcanActivity("E1.3", "267VPu8ab9991QBA3MI3UN", K.PICK_UP, Pose(0.0, -0.75, 0.45), 2.0),
        "husky_ur5", "sim")


TABLE_5_2 = {
    "mobile_base": {"activities": ["move_to_component", "transport"]},
    "manipulator": {"activities": ["position_for_picking_up", "position_for_installing"]},
    "gripper": {"activities": ["pick_up", "install"]},
}


@pytest.mark.parametrize("data, message", [
    ({"robot_types": TABLE_5_2}, "'robots' must map"),
    ({"robot_types": {"arm": {"activities": ["weld"]}}, "robots": {"r": {"types": ["arm"]}}},
     "robot_types.arm: unknown construction activity 'weld'"),
    ({"robot_types": TABLE_5_2, "robots": {"r": {"types": ["crane"]}}}, "robots.r.types names unknown robot type 'crane'"),
    ({"robot_types": TABLE_5_2, "robots": {"r": {"types": ["gripper"], "payload_kg": -1}}},
     "robot 'r': key 'payload_kg' must be >= 0 and <= 5e[+]06 kg, got -1"),
    ({"robot_types": TABLE_5_2, "robots": {"r": {"types": ["gripper"], "payload_kg": "heavy"}}},
     "robot 'r': key 'payload_kg' must be a number in kg, got 'heavy'"),
    ({"robot_types": TABLE_5_2, "robots": {"r": {"types": ["mobile_base"], "speed_m_s": 0}}},
     "robot 'r': key 'speed_m_s' must be > 0 and <= 20 m/s, got 0"),
    ({"robot_types": TABLE_5_2, "robots": {"r": {"types": ["gripper"], "handling_s": {"pick_upp": 3}}}},
     "robot 'r': handling_s: unknown construction activity 'pick_upp'"),
    ({"robot_types": TABLE_5_2, "robots": {"r": {"types": ["gripper"], "handling_s": {"install": -5}}}},
     "robot 'r' handling_s: key 'install' must be >= 0 and <= 86400 s, got -5"),
    ({"robot_types": TABLE_5_2, "robots": {"r": {"types": ["gripper"], "home": [0, 0]}}},
     "robot 'r': key 'home' must be a list of 3 numbers in metres"),
])
def test_bad_capability_table_names_the_key(data, message):
    with pytest.raises(InputError, match=message):
        parse_capabilities(data, "my.yaml")


def test_capability_yaml_file_errors(tmp_path):
    with pytest.raises(InputError, match="neither a built-in fleet .* nor a file"):
        load_capabilities(tmp_path / "none.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("robot_types: [unclosed\n")
    with pytest.raises(InputError, match=r"bad.yaml( line \d+)?: not valid YAML"):
        load_capabilities(bad)


def test_gripper_opening_is_matched_to_the_component_section(table_5_2):
    table = parse_capabilities({"robot_types": table_5_2, "robots": {
        "small_gripper": {"types": ["manipulator", "gripper"], "payload_kg": 500, "gripper_opening_m": [0.02, 0.12]},
        "wide_gripper": {"types": ["manipulator", "gripper"], "payload_kg": 500, "gripper_opening_m": [0.1, 0.4]},
    }})
    column = RcanActivity("A.1", "W250", K.PICK_UP, Pose(0, 0, 0), 290.0, section_m=(0.253, 0.254))
    assert [r.name for r in table.capable_robots(K.PICK_UP, 290.0, column.section_m)] == ["wide_gripper"]
    rod = RcanActivity("B.1", "ROD", K.PICK_UP, Pose(0, 0, 0), 2.0, section_m=(0.03, 0.03))
    assert TaskAllocator(table).choose(rod) == "small_gripper"
    slab = RcanActivity("C.1", "SLAB", K.INSTALL, Pose(0, 0, 0), 100.0, section_m=(0.6, 1.2))
    with pytest.raises(InputError, match=r"section 0.600 x 1.200 m\): it needs a gripper with that payload and gripper opening"):
        TaskAllocator(table).choose(slab)
    with pytest.raises(InputError, match=r"robot 'r': key 'gripper_opening_m' must be \[min, max\] with min <= max"):
        parse_capabilities({"robot_types": table_5_2, "robots": {"r": {"types": ["gripper"], "gripper_opening_m": [0.3, 0.1]}}})


@pytest.mark.parametrize("value, message", [
    (".nan", "key 'robots.crane.payload_kg' is NaN"),
    (".inf", "key 'robots.crane.payload_kg' is infinite"),
    ("1e308", "key 'robots.crane.payload_kg' is 1e[+]308, beyond any physical value"),
    ("10000000", "line 7: robot 'crane': key 'payload_kg' must be >= 0 and <= 5e[+]06 kg, got 1e[+]07"),
])
def test_impossible_numbers_in_a_capability_file_name_file_key_and_line(tmp_path, value, message):
    path = tmp_path / "caps.yaml"
    path.write_text(
        "robot_types:\n"
        "  base: {activities: [move_to_component, transport]}\n"
        "  arm: {activities: [position_for_picking_up, position_for_installing, pick_up, install]}\n"
        "robots:\n"
        "  crane:\n"
        "    types: [base, arm]\n"
        f"    payload_kg: {value}\n"
        "    reach_m: 15\n")
    with pytest.raises(InputError, match=f"caps.yaml line 7: {message}" if "line 7" not in message else message):
        load_capabilities(path)


def test_capability_file_numbers_in_range_are_read_with_units(tmp_path):
    path = tmp_path / "caps.yaml"
    path.write_text(
        "robot_types:\n  all: {activities: [move_to_component, transport, position_for_picking_up, pick_up,"
        " position_for_installing, install]}\n"
        "robots:\n  crane: {types: [all], payload_kg: 2e4, reach_m: 15, speed_m_s: 0.8, handling_s: {Pick up: 300},"
        " home: [155000.0, 463000.0, 0], gripper_opening_m: [0, 2]}\n")
    crane = load_capabilities(path).by_name["crane"]
    assert (crane.payload_kg, crane.reach_m, crane.speed_m_s) == (20000.0, 15.0, 0.8)
    assert crane.load_s == 300.0 and crane.handling_s["pick_up"] == 300.0  # "Pick up" read as Table 5.2 spells it
    assert crane.home_m == (155000.0, 463000.0, 0.0)  # georeferenced coordinates are fine (the model frame)


def test_a_fleets_site_homes_are_placed_in_the_model_frame(tmp_path):
    """A fleet's homes are site positions; RCAN's goals are in the model frame: a home h is at
    h - model_offset (the model -> site translation `simulate` uses)."""
    from bimrobot.rcan.fleet import model_offset_of
    from bimrobot.site.site import load_site

    site_file = tmp_path / "site.yaml"
    site_file.write_text("robot_home: [[100.0, 50.0], [104.0, 50.0]]\nconstruction_area: [[0, 0], [20, 10]]\n")
    site = load_site(site_file)
    table = load_capabilities("fleet2", site=site, model_offset=(-154_990.0, -462_995.0))
    homes = [robot.home_m for robot in table.robots]
    assert homes[:3] == [(155_090.0, 463_045.0, 0.0), (155_094.0, 463_045.0, 0.0), (155_090.0, 463_045.0, 0.0)]
    # a plan whose installs span x 155,000-155,004, y 463,000-463,002 is centred in the area (10, 5)
    installs = [RcanActivity(f"A{i}", "C", K.INSTALL, Pose(x, y, 0.0)) for i, (x, y) in
                enumerate([(155_000.0, 463_000.0), (155_004.0, 463_002.0)])]
    moves = [RcanActivity("M", "C", K.MOVE_TO_COMPONENT, Pose(-10.0, -10.0, 0.0))]  # the yard does not count
    assert model_offset_of(installs + moves, site) == pytest.approx((10.0 - 155_002.0, 5.0 - 463_001.0))
