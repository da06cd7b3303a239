"""The robot family from the capability table: a base's footprint from ``footprint_m``, and the heavy
variant moving a component over 100 kg that the UR5 cannot lift."""

import importlib.util
import re

import numpy as np

import pytest

# found, not imported: MuJoCo and mink cost about 1 s of imports, paid when the tests run, not at collection
MISSING = [name for name in ("mujoco", "mink", "pyastar2d") if importlib.util.find_spec(name) is None]
if MISSING:
    pytest.skip(f"{', '.join(MISSING)} not installed (the physics extra)", allow_module_level=True)

from bimrobot.core.errors import InputError  # noqa: E402
from bimrobot.rcan.activities import ActivityKind, Pose, RcanActivity  # noqa: E402
from bimrobot.rcan.backends import create_backend  # noqa: E402
from bimrobot.rcan.generation import load_capabilities  # noqa: E402
from bimrobot.rcan.node import RcanNode  # noqa: E402

from mujoco_helpers import ROBOT_TYPES, ur5_robots_at  # noqa: E402


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """The MuJoCo site (MuJoCo, mink and trimesh: about 2 s of imports), imported when these tests run,
    not at collection."""
    global Blocked, MotionFailed
    from bimrobot.physics.site import Blocked, MotionFailed


TABLE = ROBOT_TYPES + """robots:
  narrow:
    types: [mobile_base, manipulator, gripper]
    payload_kg: 5.0
    reach_m: 0.85
    home: [-4.0, 0.0, 0.0]
  wide:
    types: [mobile_base, manipulator, gripper]
    payload_kg: 5.0
    reach_m: 0.85
    footprint_m: [3.0, 2.4]
    home: [-4.0, 0.0, 0.0]
"""


def test_footprint_from_the_capability_table_sets_the_base_and_its_path_clearance(tmp_path):
    table = tmp_path / "capabilities.yaml"
    table.write_text(TABLE)
    backend = create_backend("mujoco", load_capabilities(str(table)))
    try:
        site = backend.site
        assert site.robots["wide"].model.footprint == (3.0, 2.4)
        assert site.robots["narrow"].model.footprint == (0.99, 0.67)  # the Husky's, when the table gives none
        chassis = site.model.geom("wide/chassis").size
        assert chassis[0] == pytest.approx(1.5) and chassis[1] == pytest.approx(1.2)
        # two installed columns 2.6 m apart (their faces), a wall of supports beside each out to +-6 m
        for name, y in (("north", 1.3 + 2.5), ("south", -1.3 - 2.5)):
            site.add_support(name, (0.0, y), 3.0, (0.15, 2.5))
        narrow = site.plan_path("narrow", (4.0, 0.0))
        wide_ok = True
        try:
            wide = site.plan_path("wide", (4.0, 0.0))
        except MotionFailed:  # no way at all is as good as a way around
            wide_ok, wide = False, []
        assert len(narrow) == 1  # straight through the gap
        if wide_ok:  # around the walls, not through the gap
            assert max(abs(p[1]) for p in wide) > 6.0
    finally:
        backend.close()


def test_a_footprint_out_of_range_is_refused_with_its_line(tmp_path):
    table = tmp_path / "capabilities.yaml"
    table.write_text(TABLE.replace("footprint_m: [3.0, 2.4]", "footprint_m: [3.0, 0.0]"))
    with pytest.raises(InputError, match=r"capabilities.yaml line \d+: robot .wide.: key .footprint_m. must hold numbers between 0.05 and 100 m"):
        load_capabilities(str(table))


POST = "0SteelPost000000000001"  # a solid steel post, 100 x 100 mm, 1.6 m: 125.6 kg
HEAVY_TABLE = ROBOT_TYPES + """robots:
  ROBOT:
    types: [mobile_base, manipulator, gripper]
    payload_kg: PAYLOAD
    reach_m: REACH
    home: [-4.0, 0.0, 0.0]
"""


def _post_nodes(robot: str) -> list[RcanNode]:
    """Pick the post up where it lies on the ground (as on the yard: its centre is the target) and
    install it upright 3.5 m away (the target: the centre of its foot, on the ground): the chain of
    a component the robot carries and installs itself."""
    common = dict(component_id=POST, weight_kg=125.6, section_m=(0.1, 0.1), size_m=(0.1, 0.1, 1.6))
    pick_up, installed = Pose(0.0, -2.0, 0.05), Pose(-1.0, 1.5, 0.0)
    kinds = [(ActivityKind.MOVE_TO_COMPONENT, Pose(0.0, -3.0, 0.0)), (ActivityKind.POSITION_FOR_PICKING_UP, pick_up),
             (ActivityKind.PICK_UP, pick_up), (ActivityKind.POSITION_FOR_INSTALLING, installed),
             (ActivityKind.INSTALL, installed)]
    return [RcanNode(f"rcan/B{n}", RcanActivity(f"B{n}", kind=kind, target=target, **common), robot, "mujoco")
            for n, (kind, target) in enumerate(kinds, start=1)]


def _run(tmp_path, name: str, payload: float, reach: float):
    table = tmp_path / f"{name}.yaml"
    table.write_text(HEAVY_TABLE.replace("ROBOT", name).replace("PAYLOAD", str(payload)).replace("REACH", str(reach)))
    backend = create_backend("mujoco", load_capabilities(str(table)))
    results = []
    try:
        for node in _post_nodes(name):
            results.append(backend.execute(node))
            if not results[-1].success:
                break
        return backend, results
    finally:
        backend.close()


