"""Assembly units (precast: the IfcElementAssembly is lifted as one), prebuilt classes and what rests on them."""


import numpy as np
import pytest

from bimrobot.bim.model import Assembly, BuildingModel, Connection, Storey
from bimrobot.site.fleet import load_fleet
from bimrobot.coordination.generate import box_element
from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import InputError
from bimrobot.bim import load_model
from bimrobot.sco import State, build_smart_model
from bimrobot.sco.build import ASSUMED_POINTS_PER_JOINT, split_points
from shared_data import SHARED_IFC


HEAVY_FLEET = """\
name: heavy
robots:
  - {name: T, kind: transport, speed: 1, carry_load: 20000, platform_size: [12, 4]}
  - {name: P, kind: positioning, speed: 1, payload: 20000, reach: 12, time_per_node: 60}
  - {name: A, kind: assembly, speed: 1, reach: 12, time_per_point: 30}
"""


def _model(elements, connections=(), assemblies=(), schema="IFC2X3"):
    return BuildingModel(
        source=None, schema=schema, project_name="test", site_name="site", units={},
        storeys=[Storey("L1", "Level 1", 0.0), Storey("L2", "Level 2", 3.0)],
        elements={e.global_id: e for e in elements}, connections=list(connections),
        assemblies={a.global_id: a for a in assemblies},
    )


def _precast_balcony():
    """A precast balcony unit (slab + two edge beams + an anchor) resting on a wall."""
    wall = box_element("WALL", "IfcWall", "wall", "L1", (0, 0, 0), (4, 0.2, 2.7), 5000.0)
    slab = box_element("BAL", "IfcSlab", "balcony slab", "L2", (0, 0.2, 2.7), (4, 1.7, 2.9), 2900.0)
    edge1 = box_element("EDGE1", "IfcBeam", "edge", "L2", (0, 0.2, 2.9), (0.1, 1.7, 3.0), 36.0)
    edge2 = box_element("EDGE2", "IfcBeam", "edge", "L2", (3.9, 0.2, 2.9), (4.0, 1.7, 3.0), 36.0)
    anchor = box_element("ANCH", "IfcDiscreteAccessory", "lifting anchor", "L2", (2, 1, 2.95), (2.05, 1.05, 3.0), 0.5)
    unit = Assembly("UNIT", "BALKON", "L2", ("BAL", "EDGE1", "EDGE2", "ANCH"))
    # relations between parts of the unit are made in the factory
    internal = [Connection("BAL", "ANCH", ("WELD1",), "WELDED"), Connection("BAL", "EDGE1", ("WELD2",), "WELDED")]
    return _model([wall, slab, edge1, edge2, anchor], internal, [unit])


def test_an_assembly_is_one_component_with_the_mass_and_extent_of_its_parts():
    pytest.importorskip("fcl", reason="connection inference uses python-fcl")
    smart = build_smart_model(_precast_balcony())
    assert set(smart.components) == {"WALL", "UNIT"}
    unit = smart.components["UNIT"]
    assert unit.part_ids == ("BAL", "EDGE1", "EDGE2", "ANCH")
    assert unit.weight_kg == pytest.approx(2900 + 36 + 36 + 0.5)
    assert unit.ifc_class == "IfcSlab" and unit.object_type == "IfcElementAssembly"  # its heaviest part's class
    assert unit.size == pytest.approx((4.0, 1.5, 0.3))  # the union of the parts, slab to edge beams
    assert unit.bottom_z == pytest.approx(2.7)
    assert smart.internal_connections == 2  # the factory welds are not site work
    assert smart.connection_source == "inferred from geometry"
    assert [j.component_ids for j in smart.joints.values()] == [("WALL", "UNIT")]
    assert smart.supporters["UNIT"] == ("WALL",)
    assert smart.summary()["assembly_units"] == 1


def test_by_element_builds_every_part_and_keeps_the_relations():
    smart = build_smart_model(_precast_balcony(), by_element=True)
    # the file's relations decide the roles again: the related parts are connectors of the slab
    assert set(smart.components) == {"WALL", "BAL", "EDGE2"} and smart.connectors == ["ANCH", "EDGE1"]
    assert smart.internal_connections == 0 and smart.assemblies == 0
    assert smart.connection_source == "IfcRelConnectsWithRealizingElements"


def test_prebuilt_classes_take_subclasses_and_unknown_names_are_refused():
    wall = box_element("W", "IfcWallStandardCase", "wall", "L1", (0, 0, 0), (4, 0.2, 2.7), 5000.0)
    beam = box_element("B", "IfcBeam", "beam", "L2", (0, 0, 2.7), (4, 0.2, 3.0), 300.0)
    model = _model([wall, beam], [Connection("W", "B", inferred=True)])
    smart = build_smart_model(model, prebuilt_classes=("IfcWall",))
    assert smart.components["W"].prebuilt and not smart.components["B"].prebuilt
    with pytest.raises(InputError, match=r"--prebuilt names 'IfcWal', which is not an IFC class \(this model's classes: IfcBeam, IfcWallStandardCase\)"):
        build_smart_model(model, prebuilt_classes=("IfcFooting", "IfcWal"))


