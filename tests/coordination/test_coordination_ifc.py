"""The thesis' chapter-4 frame (authored with IfcOpenShell) and the real ifcUnit.ifc, end to end."""

import pytest

from bimrobot.site.fleet import load_fleet
from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import InputError
from bimrobot.sco import State, build_smart_model

LONG_PLATFORM_FLEET = """\
version: 2
name: fleet2-long
robots:
  - {name: TransportRobot11, kind: transport, speed_m_s: 0.5, carry_kg: 300, platform_m: [5.0, 1.0]}
  - {name: TransportRobot12, kind: transport, speed_m_s: 0.8, carry_kg: 300, platform_m: [5.0, 1.0]}
  - {name: PositioningRobot21, kind: positioning, speed_m_s: 1.0, lift_kg: 300, reach_m: 4.0, time_per_node_s: 120}
  - {name: PositioningRobot22, kind: positioning, speed_m_s: 1.0, lift_kg: 300, reach_m: 4.0, time_per_node_s: 60}
  - {name: AssemblyRobot31, kind: assembly, speed_m_s: 1.0, reach_m: 4.0, time_per_point_s: 60}
  - {name: AssemblyRobot32, kind: assembly, speed_m_s: 1.0, reach_m: 4.0, time_per_point_s: 30}
"""


def test_steel_frame_smart_components(steel_frame_model):
    smart = build_smart_model(steel_frame_model)
    classes = sorted(c.ifc_class for c in smart.components.values())
    assert classes == ["IfcBeam"] * 4 + ["IfcColumn"] * 4 + ["IfcFooting"] * 4
    assert len(smart.nodes) == 24 and len(smart.joints) == 12
    columns = [c for c in smart.components.values() if c.ifc_class == "IfcColumn"]
    assert all(c.node_number == 3 for c in columns)
    assert all(c.weight_kg == pytest.approx(289.81, abs=0.01) for c in columns)
    beams = sorted(round(c.weight_kg, 2) for c in smart.components.values() if c.ifc_class == "IfcBeam")
    assert beams == [105.49, 105.49, 134.39, 134.39]
    assert {n.assembly_method for n in smart.nodes.values()} == {"bolt"}
    for node in smart.nodes.values():  # node ids are "<relating>:<related>" of a relation in the file
        relating, related = node.id.split(":")
        assert any(c.relating_id == relating and c.related_id == related for c in steel_frame_model.connections)


@pytest.mark.parametrize("fleet", ["fleet1", "fleet2"])
def test_steel_frame_is_built_by_both_thesis_fleets(steel_frame_model, fleet):
    smart = build_smart_model(steel_frame_model)
    result = simulate(smart, load_fleet(fleet), storey_elevations=[s.elevation for s in steel_frame_model.storeys])
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    assert len(result.floor_finish) == 2
    points = sum(n.assembly_point_number for n in smart.nodes.values())
    slowest_share = points * 60 if fleet == "fleet1" else points * 20  # 60 s/point, or 60 and 30 s/point together
    assert result.makespan > slowest_share


def test_ifc_unit_cleats_are_connectors_and_duplicates_are_not_built(ifc_unit_model):
    smart = build_smart_model(ifc_unit_model)
    assert sorted(c.ifc_class for c in smart.components.values()) == ["IfcBeam"] * 4 + ["IfcColumn"] * 4
    cleats = [gid for gid, e in ifc_unit_model.elements.items() if "Angle_Cleat" in e.name]
    assert len(cleats) == 16 and set(cleats) <= set(smart.connectors)
    assert len(smart.duplicates) == 8  # uncut copies of the 4 columns and 4 beams, in the same places
    assert len(smart.nodes) == 28 and len(smart.joints) == 12
    methods = {n.assembly_method for n in smart.nodes.values()}
    assert methods == {"bolt", "weld"}  # base plates are welded (IfcFastener), cleats bolted
    assert all(c.node_number == 5 for c in smart.components.values() if c.ifc_class == "IfcColumn")


def test_ifc_unit_needs_longer_platforms_than_table_4_1(ifc_unit_model, tmp_path):
    with pytest.raises(InputError, match=r"cannot build 2 of 8 components: 2 IfcBeam need a carrier for up to 173 kg and 4.47 x 0.31 m .* on up to 4 x 1 m"):
        simulate(build_smart_model(ifc_unit_model), load_fleet("fleet2"))
    fleet = tmp_path / "fleet2-long.yaml"
    fleet.write_text(LONG_PLATFORM_FLEET)
    smart = build_smart_model(ifc_unit_model)
    result = simulate(smart, load_fleet(fleet), storey_elevations=[s.elevation for s in ifc_unit_model.storeys])
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    assert sum(1 for a in result.activities if a.activity == "transport") == 8


def test_lbd_importer_accepts_our_schedule(steel_frame_model, tmp_path):
    """The schedule CSV is the contract with the lbd/rcan parts: their validated importer must take it."""
    lbd_schedule = pytest.importorskip("bimrobot.schedule.csv")
    from bimrobot.coordination.schedule import write_schedule_csv

    smart = build_smart_model(steel_frame_model)
    result = simulate(smart, load_fleet("fleet2"), breakdowns=[("TransportRobot12", 20.0)],
                      storey_elevations=[s.elevation for s in steel_frame_model.storeys])
    path = write_schedule_csv(result.activities, tmp_path / "schedule.csv")
    schedule = lbd_schedule.load_schedule_csv(path, steel_frame_model)
    assert len(schedule.activities) == sum(1 for a in result.activities if not a.aborted)