@pytest.mark.slow
def test_the_heavy_variant_installs_a_126_kg_post_and_the_ur5_cannot_lift_it(tmp_path):
    backend, results = _run(tmp_path, "heavy_arm", 300.0, 2.0)
    assert backend.families["heavy_arm"].family == "heavy"
    assert all(r.success for r in results), results[-1].message
    placed = re.search(r"placement error ([0-9.]+) mm, ([0-9.]+) degrees", results[-1].message)
    assert placed and float(placed.group(1)) < 10.0 and float(placed.group(2)) < 1.0
    assert backend.placements[POST][0] < 0.010

    backend, results = _run(tmp_path, "ur5_arm", 5.0, 0.85)
    assert backend.families["ur5_arm"].family == "ur5"
    failed = results[-1]
    assert not failed.success and failed.activity_id == "B3"  # the pick-up
    assert "weighs 125.6 kg" in failed.message and "rated payload 5.0 kg" in failed.message
    assert backend.site.robots["ur5_arm"].holding is None


BEAM = "0SteelBeam000000000001"  # the chapter-4 frame's 3.2 m W-section beam: 134.4 kg
COLUMNS = ("0SteelColumn0000000001", "0SteelColumn0000000002")  # 4 m W-section columns, 289.8 kg


def _positioner_table(home_xy: tuple[float, float]) -> str:
    """A capability table of one robot, "positioner": the heavy variant (a 4 m arm, 300 kg) at ``home_xy`` (m)."""
    return (HEAVY_TABLE.replace("ROBOT", "positioner").replace("PAYLOAD", "300").replace("REACH", "4.0")
            .replace("home: [-4.0, 0.0, 0.0]", f"home: [{home_xy[0]}, {home_xy[1]}, 0.0]"))


def _beam_between_two_columns() -> list[RcanActivity]:
    """Two frame columns installed from the start (no activity lifts them), 3.5 m apart at x = 2.85 m,
    and the chain of the 3.2 m beam between them: from lying flat on the ground to installed on top."""
    column = dict(weight_kg=289.81, section_m=(0.253, 0.254), size_m=(0.253, 0.254, 4.0), lifts=False)
    plan = [RcanActivity(f"C{n}", component_id=gid, kind=ActivityKind.POSITION_FOR_INSTALLING,
                         target=Pose(2.85, y, 0.03), **column) for n, (gid, y) in enumerate(zip(COLUMNS, (0.0, 3.5)))]
    beam = dict(component_id=BEAM, weight_kg=134.39, section_m=(0.165, 0.31), size_m=(0.165, 0.31, 3.223))
    lying, installed = Pose(5.0, -1.5, 0.0825), Pose(2.85, 0.14, 3.87)  # its centre on the ground; its end's centre
    chain = [(ActivityKind.MOVE_TO_COMPONENT, Pose(5.0, -2.5, 0.0)), (ActivityKind.POSITION_FOR_PICKING_UP, lying),
             (ActivityKind.PICK_UP, lying), (ActivityKind.POSITION_FOR_INSTALLING, installed),
             (ActivityKind.INSTALL, installed)]
    return plan + [RcanActivity(f"B{n}", kind=kind, target=target, **beam) for n, (kind, target) in enumerate(chain, start=1)]


@pytest.mark.slow
def test_a_4_m_arm_lifts_a_beam_from_the_ground_and_installs_it_level_between_two_columns(tmp_path):
    """The frame's top beams: a beam lying flat (web horizontal) is picked from above and must roll
    onto its side in the air, then rise to 3.9 m, where a tool held pointing down would put the wrist
    out of a 4 m arm's reach. The columns it spans are installed already (no activity lifts them:
    they start in place)."""
    table = tmp_path / "positioner.yaml"
    table.write_text(_positioner_table((7.0, -3.0)))
    plan = _beam_between_two_columns()
    backend = create_backend("mujoco", load_capabilities(str(table)), plan=plan)
    try:
        results = []
        for activity in plan[2:]:
            results.append(backend.execute(RcanNode(f"rcan/{activity.activity_id}", activity, "positioner", "mujoco")))
            assert results[-1].success, results[-1].message
        assert backend.installed[BEAM].kind == "horizontal"
        position_m, angle_deg = backend.placements[BEAM]
        assert position_m < 0.010 and angle_deg < 1.0, results[-1].message
    finally:
        backend.close()


