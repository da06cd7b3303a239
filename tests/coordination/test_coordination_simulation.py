"""The market-based construction simulation: known times, thesis rules, faults."""

import pytest

from bimrobot.bim.model import BuildingModel, Connection, Storey
from bimrobot.site.fleet import load_fleet
from bimrobot.site.site import Site
from bimrobot.coordination.generate import box_element, generated_frame
from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import BimrobotError, InputError
from bimrobot.sco import State, build_smart_model

THESIS_SEQUENCE = [
    "OnYard", "InTransit", "Arrived", "InLocation", "WorkingInPositioning", "PositionFixed",
    "WaitForAssembly", "WorkingInAssembly", "Assembled",
]


def _one_column():
    """A column (centre at x = y = 0) bolted through a base plate to a footing: 4 bolts on each side."""
    footing = box_element("F", "IfcFooting", "", "L1", (-0.6, -0.6, -0.6), (0.6, 0.6, 0.0), 2000.0)
    plate = box_element("P", "IfcPlate", "", "L1", (-0.2, -0.2, 0.0), (0.2, 0.2, 0.02), 25.0)
    column = box_element("C", "IfcColumn", "", "L1", (-0.125, -0.125, 0.02), (0.125, 0.125, 4.0), 290.0)
    model = BuildingModel(
        source=None, schema="IFC4", project_name="one column", site_name="", units={},
        storeys=[Storey("L1", "Level 1", 0.0)], elements={e.global_id: e for e in (footing, plate, column)},
        connections=[Connection("F", "P", ("a1", "a2", "a3", "a4")), Connection("C", "P", ("b1", "b2", "b3", "b4"))],
    )
    return model


def _frame(nx=2, ny=2, floors=1):
    model = generated_frame(nx, ny, floors)
    return build_smart_model(model), [s.elevation for s in model.storeys]


def test_one_column_build_takes_the_hand_computed_time():
    # Transport robot home (10, 0), yard (6, 0), column at (0, 0): 4 m + 6 m at 0.5 m/s = 20 s.
    # Positioning robot from (0, 8): 8 m at 1 m/s, then 1 node x 120 s: finishes at 20 + 8 + 120 = 148 s.
    # Assembly robot from (0, -6): 6 m at 1 m/s, then 8 bolts x 60 s: finishes at 148 + 6 + 480 = 634 s.
    site = Site(yard=((6.0, 0.0),), robot_home=((10.0, 0.0), (0.0, 8.0), (0.0, -6.0)),
                construction_area=((-1, -1), (1, 1)), model_offset=(0.0, 0.0))
    smart = build_smart_model(_one_column())
    result = simulate(smart, load_fleet("fleet1"), site)
    assert result.makespan == pytest.approx(634.0)
    rows = {(a.activity, a.robot): (a.start, a.finish) for a in result.activities}
    assert rows[("transport", "TransportRobot11")] == pytest.approx((0.0, 20.0))
    assert rows[("position", "PositioningRobot21")] == pytest.approx((20.0, 148.0))
    assert [a.activity for a in result.activities] == ["transport", "position", "assemble", "assemble"]
    assert result.activities[-1].finish == pytest.approx(634.0)
    assert [s for _, s in result.state_history["C"]] == THESIS_SEQUENCE
    assert [t for t, s in result.state_history["C"] if s == "Arrived"] == pytest.approx([20.0])
    busy = {r.name: r.busy_time for r in result.robots}
    assert busy == pytest.approx({"TransportRobot11": 20.0, "PositioningRobot21": 128.0, "AssemblyRobot31": 486.0})


@pytest.mark.parametrize("fleet", ["fleet1", "fleet2"])
def test_frame_is_built_floor_by_floor_columns_before_beams(fleet):
    smart, elevations = _frame(2, 2, 2)
    result = simulate(smart, load_fleet(fleet), storey_elevations=elevations, per_node=False)  # whole-component positioning
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    assert all(n.state == State.ASSEMBLED for n in result.built.nodes.values())
    finish = {(a.activity, a.global_id): a.finish for a in result.activities if a.activity != "assemble"}
    start = {(a.activity, a.global_id): a.start for a in result.activities if a.activity == "transport"}
    for gid, supporters in smart.supporters.items():
        for supporter in supporters:
            if not smart.components[supporter].prebuilt:
                assert start[("transport", gid)] >= finish[("position", supporter)] - 1e-9
    # no transport of floor k+1 before every joint of floor k is assembled
    for floor, done in enumerate(result.floor_finish[:-1]):
        later = [a.start for a in result.activities if a.activity == "transport" and smart.components[a.global_id].floor > floor]
        assert min(later) >= done - 1e-9
    assert result.floor_finish[-1] == pytest.approx(result.makespan)