def test_a_model_with_assemblies_lists_the_assembly_class_and_may_mark_every_unit_prebuilt():
    pytest.importorskip("fcl", reason="connection inference uses python-fcl")
    model = _precast_balcony()
    with pytest.raises(InputError, match=r"this model's classes: IfcBeam, IfcDiscreteAccessory, IfcElementAssembly, IfcSlab, IfcWall"):
        build_smart_model(model, prebuilt_classes=("Slab",))
    smart = build_smart_model(model, prebuilt_classes=("IfcElementAssembly",))
    assert smart.components["UNIT"].prebuilt and not smart.components["WALL"].prebuilt


@pytest.mark.parametrize("tolerance", [0.0, -0.01, float("nan"), 2.0])
def test_impossible_contact_tolerances_are_refused(tolerance):
    model = _model([box_element("B", "IfcBeam", "beam", "L1", (0, 0, 0), (4, 0.2, 0.3), 300.0)])
    with pytest.raises(InputError, match=r"contact tolerance must be > 0 and <= 0.5 m"):
        build_smart_model(model, inferred_tolerance_m=tolerance)


def _slab_on_a_robot_built_beam():
    """A cast slab (prebuilt) resting on two walls (prebuilt) and on a downstand beam the robots place;
    a column stands on the slab."""
    wall1 = box_element("W1", "IfcWall", "wall", "L1", (0, 0, 0), (0.2, 4, 2.7), 5000.0)
    wall2 = box_element("W2", "IfcWall", "wall", "L1", (4.8, 0, 0), (5.0, 4, 2.7), 5000.0)
    beam = box_element("BEAM", "IfcBeam", "downstand beam", "L1", (0.2, 1.9, 2.3), (4.8, 2.1, 2.7), 400.0)
    slab = box_element("SLAB", "IfcSlab", "cast slab", "L2", (0, 0, 2.7), (5, 4, 2.9), 9000.0)
    column = box_element("COL", "IfcColumn", "column", "L2", (2.4, 1.9, 2.9), (2.6, 2.1, 5.9), 250.0)
    pairs = [("W1", "BEAM"), ("W2", "BEAM"), ("W1", "SLAB"), ("W2", "SLAB"), ("BEAM", "SLAB"), ("SLAB", "COL")]
    return _model([wall1, wall2, beam, slab, column], [Connection(a, b, inferred=True) for a, b in pairs])


def test_a_prebuilt_slab_on_a_robot_built_beam_is_made_once_the_beam_is_placed(tmp_path):
    """The --prebuilt crash (KeyError in _finish_positioning) at its cause: such a slab is not on site
    from the start; it is made by others the moment what it rests on is fixed."""
    model = _slab_on_a_robot_built_beam()
    smart = build_smart_model(model, prebuilt_classes=("IfcWall", "IfcSlab"))
    assert smart.prebuilt_later == ["SLAB"]
    assert smart.components["SLAB"].state == State.IN_LOCATION  # not there yet
    assert smart.components["W1"].state == State.POSITION_FIXED  # on site from the start
    assert smart.robot_supporters("COL") == ("BEAM",)  # the column waits for the beam under the slab
    fleet = tmp_path / "heavy.yaml"
    fleet.write_text(HEAVY_FLEET)
    result = simulate(smart, load_fleet(fleet), storey_elevations=[0.0, 3.0])
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    rows = {(a.activity, a.global_id): a for a in result.activities}
    assert ("transport", "SLAB") not in rows and ("position", "SLAB") not in rows  # no robot time for it
    slab_made = dict(result.state_history["SLAB"])
    beam_fixed = rows["position", "BEAM"].finish
    assert min(t for t, s in result.state_history["SLAB"] if s == "PositionFixed") == pytest.approx(beam_fixed)
    assert "InLocation" in slab_made.values()
    column = rows["transport", "COL"]
    assert column.start >= beam_fixed and rows["position", "BEAM"].id in column.predecessors
    made = [e for e in result.events if e["event"] == "prebuilt_in_place"]
    assert made == [{"time": pytest.approx(beam_fixed, abs=1e-3), "step": made[0]["step"], "event": "prebuilt_in_place",
                     "component": "SLAB", "supporters": ["BEAM", "W1", "W2"]}]