def test_a_4_m_arm_reaches_a_column_side_at_shoulder_height_with_its_elbow_up(tmp_path):
    """Work on a column in place: the tool level, pointing at the column's side at the shoulder's
    height, 2.8 m in front. From the arm tucked for driving, inverse kinematics seeded near it ends
    with the elbow (a 1.8 m forearm) below the ground; the elbow-up solution must be found."""
    from bimrobot.physics import motion
    from bimrobot.physics.site import TUCK_POSTURE

    table = tmp_path / "assembler.yaml"
    table.write_text(HEAVY_TABLE.replace("ROBOT", "assembler").replace("PAYLOAD", "0").replace("REACH", "4.0"))
    backend = create_backend("mujoco", load_capabilities(str(table)))
    try:
        site = backend.site
        robot = site.robots["assembler"]
        robot.q_ref = TUCK_POSTURE - [0.0, 0.0, 0.0, 2 * np.pi, 0.0, 0.0]  # as driving leaves it: wrist 1 at -3 pi / 2
        arm_base = site.arm_base_pose("assembler")
        shoulder = arm_base[:3, 3] + [0.0, 0.0, robot.model.dh[0][1]]
        toward = np.array([1.0, -0.04, 0.0]) / np.hypot(1.0, 0.04)  # the tool level, 2.3 degrees off +x
        level = np.column_stack([[0.0, 0.0, -1.0], np.cross(toward, [0.0, 0.0, -1.0]), toward])
        goal = motion.pose(level, shoulder + [2.76, -0.11, 0.0])
        q = site.solve("assembler", goal)
        assert arm_base[2, 3] + robot.ik.lowest_link(q) >= site.ground_z + 0.06 * robot.model.scale
        assert np.linalg.norm(site.tcp_position_at("assembler", q) - goal[:3, 3]) < 0.002
    finally:
        backend.close()


@pytest.mark.slow
def test_a_prebuilt_column_stands_on_its_footing_while_a_4_m_arm_works_on_the_footing_beside_it(tmp_path):
    """The frame's footing connections with the column in place from the start (no activity lifts
    it): the column stands on its pedestal (a support as tall as the column's lower half used to
    push it over at the start), and the assembly robot, whose wrist is half a metre wide, reaches the
    footing's top beside it touching nothing and leaves the column where it was. Freed by the
    install, it takes its arm back from its work and tucks it (on the frame an idle robot's arm,
    left out at its last work point, stood in the way of another robot's work)."""
    table = tmp_path / "assembler.yaml"
    table.write_text(HEAVY_TABLE.replace("ROBOT", "assembler").replace("PAYLOAD", "0").replace("REACH", "4.0")
                     .replace("home: [-4.0, 0.0, 0.0]", "home: [18.5, 4.0, 0.0]"))  # fleet2's
    footing = "0ConcreteFooting000001"
    plan = [RcanActivity("C1", component_id=COLUMNS[0], kind=ActivityKind.POSITION_FOR_INSTALLING,
                         target=Pose(0.0, 0.0, 0.025), weight_kg=289.81, size_m=(0.253, 0.254, 4.0), lifts=False)]
    common = dict(component_id=footing, weight_kg=2073.6, size_m=(0.6, 1.2, 1.2), lifts=False)
    plan += [RcanActivity("F1", kind=ActivityKind.MOVE_TO_COMPONENT, target=Pose(0.0, -0.6, 0.0), **common),
             RcanActivity("F2", kind=ActivityKind.POSITION_FOR_INSTALLING, target=Pose(0.0, 0.0, -0.6), **common),
             RcanActivity("F3", kind=ActivityKind.INSTALL, target=Pose(0.0, 0.0, -0.6), **common)]
    backend = create_backend("mujoco", load_capabilities(str(table)), plan=plan)
    try:
        site, reach = backend.site, {}  # plan-view distance (m) of the tool from the base's centre
        for activity in plan[1:]:
            result = backend.execute(RcanNode(f"rcan/{activity.activity_id}", activity, "assembler", "mujoco"))
            assert result.success, result.message
            reach[activity.activity_id] = float(np.linalg.norm(site.tcp_pose("assembler")[:2, 3]
                                                               - site.base_xy_yaw("assembler")[:2]))
        assert "arm was left out" not in result.message
        assert np.abs(site.arm_q("assembler") - site.stowed_posture("assembler")).max() < 0.05
        assert reach["F2"] > 2.0 and reach["F3"] < min(site.robots["assembler"].model.footprint) / 2  # over its chassis
        assert site.robot_contacts("assembler") == []
        column = backend.site.body_pose(COLUMNS[0])
        assert np.linalg.norm(column[:3, 3] - backend.targets[COLUMNS[0]][:3, 3]) < 0.001  # not pushed
    finally:
        backend.close()


def _positioner_and(tmp_path, robot: str, payload_kg: float, reach_m: float, home_xy: tuple[float, float]):
    """The beam chain's positioner (a 4 m arm, at (7, -3)) and one more robot at ``home_xy`` (m);
    returns (backend, plan of :func:`_beam_between_two_columns`)."""
    table = tmp_path / "two.yaml"
    table.write_text(_positioner_table((7.0, -3.0))
                     + f"  {robot}:\n    types: [mobile_base, manipulator, gripper]\n    payload_kg: {payload_kg}\n"
                       f"    reach_m: {reach_m}\n    home: [{home_xy[0]}, {home_xy[1]}, 0.0]\n")
    plan = _beam_between_two_columns()
    return create_backend("mujoco", load_capabilities(str(table)), plan=plan), plan


def _install_beam(backend, plan) -> None:
    """The positioner runs the beam's chain, from driving to it to installing it; every step succeeds."""
    for activity in plan[2:]:
        result = backend.execute(RcanNode(f"rcan/{activity.activity_id}", activity, "positioner", "mujoco"))
        assert result.success, result.message