@pytest.mark.parametrize("evaluator", ["least-cost", "quickest-finish", "greedy-nearest", "random"])
def test_schedule_is_consistent_whatever_the_allocator(evaluator):
    smart, elevations = _frame(3, 2, 1)
    result = simulate(smart, load_fleet("fleet2"), evaluator=evaluator, seed=3, storey_elevations=elevations)
    by_id = {a.id: a for a in result.activities}
    for a in result.activities:
        for p in a.predecessors:
            assert a.start >= by_id[p].finish - 1e-9, (a, by_id[p])
    for robot in result.robots:
        mine = sorted((a.start, a.finish) for a in result.activities if a.robot == robot.name)
        assert all(f1 <= s2 + 1e-9 for (_, f1), (s2, _) in zip(mine, mine[1:]))  # one task at a time
        assert robot.busy_time == pytest.approx(sum(f - s for s, f in mine))
    assert result.makespan == pytest.approx(max(a.finish for a in result.activities))
    assert 0 < result.utilisation < 1


def test_two_robots_of_each_kind_build_faster_than_one():
    smart1, elevations = _frame()
    smart2, _ = _frame()
    one = simulate(smart1, load_fleet("fleet1"), storey_elevations=elevations)
    two = simulate(smart2, load_fleet("fleet2"), storey_elevations=elevations)
    assert two.makespan < 0.6 * one.makespan
    # with one assembly robot, the build is never shorter than its handling work: 144 points x 60 s
    assert one.makespan >= 144 * 60


def test_breakdown_mid_task_reauctions_and_loses_nothing():
    smart, elevations = _frame()
    result = simulate(smart, load_fleet("fleet2"), breakdowns=[("AssemblyRobot32", 400.0)], storey_elevations=elevations)
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    aborted = [a for a in result.activities if a.aborted]
    assert len(aborted) == 1 and aborted[0].robot == "AssemblyRobot32" and aborted[0].finish == pytest.approx(400.0)
    assert not [a for a in result.activities if a.robot == "AssemblyRobot32" and a.start >= 400.0]
    assert any("AssemblyRobot32 broke down" in line and "auctioned again" in line for line in result.log_lines)
    reauction = [e for e in result.events if e["event"] == "reauction"]
    assert len(reauction) == 1 and reauction[0]["robot"] == "AssemblyRobot32"
    redone = [e for e in result.events if e["event"] == "award" and e["request"] == reauction[0]["request"]]
    assert [e["robot"] for e in redone] == ["AssemblyRobot32", "AssemblyRobot31"]
    # every joint assembled exactly once in the schedule
    assembled_nodes = [a.name for a in result.activities if a.activity == "assemble" and not a.aborted]
    assert len(assembled_nodes) == len(set(assembled_nodes)) == len(smart.nodes)


def test_transport_breakdown_leaves_the_component_where_it_was_dropped():
    smart, elevations = _frame()
    result = simulate(smart, load_fleet("fleet2"), breakdowns=[("TransportRobot12", 10.0)], storey_elevations=elevations)
    dropped = next(e for e in result.events if e["event"] == "reauction")
    assert dropped["state"] == "OnYard"
    history = [s for _, s in result.state_history[dropped["component"]]]
    assert history[:4] == ["OnYard", "InTransit", "OnYard", "InTransit"]
    assert history[-1] == "Assembled"


def test_breakdown_of_the_only_assembly_robot_stalls_with_a_clear_error():
    smart, elevations = _frame()
    with pytest.raises(BimrobotError, match=r"no working robot can assemble joint .* \(broken down: AssemblyRobot31\)"):
        simulate(smart, load_fleet("fleet1"), breakdowns=[("AssemblyRobot31", 100.0)], storey_elevations=elevations)


def test_component_no_robot_can_carry_is_refused_before_simulating():
    model = generated_frame(2, 1, 1, bay_x=5.0)  # a 4.75 m beam: longer than the 4 m platforms
    with pytest.raises(
        InputError,
        match=r"fleet fleet1 cannot build 1 of 3 components: 1 IfcBeam needs a carrier for up to 184 kg and 4.75 x 0.31 m "
        r"\(e.g. beam-0-x-0-0\); the fleet carries at most 300 kg on up to 4 x 1 m",
    ):
        simulate(build_smart_model(model), load_fleet("fleet1"))


def test_component_too_heavy_to_position_is_refused(tmp_path):
    model = generated_frame(2, 1, 1)
    model.elements["column-0-0-0"].weight_kg = 450.0
    fleet = tmp_path / "strong_transport.yaml"
    fleet.write_text(
        "robots:\n"
        "  - {name: T, kind: transport, speed: 1, carry_load: 1000, platform_size: [5, 1]}\n"
        "  - {name: P, kind: positioning, speed: 1, payload: 300, reach: 4, time_per_node: 60}\n"
        "  - {name: A, kind: assembly, speed: 1, reach: 4, time_per_point: 30}\n"
    )
    with pytest.raises(
        InputError,
        match=r"1 IfcColumn needs a positioner for up to 450 kg at 3.85 m reach \(e.g. column-0-0-0\); .* positions at most 300 kg",
    ):
        simulate(build_smart_model(model), load_fleet(fleet))


