"""Generated buildings (issue 38): real IFC files that every command reads like a user's model, with a
random fleet and a derived site, all from one seed."""

import json

import pytest

from bimrobot.bim import load_model
from bimrobot.bim.examples import CONCRETE_DENSITY, HOLLOW_CORE_KG_PER_M2, PRECAST_COLUMN
from bimrobot.cli import main
from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import InputError
from bimrobot.site.generated import draw_fleet, draw_layout, generate, grid_for, is_generated, parse_spec
from bimrobot.sco import build_smart_model


@pytest.fixture(scope="module")
def precast(tmp_path_factory):
    """A precast frame of 3 x 2 column lines and 2 floors (seed 7), read back as `simulate` reads it."""
    made = generate("generated:precast:3x2x2:seed=7", tmp_path_factory.mktemp("precast") / "precast.ifc")
    model = load_model(made.path)
    return made, model, build_smart_model(model)


def test_a_precast_frame_is_read_back_as_its_units_joints_and_weights(precast):
    made, model, smart = precast
    layout = made.layout
    # 6 columns + 4 beams + 2 planks per floor, each an IfcElementAssembly lifted as one unit
    assert made.components == len(smart.components) == 24 == len(model.assemblies)
    assert model.class_counts() == {"IfcColumn": 12, "IfcBeam": 8, "IfcSlab": 4}
    # joints: 6 column-on-column (floor 2), 2 dowelled ends per beam, a plank on each of its two beams
    assert len(smart.joints) == 6 + 2 * 8 + 2 * 4
    assert smart.summary()["assembly_points"] == len(smart.joints) * 2 * layout.bolts_per_node / 2 * 2
    column = next(c for c in smart.components.values() if c.name.startswith("Precast column"))
    side = PRECAST_COLUMN[0]
    assert column.weight_kg == pytest.approx(side * side * layout.storey_height * CONCRETE_DENSITY, rel=1e-3)
    plank = next(c for c in smart.components.values() if c.name.startswith("Hollow-core plank"))
    width, span = layout.bay_x - 0.44, layout.bay_y - 0.04  # cut around the columns; bearing on both beams
    assert plank.weight_kg == pytest.approx(width * span * HOLLOW_CORE_KG_PER_M2, rel=1e-3)
    # the top of the building is where its storeys say (metres, z up)
    top = max(e.world_bounds[1][2] for e in model.elements.values())
    assert top == pytest.approx(2 * layout.storey_height + 0.2, abs=1e-6)


def test_the_same_spec_gives_the_same_building_fleet_and_site(precast, tmp_path):
    made, model, _ = precast
    again = generate("generated:precast:3x2x2:seed=7", tmp_path / "again.ifc")
    twin = load_model(again.path)
    assert list(twin.elements) == list(model.elements)  # GlobalIds derived from names, in file order
    assert again.layout == made.layout and again.site == made.site
    assert [r.name for r in again.fleet.robots] == [r.name for r in made.fleet.robots]
    other = draw_layout(parse_spec("generated:precast:3x2x2:seed=8"))
    assert (other.bay_x, other.bay_y) != (made.layout.bay_x, made.layout.bay_y)


def test_the_random_fleet_builds_the_generated_building(precast):
    """Every component of the precast frame is installed by the seed's fleet on the seed's site."""
    made, model, smart = precast
    fleet = made.fleet
    kinds = [r.kind for r in fleet.robots]
    assert {kinds.count(k) for k in set(kinds)} <= {1, 2, 3} and set(kinds) == {"transport", "positioning", "assembly"}
    result = simulate(smart, fleet, made.site, storey_elevations=[s.elevation for s in model.storeys], per_node=False)
    assert result.makespan > 0
    assert {c.state.name for c in result.built.components.values()} == {"ASSEMBLED"}
    assert {a.robot for a in result.activities} <= {r.name for r in fleet.robots}


@pytest.mark.parametrize("kind, grid, components, joints", [
    ("steel", "2x2x1", 8, 4 + 2 * 4),  # 4 columns on plates, 4 beams with a clip angle at each end
    # 7 walls and 2 slabs a floor; each slab welded to its 4 walls, upper walls dowelled to the slabs beside them
    ("panel", "2x1x2", 2 * 9, 2 * (2 * 4) + (4 * 1 + 1 + 2 + 1)),
])
def test_steel_and_panel_buildings_have_their_components_and_joints(kind, grid, components, joints, tmp_path):
    made = generate(f"generated:{kind}:{grid}:seed=1", tmp_path / f"{kind}.ifc")
    smart = build_smart_model(load_model(made.path))
    assert made.components == components == sum(1 for c in smart.components.values() if not c.prebuilt)
    assert len(smart.joints) == joints
    assert not smart.inferred  # every joint comes from an IfcRelConnectsWithRealizingElements