@pytest.mark.slow
def test_a_robot_waiting_where_a_beam_prop_goes_stays_free_to_drive_under_the_installed_beam(tmp_path):
    """On the frame a transport robot waited under a beam's span; the beam's prop (the support under
    its middle third) appeared inside its chassis and it could never leave; later the props of the
    installed beams closed the bays between the columns to every robot. A prop stands for the
    connections the beam hangs from: it holds the beam, and robots pass through it."""
    backend, plan = _positioner_and(tmp_path, "bystander", 5.0, 0.85, (2.85, 1.75))  # under the beam's middle
    try:
        site = backend.site
        _install_beam(backend, plan)
        assert backend.placements[BEAM][0] < 0.010  # resting on its prop
        assert [c[2] + h[2] for c, h in site.props] == [pytest.approx(3.715, abs=0.01)]
        assert site.robot_contacts("bystander") == []
        site.drive("bystander", (-1.0, 1.75))  # across the beam's span, under it
        assert np.linalg.norm(site.base_xy_yaw("bystander")[:2] - np.array([-1.0, 1.75])) < 0.05
        assert backend.placements[BEAM][0] < 0.010
    finally:
        backend.close()


@pytest.mark.slow
def test_an_arm_left_reaching_where_a_beam_prop_goes_does_not_stop_the_beam_or_its_robot(tmp_path):
    """On the frame an assembly robot ended its install with its 4 m arm stretched over the span of
    the next beam; the beam's prop appeared around its wrist, and every later drive failed (tucking
    the arm touched the prop). Robots pass through props (an empty arm reaching into the place of a
    solid support, a column's pedestal, is stowed first)."""
    backend, plan = _positioner_and(tmp_path, "assembler", 300.0, 4.0, (1.44, 0.92))  # beside the beam's middle
    try:
        site = backend.site
        site.turn("assembler", 0.61)
        site.move_arm("assembler", np.array([1.10, -1.545, -2.597, 4.142, -1.073, -1.571]))  # as the frame's was
        prop_xy, prop_half = (2.85, 1.75), (0.09, 0.5)  # where the prop under the beam's middle third goes
        assert site.arm_within("assembler", prop_xy, prop_half, 3.7)
        _install_beam(backend, plan)
        assert site.robot_contacts("assembler") == []
        assert backend.placements[BEAM][0] < 0.010
        away = RcanActivity("M9", component_id=BEAM, kind=ActivityKind.MOVE_TO_COMPONENT, target=Pose(-3.0, -3.0, 0.0),
                            weight_kg=134.39, size_m=(0.165, 0.31, 3.223))
        result = backend.execute(RcanNode("rcan/M9", away, "assembler", "mujoco"))
        assert result.success, result.message
    finally:
        backend.close()


@pytest.mark.slow
def test_a_beam_carried_low_over_its_props_place_is_installed_and_the_prop_appears_under_it(tmp_path):
    """On the frame a positioning robot stood between the columns with its beam carried low at its
    front, right where the beam's prop goes; the prop appeared around its arm and the beam escalated.
    The seat appears once the beam is held above it."""
    table = tmp_path / "positioner.yaml"
    table.write_text(_positioner_table((7.0, -3.0)))
    plan = _beam_between_two_columns()
    backend = create_backend("mujoco", load_capabilities(str(table)), plan=plan)
    try:
        site = backend.site
        for activity in plan[2:5]:  # to the beam, over it, picked up
            result = backend.execute(RcanNode(f"rcan/{activity.activity_id}", activity, "positioner", "mujoco"))
            assert result.success, result.message
        backend._to_carry("positioner")
        prop_xy, prop_half = (2.85, 1.75), (0.09, 0.5)  # under the beam's middle third
        reach = np.linalg.norm(site.tcp_pose("positioner")[:2, 3] - site.base_xy_yaw("positioner")[:2])
        way = site.plan_poses("positioner", (2.85 - reach, 1.75), 0.0, iterations=250)  # the beam over the prop's place
        site.drive("positioner", way.end, path=way)
        assert site.arm_within("positioner", prop_xy, prop_half, 3.7)
        for activity in plan[5:]:
            result = backend.execute(RcanNode(f"rcan/{activity.activity_id}", activity, "positioner", "mujoco"))
            assert result.success, result.message
        assert any(c[2] + h[2] > 3.0 for c, h in site.props)  # the prop stands under the beam
        assert site.robot_contacts("positioner") == []
        assert backend.placements[BEAM][0] < 0.010
    finally:
        backend.close()


def test_a_robot_with_a_low_support_put_under_its_chassis_drives_off_it(tmp_path):
    """On the frame a column's 2.5 cm pedestal was put on its footing while the positioning robot's
    chassis stood over it; every path from there was refused (the chassis 'would touch' it driving
    out), and the robot never moved again. What the chassis stands over already is left to the
    contact check while it drives off."""
    table = tmp_path / "one.yaml"
    table.write_text(_positioner_table((0.0, 0.0)))
    backend = create_backend("mujoco", load_capabilities(str(table)))
    try:
        site = backend.site
        site.add_support("pedestal", (0.6, 0.0), 0.025, (0.14, 0.14))  # under the chassis' front half
        site.step(0.5)
        assert site.robot_contacts("positioner") == []  # it stands over it, touching nothing
        driven = site.drive("positioner", (-4.0, 3.0))
        assert np.linalg.norm(site.base_xy_yaw("positioner")[:2] - np.array([-4.0, 3.0])) < 0.05, driven
    finally:
        backend.close()