def test_the_cp_sat_task_graph_follows_supports_through_a_prebuilt_slab():
    pytest.importorskip("ortools")
    from bimrobot.planning.optimal_graph import task_graph
    from bimrobot.coordination.simulation import ConstructionSimulation

    smart = build_smart_model(_slab_on_a_robot_built_beam(), prebuilt_classes=("IfcWall", "IfcSlab"))
    sim = ConstructionSimulation(smart, load_fleet("site-crane"), storey_elevations=[0.0, 3.0])
    tasks = {t.key: t for t in task_graph(smart, sim)}
    assert "position:BEAM" in tasks["transport:COL"].predecessors
    assert "transport:SLAB" not in tasks


@pytest.fixture(scope="module")
def prefab():
    path = SHARED_IFC / "MULTICOM-Prefab.ifc"
    if not path.exists():
        pytest.skip(f"{path} is absent: the shared test data lives beside the repository, not in it")
    from bimrobot.bim import load_model

    return load_model(path)


def test_multicom_prefab_is_built_as_its_118_precast_units(prefab):
    pytest.importorskip("fcl", reason="connection inference uses python-fcl")
    smart = build_smart_model(prefab)
    assert len(smart.components) == 118 == len(prefab.assemblies)
    assert all(c.part_ids and c.object_type == "IfcElementAssembly" for c in smart.components.values())
    for unit in smart.components.values():
        parts = [prefab.elements[p] for p in unit.part_ids]
        known = [p.weight_kg for p in parts if p.weight_kg is not None]
        assert unit.weight_kg == pytest.approx(sum(known))
        low = np.min([p.world_bounds[0] for p in parts], axis=0)
        high = np.max([p.world_bounds[1] for p in parts], axis=0)
        assert unit.bottom_z == pytest.approx(low[2])
        assert np.allclose(unit.target_position, (low + high) / 2)
    heaviest = max(smart.components.values(), key=lambda c: c.weight_kg)
    assert 3000 < heaviest.weight_kg < 4000  # the balcony unit: a 3.5 t slab with its embedded parts
    # element by element the accessories stay out, and the small parts become components of their own
    by_element = build_smart_model(prefab, by_element=True)
    assert len(by_element.components) > 200 and by_element.assemblies == 0


def test_multicom_stairs_factory_welds_are_not_site_joints():
    path = SHARED_IFC / "MULTICOM-trappen_bordessen.ifc"
    if not path.exists():
        pytest.skip(f"{path} is absent: the shared test data lives beside the repository, not in it")
    pytest.importorskip("fcl", reason="connection inference uses python-fcl")
    from bimrobot.bim import load_model

    model = load_model(path)
    smart = build_smart_model(model)
    assert len(smart.components) == len(model.assemblies) == 9  # 6 flights (TRAP) and 3 landings (BORDES)
    assert {c.name for c in smart.components.values()} == {"TRAP", "BORDES"}
    # the export's 36 IfcRelConnectsWithRealizingElements weld lifting anchors inside one unit
    assert smart.internal_connections == 36
    assert smart.connection_source == "inferred from geometry"
    assert all(len(set(j.component_ids)) == 2 for j in smart.joints.values())
    element_wise = build_smart_model(model, by_element=True)
    assert element_wise.connection_source == "IfcRelConnectsWithRealizingElements" and len(element_wise.joints) == 36


def test_a_rafter_drawn_diagonally_in_an_unrotated_frame_is_as_long_and_thin_as_it_is():
    """ArchiCAD's roof members: identity placement, body sloping in x and z; its local box is 4 x 0.1 x 3 m."""
    import trimesh

    rafter = trimesh.creation.box(extents=(5.0, 0.1, 0.2))
    rafter.apply_transform(trimesh.transformations.rotation_matrix(np.arctan2(3, 4), [0, 1, 0]))
    element = box_element("R", "IfcMember", "rafter", "L1", (0, 0, 0), (1, 1, 1), 50.0)
    element.vertices, element.faces = np.asarray(rafter.vertices), np.asarray(rafter.faces)
    smart = build_smart_model(_model([element]))
    assert smart.components["R"].size == pytest.approx((5.0, 0.2, 0.1), abs=1e-6)


# ---- issue 34: aggregates lifted as units (not only IfcElementAssembly), fastening points from the model
# or a per-joint default reported as assumed, goals from the body, and refusals that name the unit ----

SHORT_PLATFORM_FLEET = """\
name: short-platform
robots:
  - {name: T, kind: transport, speed: 1, carry_load: 20000, platform_size: [3, 2]}
  - {name: P, kind: positioning, speed: 1, payload: 20000, reach: 12, time_per_node: 60}
  - {name: A, kind: assembly, speed: 1, reach: 12, time_per_point: 30}
"""


@pytest.fixture(scope="module")
def geelen():
    path = SHARED_IFC / "GEELEN-Breedplaat_V1.ifc"
    if not path.exists():
        pytest.skip(f"{path} is absent: the shared test data lives beside the repository, not in it")
    return load_model(path)