def test_unknown_robot_in_breakdown_is_refused():
    smart, _ = _frame()
    with pytest.raises(InputError, match="breakdown names robot 'Robot9', which is not in fleet fleet2"):
        simulate(smart, load_fleet("fleet2"), breakdowns=[("Robot9", 10.0)])


def test_mobile_manipulators_do_every_task(tmp_path):
    fleet = tmp_path / "mm.yaml"
    fleet.write_text(
        "robots:\n"
        "  - {name: MM1, kind: mobile_manipulator, speed: 1, carry_load: 400, platform_size: [4, 1],"
        " payload: 400, reach: 4.5, time_per_node: 60, time_per_point: 30}\n"
    )
    smart, elevations = _frame(2, 1, 1)
    result = simulate(smart, load_fleet(fleet), storey_elevations=elevations)
    assert {a.robot for a in result.activities} == {"MM1"}
    assert {a.activity for a in result.activities} == {"transport", "position", "assemble"}
    assert result.utilisation == pytest.approx(1.0)


def test_random_allocator_is_reproducible_with_its_seed():
    runs = []
    for seed in (7, 7, 8):
        smart, elevations = _frame(3, 2, 1)
        result = simulate(smart, load_fleet("fleet2"), evaluator="random", seed=seed, storey_elevations=elevations)
        runs.append([(a.activity, a.global_id, a.robot) for a in result.activities])
    assert runs[0] == runs[1]
    assert runs[0] != runs[2]


from hypothesis import given, settings, strategies as st  # noqa: E402

from bimrobot.site.fleet import fleet_from_dict  # noqa: E402


@settings(max_examples=15, deadline=None)
@given(
    nx=st.integers(1, 3), ny=st.integers(1, 2), floors=st.integers(1, 2),
    per_kind=st.integers(1, 3), manipulators=st.integers(0, 2),
    evaluator=st.sampled_from(["least-cost", "quickest-finish", "greedy-nearest", "random"]),
    speed=st.floats(0.3, 2.0), seed=st.integers(0, 1000),
)
def test_any_frame_and_fleet_builds_completely_and_consistently(nx, ny, floors, per_kind, manipulators, evaluator, speed, seed):
    robots = []
    for i in range(per_kind):
        robots.append({"name": f"T{i}", "kind": "transport", "speed": speed, "carry_load": 300, "platform_size": [4, 1]})
        robots.append({"name": f"P{i}", "kind": "positioning", "speed": speed, "payload": 300, "reach": 4.5, "time_per_node": 30 + 30 * i})
        robots.append({"name": f"A{i}", "kind": "assembly", "speed": speed, "reach": 4.5, "time_per_point": 20 + 10 * i})
    for i in range(manipulators):
        robots.append({"name": f"M{i}", "kind": "mobile_manipulator", "speed": speed, "carry_load": 300, "platform_size": [4, 1],
                       "payload": 300, "reach": 4.5, "time_per_node": 90, "time_per_point": 45})
    fleet = fleet_from_dict({"name": "random", "robots": robots}, "hypothesis")
    model = generated_frame(nx, ny, floors)
    smart = build_smart_model(model)
    result = simulate(smart, fleet, evaluator=evaluator, seed=seed, storey_elevations=[s.elevation for s in model.storeys])
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    by_id = {a.id: a for a in result.activities}
    for a in result.activities:
        assert all(a.start >= by_id[p].finish - 1e-6 for p in a.predecessors)
    for robot in result.robots:
        mine = sorted((a.start, a.finish) for a in result.activities if a.robot == robot.name)
        assert all(f1 <= s2 + 1e-6 for (_, f1), (s2, _) in zip(mine, mine[1:]))
    transports = sorted(a.global_id for a in result.activities if a.activity == "transport")
    assert transports == sorted(c.id for c in smart.components.values() if not c.prebuilt)


def test_joints_among_prebuilt_components_are_already_made():
    """With footings and columns prebuilt, only the beam's joints are assembled by robots."""
    model = generated_frame(2, 1, 1)
    smart = build_smart_model(model, prebuilt_classes=("IfcFooting", "IfcColumn"))
    assert smart.components["footing-0-0"].state == State.ASSEMBLED  # its only joint is with its column
    assert smart.components["column-0-0-0"].state == State.POSITION_FIXED  # waits for the beam
    result = simulate(smart, load_fleet("fleet1"), storey_elevations=[s.elevation for s in model.storeys])
    assembled = {a.name.split()[1] for a in result.activities if a.activity == "assemble"}
    assert assembled == {n.id for n in smart.nodes.values() if "clip" in n.id}
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())