def test_a_robot_that_cannot_turn_where_it_stands_backs_straight_out_of_a_supports_way(tmp_path):
    """On the frame a positioning robot holding a beam stood between the columns, where it sweeps
    metres when it turns; the beam's prop was to go where it stood, no stand around the prop had a
    path, and the beam escalated. With no path to any stand it drives straight along its heading
    until its chassis is clear of the support's place."""
    table = tmp_path / "one.yaml"
    table.write_text(_positioner_table((0.0, 0.0)))
    backend = create_backend("mujoco", load_capabilities(str(table)))
    try:
        site = backend.site
        for name, y in (("north", 1.3), ("south", -1.3)):  # a corridor narrower than its turning circle
            site.add_support(f"wall/{name}", (0.0, y), 2.0, (6.0, 0.1))
        prop = (np.array([0.5, 0.0]), np.array([0.14, 0.14]))
        assert not site.footprint_clear("positioner", (0.0, 0.0), 0.0, [prop])
        site.make_room("positioner", *prop)
        x, y, yaw = site.base_xy_yaw("positioner")
        assert site.footprint_clear("positioner", (x, y), yaw, [prop])
        assert abs(y) < 0.05 and abs(yaw) < 0.05 and x < 0.0  # straight back, not turned
        assert site.robot_contacts("positioner") == []
    finally:
        backend.close()


def test_a_robot_in_a_corridor_too_narrow_to_turn_in_drives_out_backwards_and_on_to_its_goal(tmp_path):
    """The grid planner lets a robot turn anywhere on its path, so it keeps the robot's turning
    circle from everything: in a 12 m corridor narrower than that circle it finds no way at all, and
    on the frame a positioning robot inside the columns was left with no path to any stand. The
    planner in the plane (OMPL, forward and backward) checks the robot's whole body instead."""
    table = tmp_path / "one.yaml"
    table.write_text(_positioner_table((0.0, 0.0)))
    backend = create_backend("mujoco", load_capabilities(str(table)))
    try:
        site = backend.site
        for name, y in (("north", 1.3), ("south", -1.3)):
            site.add_support(f"wall/{name}", (0.0, y), 2.0, (6.0, 0.1))
        assert 2 * site.sweep_radius("positioner") > 2.4  # it cannot turn between the walls
        with pytest.raises(MotionFailed, match="no collision-free path"):
            site.plan_path("positioner", (-9.0, 3.0))
        site.drive("positioner", (-9.0, 3.0))
        assert np.linalg.norm(site.base_xy_yaw("positioner")[:2] - np.array([-9.0, 3.0])) < 0.02
        assert site.robot_contacts("positioner") == []
    finally:
        backend.close()


def test_an_arm_plans_its_way_round_a_pillar_its_straight_joint_path_would_hit(tmp_path):
    """Arm paths used to be a straight joint-space move or one through a few fixed via postures; on
    the frame a 4 m arm's elbow met a prop on the way to its tucked posture, and the robot escalated
    its next activities. plan_arm searches joint space (OMPL's RRT-Connect on MuJoCo's collision
    check); each straight segment of its path is clear."""
    table = tmp_path / "arm.yaml"
    table.write_text(HEAVY_TABLE.replace("ROBOT", "arm").replace("PAYLOAD", "5").replace("REACH", "0.85")
                     .replace("home: [-4.0, 0.0, 0.0]", "home: [0.0, 0.0, 0.0]"))
    backend = create_backend("mujoco", load_capabilities(str(table)))
    try:
        site = backend.site
        site.add_support("pillar", (-0.62, 0.0), 2.0, (0.08, 0.6))  # behind the chassis
        left = np.array([1.3, -0.3, -0.3, -1.0, 1.57, 0.0])  # reaching out to the left, then to the right
        right = left * np.array([-1, 1, 1, 1, 1, 1])
        site.data.qpos[site.idx["arm"]["q"]] = left
        site.robots["arm"].q_ref = left.copy()
        site.step(1.0)
        assert site.robot_contacts("arm") == []
        assert site.path_contacts("arm", left, right, set())  # the straight way sweeps through the pillar
        path = site.plan_arm("arm", right)
        assert path is not None and np.allclose(path[-1], right)
        for a, b in zip(path, path[1:]):
            assert site.path_contacts("arm", a, b, set()) == []
            site.move_arm("arm", b)
        assert site.robot_contacts("arm") == []
        assert np.abs(site.arm_q("arm") - right).max() < 0.02
    finally:
        backend.close()


class _RecordingCondition:
    """The backend's condition, except that a wait is recorded (its timeout, s) and returns at once as
    if it had timed out: the test sees which wait the robot chose without spending it."""

    def __init__(self, condition, waits: list):
        self._condition, self._waits = condition, waits

    def __getattr__(self, name):
        return getattr(self._condition, name)

    def __enter__(self):
        return self._condition.__enter__()

    def __exit__(self, *exc):
        return self._condition.__exit__(*exc)

    def wait(self, timeout=None):
        self._waits.append(timeout)
        return False