def test_tekla_wide_slab_aggregates_are_lifted_as_25_units_not_279_blocks(geelen):
    """GEELEN-Breedplaat: 25 precast floor plates, each an IfcSlab aggregating 5-16 proxies (plate,
    lattice girders, blocks). Each plate is one lift; --by-element keeps the 279 pieces."""
    pytest.importorskip("fcl", reason="connection inference uses python-fcl")
    assert len(geelen.assemblies) == 25 and {a.ifc_class for a in geelen.assemblies.values()} == {"IfcSlab"}
    units = build_smart_model(geelen)
    assert len(units.components) == 25 and units.assemblies == 25
    plate = next(iter(units.components.values()))
    assert plate.object_type == "IfcSlab" and plate.ifc_class == "IfcSlab" and plate.what == "IfcSlab unit"
    assert len(build_smart_model(geelen, by_element=True).components) == 279
    # the old comma list marks the plates prebuilt by the class of their whole
    assert all(c.prebuilt for c in build_smart_model(geelen, prebuilt_classes="IfcSlab").components.values())


def test_inferred_joints_take_their_points_from_the_models_bolts(shared_ifc):
    """ifcUnit without its relations: its 28 bolts (placed at the origin in the file, found where their
    bodies are) give the joints they reach into their points; the other joints are assumed, 4 each."""
    pytest.importorskip("fcl", reason="connection inference uses python-fcl")
    model = load_model(shared_ifc("ifcUnit.ifc"))
    model.connections = []
    smart = build_smart_model(model, by_element=True)
    by_source = smart.assembly_points_by_source
    assert smart.connection_source == "inferred from geometry"
    assert 0 < by_source["model"]["points"] <= 28
    assert by_source["assumed"]["points"] == by_source["assumed"]["joints"] * ASSUMED_POINTS_PER_JOINT
    bolted = [j for j in smart.joints.values() if smart.nodes[j.node_ids[0]].assembly_point_source == "model"]
    assert bolted and all(j.realizing_ids for j in bolted)
    assert all(smart.nodes[n].assembly_method == "bolt" for j in bolted for n in j.node_ids)
    assert smart.summary()["assembly_points_by_source"] == by_source


def test_the_per_joint_default_is_a_parameter_split_over_the_two_nodes():
    pytest.importorskip("fcl", reason="connection inference uses python-fcl")
    smart = build_smart_model(_precast_balcony(), assembly_points_per_joint=3)
    (joint,) = smart.joints.values()
    assert sorted(smart.nodes[n].assembly_point_number for n in joint.node_ids) == [1, 2]
    assert smart.assembly_points_by_source["assumed"] == {"joints": 1, "points": 3, "per_joint": 3}
    assert split_points(4) == (2, 2) and split_points(1) == (1, 0)
    with pytest.raises(InputError, match="assembly_points_per_joint must be a whole number of fastening points >= 1"):
        build_smart_model(_precast_balcony(), assembly_points_per_joint=0)


def test_goals_come_from_the_body_in_the_smart_model(shared_ifc):
    """engine_web's concrete columns are placed at (0, 0, 0): their components' origin (the goal the
    schedule, graph and RCAN use) is the body's bottom centre, 100 m away, and the summary says so."""
    pytest.importorskip("fcl", reason="connection inference uses python-fcl")
    model = load_model(shared_ifc("engine_web-ifc_example.ifc"), include="IfcColumn")
    smart = build_smart_model(model)
    goals = smart.summary()["goals_from_body"]
    assert goals["count"] == 41 - 11 and {e["class"] for e in goals["elements"]} == {"IfcColumn"}
    for entry in goals["elements"]:
        component = smart.components[entry["GlobalId"]]
        assert abs(component.origin[0] - component.target_position[0]) < 0.2
        assert abs(component.origin[1] - component.target_position[1]) < 0.2


def test_a_unit_too_long_for_the_fleet_is_named_as_the_assembly_with_remedies_that_fit(tmp_path):
    """The 4 m balcony unit on a 3 m platform: named 'IfcElementAssembly unit (main part IfcSlab)', and
    the remedies are --by-element or a longer platform (not 'IfcSlab', not only 'a stronger fleet')."""
    pytest.importorskip("fcl", reason="connection inference uses python-fcl")
    fleet = tmp_path / "short.yaml"
    fleet.write_text(SHORT_PLATFORM_FLEET)
    with pytest.raises(InputError) as refused:
        simulate(build_smart_model(_precast_balcony()), load_fleet(fleet), storey_elevations=[0.0, 3.0])
    message = str(refused.value)
    assert "1 IfcElementAssembly unit (main part IfcSlab) needs a carrier" in message
    assert "--by-element" in message and "longer platform" in message