def test_floor_plates_rest_on_their_walls_and_units_side_by_side_wait_for_nothing(tmp_path):
    """The plates kind has what the shared GEELEN floor of plates has and the other kinds lack: joints
    between units side by side, which may be set in any order, so the order decides when a joint can be made."""
    from bimrobot.bim.examples import CONCRETE_DENSITY, FLOOR_PLATE_THICKNESS

    made = generate("generated:plates:2x2x2:seed=1", tmp_path / "plates.ifc")
    model = load_model(made.path)
    smart = build_smart_model(model)
    # per floor 3 wall lines of 2 panels and 2 bays of 2 plates
    assert made.components == len(smart.components) == 20 and model.class_counts() == {"IfcWall": 12, "IfcSlab": 8}
    # per floor 3 wall-wall in a line, 2 ends of 4 plates, 2 plate-plate; 6 walls on walls below
    assert len(smart.joints) == 2 * (3 + 8 + 2) + 6 and not smart.inferred
    names = {c.id: c.name.removesuffix(" unit") for c in smart.components.values()}  # each an assembly unit
    by_name = {name: gid for gid, name in names.items()}
    plate = smart.components[by_name["Floor plate 0-1-0"]]
    assert sorted(names[s] for s in smart.supporters[plate.id]) == ["Bearing wall 0-1-0", "Bearing wall 0-2-0"]
    span, width = made.layout.bay_x - 0.24, made.layout.bay_y - 0.02
    assert plate.weight_kg == pytest.approx(span * width * FLOOR_PLATE_THICKNESS * CONCRETE_DENSITY, rel=1e-3)
    assert smart.supporters[by_name["Bearing wall 0-1-1"]] == ()  # beside wall 0-1-0, joined, not carried
    assert [names[s] for s in smart.supporters[by_name["Bearing wall 1-1-1"]]] == ["Bearing wall 0-1-1"]
    result = simulate(smart, made.fleet, made.site, storey_elevations=[s.elevation for s in model.storeys], per_node=False)
    assert {c.state.name for c in result.built.components.values()} == {"ASSEMBLED"}


@pytest.mark.parametrize("kind", ["steel", "precast", "panel", "plates"])
@pytest.mark.parametrize("components", [10, 100, 1000, 10000])
def test_a_number_of_components_gives_a_grid_that_close(kind, components):
    import numpy as np

    from bimrobot.bim.examples import building_components

    nx, ny, floors = grid_for(kind, components, np.random.default_rng(0))
    assert abs(building_components(kind, nx, ny, floors) - components) <= max(2, 0.05 * components)
    assert floors <= 12 and max(nx, ny) <= 3 * min(nx, ny)


def test_specs_are_parsed_and_bad_ones_refused_in_one_sentence():
    spec = parse_spec("generated:precast:4x3x5:seed=7")
    assert (spec.kind, spec.dims, spec.seed, spec.bolts) == ("precast", (4, 3, 5), 7, None)
    assert parse_spec("generated:steel:1000:bolts=6").components == 1000
    assert not is_generated("generated:6x6x4") and is_generated("generated:steel:10")
    for text, words in [("generated:timber:3x3x3", "kind must be one of steel, precast, panel, plates"),
                        ("generated:steel:0x3x3", "at least 1"),
                        ("generated:panel:3x3x3:colour=5", "must be seed=S or bolts=B"),
                        ("generated:steel:99999", "from 1 to 20,000"),
                        ("generated:steel:2x2x1:bolts=13", "from 1 to 12")]:
        with pytest.raises(InputError, match=words):
            parse_spec(text)


def test_a_spec_is_a_model_path_for_simulate(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BIMROBOT_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "sim"
    assert main(["simulate", "generated:panel:1x1x1:seed=3", "--fleet", "site-crane", "--per-joint", "--no-gantt",
                 "--no-progress", "-o", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["smart_components"]["components"] == 5  # four wall panels and the slab on them
    assert len(list((tmp_path / "cache").glob("panel-1x1x1-seed3-*.ifc"))) == 1
    capsys.readouterr()
    assert main(["inspect", "generated:panel:1x1x1:seed=3"]) == 0  # any command: the same cached file
    assert "project 'generated:panel:1x1x1:seed=3 (1x1x1)'" in capsys.readouterr().out
    assert len(list((tmp_path / "cache").iterdir())) == 1
    assert main(["simulate", "generated:panel:1x1x1:seed=-1", "-o", str(tmp_path / "bad")]) == 2
    assert "must be seed=S or bolts=B" in capsys.readouterr().err


def test_plan_generate_writes_building_fleet_and_site(tmp_path, capsys):
    out = tmp_path / "gen"
    assert main(["plan", "generate", "--kind", "steel", "--grid", "2x1x1", "--seed", "4", "-o", str(out)]) == 0
    info = json.loads((out / "generated.json").read_text())
    assert info["components"] == 3 and info["spec"] == "generated:steel:2x1x1:seed=4"
    assert main(["simulate", str(out / "building.ifc"), "--fleet", str(out / "fleet.yaml"), "--site",
                 str(out / "site.yaml"), "--per-joint", "--no-gantt", "--no-progress", "-o", str(tmp_path / "sim")]) == 0
    spec = parse_spec(info["spec"])
    fleet = draw_fleet(spec, draw_layout(spec))
    from bimrobot.site.fleet import load_fleet

    assert load_fleet(out / "fleet.yaml").robots == fleet.robots  # the seed's fleet, read back as written
    capsys.readouterr()
    assert main(["plan", "generate", "--kind", "steel", "--components", "10", "--seed", "-2", "-o", str(tmp_path / "x")]) == 2
    assert "--seed must be a whole number >= 0" in capsys.readouterr().err