def test_a_blocked_activity_with_nothing_else_under_way_fails_without_waiting_out_the_long_wait(tmp_path):
    """A robot whose way is blocked waits for other robots' work; when no other activity is under
    way (nothing can clear the way) it fails after IDLE_WAIT_S, not BLOCKED_WAITS x BLOCKED_WAIT_S
    (40 minutes of a frame run went so)."""
    from bimrobot.rcan.backends import mujoco as backend_module

    table = tmp_path / "one.yaml"
    table.write_text(HEAVY_TABLE.replace("ROBOT", "walled").replace("PAYLOAD", "5").replace("REACH", "0.85"))
    backend = create_backend("mujoco", load_capabilities(str(table)))
    try:
        for name, (x, y, hx, hy) in {"n": (-4.0, 1.5, 3.0, 0.2), "s": (-4.0, -1.5, 3.0, 0.2),
                                     "e": (-2.5, 0.0, 0.2, 1.3), "w": (-5.5, 0.0, 0.2, 1.3)}.items():
            backend.site.add_support(f"wall/{name}", (x, y), 1.0, (hx, hy))  # a pen around its home
        move = RcanActivity("M1", component_id=POST, kind=ActivityKind.MOVE_TO_COMPONENT, target=Pose(4.0, 0.0, 0.0),
                            weight_kg=125.6, size_m=(0.1, 0.1, 1.6))
        waits = []  # the timeouts the robot waited with, recorded instead of spent (no wall clock in the test)
        backend._changed = _RecordingCondition(backend._changed, waits)
        result = backend.execute(RcanNode("rcan/M1", move, "walled", "mujoco"))
        assert not result.success and "no collision-free path for walled" in result.message
        # it did not wait for work that nobody is doing: one short wait at most, never the long one
        assert len(waits) <= 1 and all(t == backend_module.IDLE_WAIT_S for t in waits), waits
    finally:
        backend.close()


def test_a_component_another_robot_holds_is_an_obstacle_to_drive_around(tmp_path):
    """On the frame a column held upright by a positioning robot (while the assembly robots fix it)
    was left out of every other robot's plans, as if it were in nobody's way: robots chose stands
    where they could not turn and paths through it."""
    from bimrobot.physics import motion
    from bimrobot.physics.site import Component

    backend = ur5_robots_at(tmp_path, {"holder": (0.0, 2.0), "walker": (-3.0, 0.0)})
    try:
        site = backend.site
        site.add_component(Component("held-block", (0.5, 0.5, 1.0), 100.0), motion.planar(0.0, 0.0, 0.0))
        site.robots["holder"].holding = "held-block"  # as close_gripper leaves it
        assert not any(np.allclose(c, (0.0, 0.0), atol=0.01) for c, _ in site.obstacles("holder"))
        assert any(np.allclose(c, (0.0, 0.0), atol=0.01) for c, _ in site.obstacles("walker"))
        path = [site.base_xy_yaw("walker")[:2]] + site.plan_path("walker", (3.0, 0.0))
        low, tall = site.obstacles("walker", split=True)
        samples = [a + (b - a) * t for a, b in zip(path, path[1:]) for t in np.linspace(0.0, 1.0, 20)]
        assert all(site.stand_clear("walker", p, low, tall) for p in samples[3:])  # around the block, not through it
    finally:
        backend.close()


def test_a_robot_near_a_column_is_not_sent_to_a_spot_where_it_cannot_turn(tmp_path):
    """A robot that has just worked beside a column may leave through the cells around it, but a goal
    among those cells (a transport's stand-off point 0.6 m from a column) is replaced by the nearest
    spot where it may stand and turn, as any goal too near an obstacle is."""
    backend = ur5_robots_at(tmp_path, {"worker": (-0.9, 0.0)})
    try:
        site = backend.site
        site.add_support("column", (0.0, 0.0), 4.0, (0.13, 0.13))
        low, tall = site.obstacles("worker", split=True)
        goal = np.array([-0.6, 0.4])
        assert not site.stand_clear("worker", goal, low, tall)
        stop = site.plan_path("worker", goal)[-1]
        assert site.stand_clear("worker", stop, low, tall)
        assert np.linalg.norm(stop - goal) < 1.5
    finally:
        backend.close()


def test_a_robot_given_other_work_while_it_still_holds_a_component_sets_that_one_down_first(tmp_path):
    """On the frame a positioning robot whose installs of a column had failed for good went on to its
    next work with the 4 m column still in its gripper. It now lays the column down nearby first, and
    says so."""
    table = tmp_path / "heavy.yaml"
    table.write_text(HEAVY_TABLE.replace("ROBOT", "heavy_arm").replace("PAYLOAD", "300").replace("REACH", "2.0"))
    backend = create_backend("mujoco", load_capabilities(str(table)))
    try:
        for node in _post_nodes("heavy_arm")[:3]:  # to the post, over it, picked up
            assert backend.execute(node).success
        other = RcanActivity("X1", component_id="0OtherPost000000000001", kind=ActivityKind.MOVE_TO_COMPONENT,
                             target=Pose(3.0, 3.0, 0.0), weight_kg=125.6, size_m=(0.1, 0.1, 1.6))
        result = backend.execute(RcanNode("rcan/X1", other, "heavy_arm", "mujoco"))
        assert result.success, result.message
        assert result.message.startswith(f"first set down {POST}, which it still held, at (")
        assert backend.site.robots["heavy_arm"].holding is None
        assert backend.site.body_pose(POST)[2, 3] < 0.2  # lying on the ground
    finally:
        backend.close()