def test_idle_robots_can_return_to_the_nearest_yard():
    # As the hand-computed one-column build, but idle robots drive back to the yard at (6, 0).
    site = Site(yard=((6.0, 0.0),), robot_home=((10.0, 0.0), (0.0, 8.0), (0.0, -6.0)),
                construction_area=((-1, -1), (1, 1)), model_offset=(0.0, 0.0), idle_robots="yard")
    result = simulate(build_smart_model(_one_column()), load_fleet("fleet1"), site)
    assert result.makespan == pytest.approx(634.0)  # nothing waits for the returning robots
    robots = {r.name: r for r in result.robots}
    # transport robot: 20 s of task, then 6 m back from the column (0, 0) to the yard at 0.5 m/s
    assert robots["TransportRobot11"].busy_time == pytest.approx(20.0)
    assert robots["TransportRobot11"].travel_time == pytest.approx(20.0 + 12.0)
    assert robots["PositioningRobot21"].travel_time == pytest.approx(8.0 + 6.0)
    assert any("TransportRobot11 has no task and returns to the yard" in line for line in result.log_lines)


def test_a_returning_robot_is_called_away_from_where_it_is(tmp_path):
    smart, elevations = _frame(3, 2, 1)
    site = Site(yard=((12.5, 4.0), (12.5, 6.0)), robot_home=((18.5, 4.0),), construction_area=((3.0, 1.5), (10.5, 8.0)),
                idle_robots="yard")
    fleet = tmp_path / "slow_positioning.yaml"  # positioning robots crawl: their way back takes minutes
    fleet.write_text(
        "robots:\n"
        "  - {name: T1, kind: transport, speed: 0.8, carry_load: 300, platform_size: [4, 1]}\n"
        "  - {name: P1, kind: positioning, speed: 0.02, payload: 300, reach: 4, time_per_node: 10}\n"
        "  - {name: A1, kind: assembly, speed: 1.0, reach: 4, time_per_point: 5}\n"
    )
    result = simulate(smart, load_fleet(fleet), site, storey_elevations=elevations)
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    stopped = [e for e in result.events if e["event"] == "return_stopped"]
    assert stopped  # some robot was given a task on its way back
    for event in stopped:  # ... and set off from where it was, between the site and the yard
        assert 3.0 <= event["x"] <= 12.5 + 1e-9
    for robot in result.robots:
        mine = sorted((a.start, a.finish) for a in result.activities if a.robot == robot.name)
        assert all(f1 <= s2 + 1e-9 for (_, f1), (s2, _) in zip(mine, mine[1:]))
        assert robot.travel_time > 0


def test_a_repaired_robot_comes_back_and_finishes_the_build():
    """fleet 1 has one assembly robot: without repair the build stalls, with a 900 s repair it ends 900 s or less later."""
    smart, elevations = _frame()
    base = simulate(smart, load_fleet("fleet1"), storey_elevations=elevations).makespan
    smart, _ = _frame()
    result = simulate(smart, load_fleet("fleet1"), breakdowns=[("AssemblyRobot31", 600.0, 900.0)], storey_elevations=elevations)
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    assert any("AssemblyRobot31 is repaired after 900 s" in line for line in result.log_lines)
    restart = min(a.start for a in result.activities if a.robot == "AssemblyRobot31" and a.start > 600.0 and not a.aborted)
    assert restart == pytest.approx(1500.0)
    assert base < result.makespan <= base + 900.0 + 600.0  # at worst the repair plus the lost work


def _snapshot(smart):
    """What a run could change in a SmartModel: every component's and node's state and position."""
    objects = [*smart.components.values(), *smart.nodes.values()]
    return [(o.id, str(o.state), tuple(float(v) for v in o.position)) for o in objects]


@pytest.mark.parametrize("per_node", [False, True])
def test_a_model_simulated_twice_gives_the_same_build_and_stays_as_built(per_node):
    smart, elevations = _frame(2, 2, 2)
    before = _snapshot(smart)
    runs = [simulate(smart, load_fleet("fleet2"), storey_elevations=elevations, per_node=per_node) for _ in range(2)]
    assert _snapshot(smart) == before  # still on the yard, as built: nothing moved, nothing assembled
    rows = [[(a.id, a.activity, a.global_id, a.robot, a.start, a.finish, a.predecessors) for a in r.activities] for r in runs]
    assert rows[0] == rows[1] and runs[0].log_lines == runs[1].log_lines and runs[0].makespan == runs[1].makespan
    assert all(c.state == State.ASSEMBLED for c in runs[1].built.components.values())