def test_a_transport_tried_again_after_its_component_was_set_down_finds_it_there(tmp_path):
    """On the frame a transport set its column down, then its arm failed to reach its ready posture:
    the activity failed, and every retry said the robot did not hold the column, so it escalated with
    the column lying where it was meant to be. A retry now finds it set down near the goal."""
    table = tmp_path / "heavy.yaml"
    table.write_text(HEAVY_TABLE.replace("ROBOT", "heavy_arm").replace("PAYLOAD", "300").replace("REACH", "2.0"))
    backend = create_backend("mujoco", load_capabilities(str(table)))
    try:
        for node in _post_nodes("heavy_arm")[:3]:
            assert backend.execute(node).success
        common = dict(component_id=POST, weight_kg=125.6, section_m=(0.1, 0.1), size_m=(0.1, 0.1, 1.6))
        carry = RcanActivity("T1", kind=ActivityKind.TRANSPORT, target=Pose(2.0, 2.0, 0.0), frees_robot=True, **common)
        first = backend.execute(RcanNode("rcan/T1", carry, "heavy_arm", "mujoco"))
        assert first.success and "set down at" in first.message
        again = backend._transport(RcanNode("rcan/T1", carry, "heavy_arm", "mujoco"))  # as a retry would
        assert again.startswith(f"Transport {POST}: set down at (") and again.endswith("by the attempt before")
        elsewhere = RcanActivity("T2", kind=ActivityKind.TRANSPORT, target=Pose(12.0, 12.0, 0.0), frees_robot=True, **common)
        with pytest.raises(MotionFailed, match="does not hold"):  # not near that goal: nothing was done
            backend._transport(RcanNode("rcan/T2", elsewhere, "heavy_arm", "mujoco"))
    finally:
        backend.close()


def test_the_middle_column_of_a_yard_row_is_picked_from_further_out_and_carried(tmp_path):
    """The yard lays components 0.5 m apart (`bimrobot.export.gazebo.layout.yard_poses`; here 0.6 m): no 0.8 m
    wide base fits between two 4 m columns, and every stand at the arm's working distance from the middle one's
    centre lay on it or on its neighbours ("every stand around it is blocked": on the frame a beam's
    chain escalated so). Its reach checked, the robot now stands further out, beyond a neighbour or
    the end, its arm over the neighbour; and it pulls the 290 kg column in, level, before lifting it
    to carry (lifted straight up out there, the arm left its branch at the edge of its workspace,
    at the wrists' torque limits)."""
    table = tmp_path / "transport.yaml"
    table.write_text(HEAVY_TABLE.replace("ROBOT", "transport").replace("PAYLOAD", "300").replace("REACH", "2.0"))
    column = dict(weight_kg=289.81, section_m=(0.253, 0.254), size_m=(0.253, 0.254, 4.0))
    width = 0.254  # lying, across the row
    rows = {f"0YardColumn00000000000{n}": (5.0, y) for n, y in enumerate((-(width + 0.6), 0.0, width + 0.6))}
    plan = [RcanActivity(f"P{n}", component_id=gid, kind=ActivityKind.POSITION_FOR_PICKING_UP,
                         target=Pose(x, y, 0.127), **column) for n, (gid, (x, y)) in enumerate(rows.items())]
    middle = plan[1]
    gid = middle.component_id
    pick = RcanActivity("U1", component_id=gid, kind=ActivityKind.PICK_UP, target=middle.target, **column)
    carry = RcanActivity("T1", component_id=gid, kind=ActivityKind.TRANSPORT, target=Pose(5.0, -6.0, 0.0),
                         frees_robot=True, **column)
    backend = create_backend("mujoco", load_capabilities(str(table)), plan=plan)
    try:
        site = backend.site
        lying_z = site.body_pose(gid)[2, 3]
        for activity in (middle, pick):
            result = backend.execute(RcanNode(f"rcan/{activity.activity_id}", activity, "transport", "mujoco"))
            assert result.success, result.message
        assert site.robots["transport"].holding == gid
        x, y, _ = site.base_xy_yaw("transport")
        half_length, half_width = np.array(site.robots["transport"].model.footprint) / 2
        outside_row = abs(x - 5.0) > 4.0 / 2 + half_width or abs(y) > 1.5 * width + 0.6 + half_width
        assert outside_row, (x, y)  # not on or between the columns
        assert np.hypot(x - 5.0, y) > 1.15 * site.working_distance("transport") + half_length
        assert site.body_pose(gid)[2, 3] - lying_z > 0.09  # lifted off the ground
        result = backend.execute(RcanNode("rcan/T1", carry, "transport", "mujoco"))
        assert result.success, result.message
        centre, _ = site.component_box(gid)
        assert np.linalg.norm(centre[:2] - (5.0, -6.0)) < 4.0 and centre[2] < 0.2  # set down near its goal
    finally:
        backend.close()


def test_an_arm_that_pushes_on_against_a_post_it_touches_stops_before_the_post_falls():
    """On the frame a column standing installed was found lying 2.3 m from its place after a robot's
    arm had worked at a point on it. A motion may move away from what it touches at its start (an
    arm left against a column could otherwise never move again), which also let it press on into
    it; now a component the robot touches may not move more than 5 mm (at its farthest corner)."""
    from bimrobot.physics import motion
    from bimrobot.physics.robot import robot_model
    from bimrobot.physics.site import Component, MujocoSite

    site = MujocoSite({"ur5": (robot_model("ur5", 5.0, 0.85, 0.12), 1.0, 0.5, (0.0, 0.0))})
    site.add_component(Component("post", (0.2, 0.2, 1.2), 20.0), motion.planar(0.85, 0.0, 0.0))
    level = np.column_stack([[0, 0, -1], [0, 1, 0], [1, 0, 0]])  # the tool level, pointing at the post (+x)
    site.move_arm("ur5", site.solve("ur5", motion.pose(level, (0.815, 0.0, 0.8))), check_contacts=False)
    assert site.robot_contacts("ur5") == ["ur5/gripper touches post"]  # its palm against the post's side
    with pytest.raises(MotionFailed, match=r"the arm of ur5 pushed post by \d mm"):
        site.move_arm("ur5", site.solve("ur5", motion.pose(level, (0.95, 0.0, 0.8))))
    site.step(2.0)
    upright = motion.angle_between(site.body_pose("post")[:3, :3], np.eye(3))
    assert np.degrees(upright) < 0.5 and np.linalg.norm(site.body_pose("post")[:2, 3] - (0.85, 0.0)) < 0.005


def _heavy_and_another(tmp_path, heavy: str, other: str, payload_kg: float, reach_m: float, home_xy):
    """A mujoco backend with the heavy robot ``heavy`` (300 kg, 2 m reach) of HEAVY_TABLE and a
    second robot ``other`` (payload kg, reach m, home x y m)."""
    table = tmp_path / "two.yaml"
    table.write_text(HEAVY_TABLE.replace("ROBOT", heavy).replace("PAYLOAD", "300").replace("REACH", "2.0")
                     + f"  {other}:\n    types: [mobile_base, manipulator, gripper]\n    payload_kg: {payload_kg}\n"
                       f"    reach_m: {reach_m}\n    home: [{home_xy[0]}, {home_xy[1]}, 0.0]\n")
    return create_backend("mujoco", load_capabilities(str(table)))


def test_an_install_whose_support_place_holds_a_robot_at_work_is_blocked_before_anything_is_lifted(tmp_path):
    """On the frame a positioning robot lifted a 4 m column over its footing before it found that an
    assembly robot at work stood where the column's pedestal goes: the activity was blocked with the
    column held high, and every retry failed from there (the way back to the carry posture was out
    of reach). Now the support's place is checked first."""
    backend = _heavy_and_another(tmp_path, "heavy_arm", "worker", 5.0, 0.85, (-1.0, 1.5))
    try:
        nodes = _post_nodes("heavy_arm")
        for node in nodes[:3]:  # to the post, over it, picked up
            assert backend.execute(node).success
        raised = RcanActivity("B4", kind=ActivityKind.POSITION_FOR_INSTALLING, target=Pose(-1.0, 1.5, 0.4),
                              component_id=POST, weight_kg=125.6, section_m=(0.1, 0.1), size_m=(0.1, 0.1, 1.6))
        backend.at_work["worker"] = "0SomethingElse00000000001"  # its gripper at another component
        site = backend.site
        tcp_before = site.tcp_pose("heavy_arm")[:3, 3]
        with pytest.raises(Blocked, match="worker stands where the support of .* goes, at work on"):
            backend._position_for_installing(RcanNode("rcan/B4", raised, "heavy_arm", "mujoco"))
        assert np.linalg.norm(site.tcp_pose("heavy_arm")[:3, 3] - tcp_before) < 0.01  # nothing moved
        assert site.robots["heavy_arm"].holding == POST
    finally:
        backend.close()


def test_a_post_held_on_its_seat_off_its_place_is_set_down_again_by_its_holder_before_the_install_is_measured(tmp_path):
    """The frame's column install, in small: one robot holds the post on its seat while another one
    installs it. Set down 15 mm off its place (as a 290 kg column once was, the arm lagging behind
    its path), the post is lifted by its holder and set down again at its BIM pose, so the install
    succeeds instead of failing on the same error at every try."""
    backend = _heavy_and_another(tmp_path, "holder", "fixer", 300, 2.0, (-4.0, 4.0))
    try:
        *positioning, install = _post_nodes("holder")
        for node in positioning:
            result = backend.execute(node)
            assert result.success, result.message
        site = backend.site
        assert site.robots["holder"].holding == POST
        shifted = backend._tcp_goal("holder", backend.targets[POST])
        shifted[0, 3] += 0.015
        raised = shifted.copy()
        raised[2, 3] += 0.01
        site.move_tcp_through("holder", [raised])
        site.move_tcp_through("holder", [shifted], onto_seat=True)
        assert backend._placement_error(POST)[0] > 0.010  # seated off its place
        result = backend.execute(RcanNode("rcan/B5", install.activity, "fixer", "mujoco"))
        assert result.success, result.message
        assert "set down again 1 time by holder" in result.message
        assert backend.placements[POST][0] < 0.010 and backend.placements[POST][1] < 1.0
    finally:
        backend.close()
