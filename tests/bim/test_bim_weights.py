"""Masses from the material structure: layer sets by thickness, constituents by fraction, names by whole
words; unknown stays unknown; implausible weights are listed as suspect; the shared real models."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import ifcopenshell
import ifcopenshell.api.context
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.aggregate
import ifcopenshell.api.unit

from bimrobot.bim import load_model
from bimrobot.bim.cli import summarize
from bimrobot.bim.model import WeightSource
from bimrobot.bim.quantities import PLAUSIBLE_DENSITY_KG_M3, density_of, match_material, weight_check
from bimrobot.cli import main
from shared_data import SHARED_IFC


# A wall 4 m long, 3 m high; its thickness is the sum of its layers (metres).
WALL_LENGTH, WALL_HEIGHT = 4.0, 3.0


class _Model:
    """A small IFC4 model in metres, written with ifcopenshell.api: one storey, walls with given materials."""

    def __init__(self):
        self.file = ifcopenshell.api.project.create_file(version="IFC4")
        project = ifcopenshell.api.root.create_entity(self.file, ifc_class="IfcProject", name="weights")
        units = [
            ifcopenshell.api.unit.add_si_unit(self.file, unit_type="LENGTHUNIT"),
            ifcopenshell.api.unit.add_si_unit(self.file, unit_type="MASSUNIT", prefix="KILO"),
        ]
        ifcopenshell.api.unit.assign_unit(self.file, units=units)
        model = ifcopenshell.api.context.add_context(self.file, context_type="Model")
        self.body = ifcopenshell.api.context.add_context(
            self.file, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model
        )
        site = ifcopenshell.api.root.create_entity(self.file, ifc_class="IfcSite", name="site")
        self.storey = ifcopenshell.api.root.create_entity(self.file, ifc_class="IfcBuildingStorey", name="Level 1")
        ifcopenshell.api.aggregate.assign_object(self.file, products=[site], relating_object=project)
        ifcopenshell.api.aggregate.assign_object(self.file, products=[self.storey], relating_object=site)
        self.count = 0

    def material(self, name: str, mass_density: float | None = None):
        material = ifcopenshell.api.material.add_material(self.file, name=name)
        if mass_density is not None:
            pset = ifcopenshell.api.pset.add_pset(self.file, product=material, name="Pset_MaterialCommon")
            ifcopenshell.api.pset.edit_pset(self.file, pset=pset, properties={"MassDensity": mass_density})
        return material

    def wall(self, name: str, thickness: float, definition=None, kind: str = "IfcMaterial", net_weight=None):
        """A wall 4 x 3 m x ``thickness`` with the material ``definition`` assigned as ``kind``."""
        wall = ifcopenshell.api.root.create_entity(self.file, ifc_class="IfcWall", name=name)
        ifcopenshell.api.spatial.assign_container(self.file, products=[wall], relating_structure=self.storey)
        matrix = np.eye(4)
        matrix[1, 3] = 10.0 * self.count  # walls apart from each other
        self.count += 1
        ifcopenshell.api.geometry.edit_object_placement(self.file, product=wall, matrix=matrix)
        representation = ifcopenshell.api.geometry.add_wall_representation(
            self.file, context=self.body, length=WALL_LENGTH, height=WALL_HEIGHT, thickness=thickness
        )
        ifcopenshell.api.geometry.assign_representation(self.file, product=wall, representation=representation)
        if definition is not None:
            ifcopenshell.api.material.assign_material(self.file, products=[wall], type=kind, material=definition)
        if net_weight is not None:
            qto = ifcopenshell.api.pset.add_qto(self.file, product=wall, name="Qto_WallBaseQuantities")
            ifcopenshell.api.pset.edit_qto(self.file, qto=qto, properties={"NetWeight": net_weight})
        return wall

    def layer_set(self, name: str, layers: list[tuple[object, float]]):
        """An IfcMaterialLayerSet of (material or None, thickness in metres), outside to inside."""
        layer_set = ifcopenshell.api.material.add_material_set(self.file, name=name, set_type="IfcMaterialLayerSet")
        for material, thickness in layers:
            layer = ifcopenshell.api.material.add_layer(self.file, layer_set=layer_set, material=material)
            ifcopenshell.api.material.edit_layer(
                self.file, layer=layer, attributes={"LayerThickness": thickness}, material=material
            )
        return layer_set

    def constituent_set(self, name: str, parts: list[tuple[object, float | None]]):
        constituents = ifcopenshell.api.material.add_material_set(self.file, name=name, set_type="IfcMaterialConstituentSet")
        for material, fraction in parts:
            constituent = ifcopenshell.api.material.add_constituent(
                self.file, constituent_set=constituents, material=material, name=material.Name
            )
            if fraction is not None:
                ifcopenshell.api.material.edit_constituent(
                    self.file, constituent=constituent, attributes={"Fraction": fraction}, material=material
                )
        return constituents

    def material_list(self, name: str, materials: list):
        listed = ifcopenshell.api.material.add_material_set(self.file, name=name, set_type="IfcMaterialList")
        for material in materials:
            ifcopenshell.api.material.add_list_item(self.file, material_list=listed, material=material)
        return listed

    def load(self, tmp_path: Path):
        path = tmp_path / "weights.ifc"
        self.file.write(str(path))
        model = load_model(path)
        return path, {e.name: e for e in model.elements.values()}, model


def _volume(thickness: float) -> float:
    return WALL_LENGTH * WALL_HEIGHT * thickness


# ---- material structure -------------------------------------------------------------------------


def test_layered_stud_partition_weighs_like_a_partition_not_like_steel(tmp_path):
    """The issue's wall: plasterboard on metal studs with an air gap, not 7850 kg/m3 for its whole volume."""
    ifc = _Model()
    board = ifc.material("Plasterboard")
    studs = ifc.material("Metal - Stud Layer")
    air = ifc.material("Air")
    layers = [(board, 0.0125), (studs, 0.092), (air, 0.025), (board, 0.0125)]
    thickness = sum(t for _, t in layers)
    ifc.wall("partition", thickness, ifc.layer_set("Partition 142", layers), kind="IfcMaterialLayerSetUsage")
    _, walls, _ = ifc.load(tmp_path)
    wall = walls["partition"]

    expected = (0.025 * 900 + 0.092 * 20 + 0.025 * 0) / thickness  # kg/m3: boards, studs, air, by thickness
    assert wall.weight_source is WeightSource.DENSITY
    assert wall.density_kg_m3 == pytest.approx(expected, rel=1e-6)
    assert 100 < wall.density_kg_m3 < 300  # a partition, a few hundred kg/m3 at most
    assert wall.weight_kg == pytest.approx(_volume(thickness) * expected, rel=1e-3)  # about 290 kg, not 134 t
    assert "Plasterboard 12.5 mm 900" in wall.weight_basis and "Air 25 mm 0" in wall.weight_basis
    assert wall.material == "Plasterboard, Metal - Stud Layer, Air"
    # the same names joined into one material name: the boards carry the mass, not "metal"
    assert density_of("Plasterboard, Metal - Stud Layer") == 900.0


def test_layer_of_unknown_material_or_only_air_gives_unknown_weight(tmp_path):
    ifc = _Model()
    board = ifc.material("Gypsum wall board")
    foo = ifc.material("Compound XR-7")
    ifc.wall("unknown layer", 0.125, ifc.layer_set("A", [(board, 0.0125), (foo, 0.1), (board, 0.0125)]), "IfcMaterialLayerSet")
    ifc.wall("studs only", 0.092, ifc.material("Metal Stud Layer"))
    ifc.wall("air only", 0.05, ifc.layer_set("B", [(ifc.material("Luftschicht"), 0.05)]), "IfcMaterialLayerSet")
    ifc.wall("no material", 0.2)
    ifc.wall("unknown name", 0.2, ifc.material("Unobtainium"))
    _, walls, _ = ifc.load(tmp_path)

    for name in ("unknown layer", "studs only", "air only", "no material", "unknown name"):
        assert walls[name].weight_kg is None, name
        assert walls[name].weight_source is WeightSource.UNKNOWN
        assert walls[name].density_kg_m3 is None
    assert "Compound XR-7" in walls["unknown layer"].weight_basis
    assert "not in the density table" in walls["unknown name"].weight_basis
    assert "stud layer" in walls["studs only"].weight_basis


def test_constituents_by_fraction_lists_only_when_densities_agree(tmp_path):
    ifc = _Model()
    concrete, timber = ifc.material("Concrete"), ifc.material("Timber")
    ifc.wall("by fraction", 0.2, ifc.constituent_set("mix", [(concrete, 0.75), (timber, 0.25)]), "IfcMaterialConstituentSet")
    ifc.wall("no fractions", 0.2, ifc.constituent_set("mix2", [(concrete, None), (timber, None)]), "IfcMaterialConstituentSet")
    ifc.wall("list of two", 0.2, ifc.material_list("list", [concrete, timber]), "IfcMaterialList")
    ifc.wall("list of same", 0.2, ifc.material_list("list2", [concrete, ifc.material("Beton C30/37")]), "IfcMaterialList")
    _, walls, _ = ifc.load(tmp_path)

    assert walls["by fraction"].density_kg_m3 == pytest.approx(0.75 * 2400 + 0.25 * 500)
    assert walls["by fraction"].weight_kg == pytest.approx(_volume(0.2) * 1925, rel=1e-3)
    assert walls["no fractions"].weight_kg is None  # shares unknown: never a guess
    assert walls["list of two"].weight_kg is None
    assert "different densities" in walls["list of two"].weight_basis
    assert walls["list of same"].density_kg_m3 == 2400.0


def test_material_mass_density_property_wins_over_the_name_when_plausible(tmp_path):
    ifc = _Model()
    ifc.wall("stated", 0.2, ifc.material("Concrete", mass_density=2150.0))
    ifc.wall("archicad zero", 0.2, ifc.material("Stahlbeton 65690", mass_density=0.0))  # ArchiCAD's "not set"
    _, walls, _ = ifc.load(tmp_path)
    assert walls["stated"].density_kg_m3 == 2150.0
    assert "MassDensity" in walls["stated"].weight_basis
    assert walls["archicad zero"].density_kg_m3 == 2500.0  # reinforced concrete, by name


# ---- names ----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, density",
    [
        ("metallic paint", None),  # "metal" only as a whole word
        ("Stairway finish", None),  # "air" only as a whole word
        ("Repair mortar", 2100.0),
        ("Radial Gradient Fill 1515460218", None),  # ArchiCAD fill names are not materials
        ("Undefined/3500", None),
        ("Solid", None),
        ("Unobtainium", None),
        ("Metal - Steel - 345 MPa", 7850.0),
        ("CONCRETE/C45/55", 2400.0),  # Tekla: class/grade
        ("C30/37", 2400.0),  # a concrete strength class alone
        ("S235JR", 7850.0),
        ("STEEL/St52-3", 7850.0),
        ("FeB500", 7850.0),
        ("Reinforced concrete C30/37", 2500.0),  # the longer entry
        ("Stone wool", 100.0),  # insulation, not stone
        ("Leichtbeton 102890359", 1600.0),
        ("Stahlbeton", 2500.0),
        ("033 - constructief staal", 7850.0),
        ("Gipskartonplatte", 900.0),
        ("Luftschicht", 0.0),
        ("Stainless steel", 7900.0),
        ("钢筋混凝土", 2500.0),
        ("金属 - 钢 43-275", 7850.0),
    ],
)
def test_names_match_whole_words_and_the_most_specific_entry(name, density):
    assert density_of(name) == density


def test_void_entries_lose_to_a_solid_material_named_beside_them():
    assert match_material("Metal - Stud Layer").entry.void  # a stud layer, not steel
    assert not match_material("Air gap, Brick").entry.void
    assert density_of("Air gap, Brick") == 1800.0


# ---- plausibility ---------------------------------------------------------------------------------


def test_weights_in_pounds_and_tonnes_are_read_in_kilograms(tmp_path):
    # The project's mass unit is the pound; one quantity names its own unit, the tonne.
    ifc = _Model()
    assignment = ifc.file.by_type("IfcUnitAssignment")[0]
    pound = ifcopenshell.api.unit.add_conversion_based_unit(ifc.file, name="pound")
    assignment.Units = [u for u in assignment.Units if u.UnitType != "MASSUNIT"] + [pound]
    concrete = ifc.material("Concrete")
    ifc.wall("pounds", 0.2, concrete, net_weight=12_000.0)
    tonnes = ifc.wall("tonnes", 0.2, concrete, net_weight=5.5)
    quantity = next(q for r in tonnes.IsDefinedBy for q in r.RelatingPropertyDefinition.Quantities)
    quantity.Unit = ifcopenshell.api.unit.add_conversion_based_unit(ifc.file, name="tonne")
    _, walls, model = ifc.load(tmp_path)

    # ifcopenshell.api writes the pound as 0.454 kg (0.45359237 exactly)
    assert model.units["mass"] == "POUND" and model.units["mass_scale_to_kg"] == pytest.approx(0.4536, abs=1e-3)
    assert walls["pounds"].weight_kg == pytest.approx(12_000.0 * 0.4536, rel=1e-3)
    assert walls["tonnes"].weight_kg == pytest.approx(5_500.0)
    assert walls["pounds"].weight_source is walls["tonnes"].weight_source is WeightSource.QUANTITY


def test_inspect_lists_implausible_weights_as_suspect_not_found(tmp_path, capsys):
    ifc = _Model()
    concrete = ifc.material("Concrete")
    volume = _volume(0.2)
    ifc.wall("agrees", 0.2, concrete, net_weight=volume * 2300)
    ifc.wall("ten times", 0.2, concrete, net_weight=volume * 24000)  # 10 x volume x density; also > 8000 kg/m3
    ifc.wall("light", 0.2, concrete, net_weight=volume * 600)  # within 50-8000 kg/m3 but 1/4 of concrete
    ifc.wall("impossible", 0.2, None, net_weight=volume * 20)  # no material: only the range can tell
    path, walls, model = ifc.load(tmp_path)

    summary = summarize(model)
    suspect = {row["name"]: row["reason"] for row in summary["suspect_weights"]}
    assert set(suspect) == {"ten times", "light", "impossible"}
    assert "outside 50-8,100 kg/m3" in suspect["impossible"]
    assert "0.25 x volume x material density" in suspect["light"]
    assert summary["weights"]["found"] == 4 and summary["weights"]["suspect"] == 3
    # every weight is in the total, with its source; the suspects are counted per class besides
    assert summary["weights"]["total_kg"] == pytest.approx(volume * (2300 + 24000 + 600 + 20), rel=1e-3)
    assert summary["weights"]["by_source_kg"] == {WeightSource.QUANTITY.value: pytest.approx(volume * 26920, rel=1e-3)}
    assert summary["suspect_by_class"]["IfcWall"]["count"] == 3

    assert main(["inspect", str(path), "--json", "--elements", "--no-progress"]) == 0
    listed = {e["name"]: e for e in json.loads(capsys.readouterr().out)["element_list"]}
    assert listed["agrees"]["weight_source"] == WeightSource.QUANTITY.value and listed["agrees"]["suspect"] is None
    assert listed["light"]["suspect"] == suspect["light"]
    assert listed["light"]["density_kg_m3"] == 2400.0
    assert main(["inspect", str(path), "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "weights: 4 found, 0 missing, 3 suspect" in text
    assert "suspect weights (3, in the totals above; each one in --json):" in text
    assert len([line for line in text.splitlines() if line.startswith("  IfcWall: 3 (")]) == 1  # one line per class


# ---- the shared real models (../shared/data/ifc) --------------------------------------------------

SHARED_FILES = sorted(p.name for p in SHARED_IFC.glob("*.ifc*")) if SHARED_IFC.is_dir() else ["(absent)"]


@pytest.fixture(scope="module")
def shared_models():
    cache: dict = {}

    def get(name: str):
        path = SHARED_IFC / name
        if not path.exists():
            pytest.skip(f"{path} is absent: the shared test data lives beside the repository, not in it")
        if name not in cache:
            cache[name] = load_model(path)
        return cache[name]

    return get


@pytest.mark.parametrize("name", SHARED_FILES)
def test_every_shared_element_with_a_material_has_a_plausible_density(shared_models, name):
    """Every element with a volume and a known material: 50-8,000 kg/m3; no weight is suspect."""
    model = shared_models(name)
    low, high = PLAUSIBLE_DENSITY_KG_M3
    for element in model.elements.values():
        if element.density_kg_m3 is not None and element.volume_m3 > 0:
            assert low <= element.density_kg_m3 <= high, (element.global_id, element.material, element.weight_basis)
        reason = weight_check(element.weight_kg, element.weight_source, element.volume_m3, element.density_kg_m3)
        assert reason is None, (element.global_id, element.material, reason)


def test_multicom_precast_concrete_weights_agree_with_their_material(shared_models):
    """Tekla's IfcQuantityWeight of each precast concrete part is within 10 % of volume x derived density."""
    model = shared_models("MULTICOM-Prefab.ifc")
    concrete = [
        e for e in model.elements.values()
        if e.weight_source is WeightSource.QUANTITY and e.material and e.material.upper().startswith("CONCRETE/")
    ]  # fmt: skip
    assert len(concrete) > 100
    ratios = np.array([e.weight_kg / (e.volume_m3 * e.density_kg_m3) for e in concrete])
    assert ratios.min() >= 0.9 and ratios.max() <= 1.1, (ratios.min(), ratios.max())


@pytest.mark.parametrize(
    "name, material, density",
    [
        ("AC20-FZK-Haus.ifc", "Leichtbeton 102890359", 1600.0),  # German, ArchiCAD layer set
        ("AC20-FZK-Haus.ifc", "Stahlbeton 65690", 2500.0),
        ("ROOT-staal.ifczip", "033 - constructief staal", 7850.0),  # Dutch
        ("engine_web-ifc_example.ifc", "Concrete, Cast-in-Place gray", 2400.0),  # Revit layer set
        ("column-extruded-solid.ifc", "S355JR", 7850.0),  # a profile set usage with a steel grade
    ],
)
def test_shared_materials_get_their_density(shared_models, name, material, density):
    model = shared_models(name)
    matching = [e for e in model.elements.values() if e.material == material]
    assert matching
    for element in matching:
        assert element.density_kg_m3 == density
        if element.weight_source is WeightSource.DENSITY:
            assert element.weight_kg == pytest.approx(element.volume_m3 * density, rel=1e-6)


def test_revit_base_plates_named_metal_stud_layer_have_unknown_weight(shared_models):
    """ifcUnit's base plates carry the wall-layer material "Metal Stud Layer": unknown, never 7850."""
    model = shared_models("ifcUnit.ifc")
    plates = [e for e in model.by_class("IfcPlate") if e.material == "Metal Stud Layer"]
    assert len(plates) == 4
    assert all(p.weight_kg is None and p.weight_source is WeightSource.UNKNOWN for p in plates)


@pytest.mark.parametrize("name", SHARED_FILES)
def test_reading_only_the_weights_gives_every_element_the_same_weight(shared_models, name):
    """``convert`` reads without the property values (``properties=False``): the same weights,
    sources, bases, materials and storeys as the full read, only ``properties`` left empty."""
    from bimrobot.bim.reader import load_model as read

    full = shared_models(name)
    lean = read(SHARED_IFC / name, properties=False)
    assert list(lean.elements) == list(full.elements)
    for key, element in lean.elements.items():
        expected = full.elements[key]
        assert (element.weight_kg, element.weight_source, element.weight_basis) == (
            expected.weight_kg, expected.weight_source, expected.weight_basis), key
        assert (element.material, element.density_kg_m3, element.storey_id) == (
            expected.material, expected.density_kg_m3, expected.storey_id), key
        assert element.properties == {}
    if name == "ifcUnit.ifc":  # Revit's "Structural/Exact Weight" property is still found
        assert any(e.weight_source is WeightSource.PROPERTY for e in lean.elements.values())
    if name == "MULTICOM-Prefab.ifc":  # and Tekla's IfcQuantityWeight
        assert any(e.weight_source is WeightSource.QUANTITY for e in lean.elements.values())


# ---- issue 34: steel stays plausible; the unknown-weight rule by class and material -------------------


def test_tekla_steel_at_8000_4_kg_m3_and_copper_are_plausible_but_20_000_is_not():
    """Tekla writes 8,000.4 kg/m3 for its steel (468 elements of one model were flagged at 50-8,000)."""
    volume = 0.05
    assert weight_check(volume * 8000.4, WeightSource.QUANTITY, volume, 7850.0) is None
    assert weight_check(volume * 8000.4, WeightSource.QUANTITY, volume, None) is None  # no material: the range
    assert weight_check(volume * 8900.0, WeightSource.QUANTITY, volume, 8900.0) is None  # copper is copper
    assert "outside 50-8,100 kg/m3" in weight_check(volume * 20000.0, WeightSource.QUANTITY, volume, None)


def test_unknown_weights_are_assumed_by_class_and_material_on_ifc_unit(shared_ifc):
    """ifcUnit's 28 bolts, 16 angle cleats (IfcColumn 'Angle_Cleat') and 4 base plates have no weight:
    steel 7,850 kg/m3, not the 2,400 of concrete; the report counts them per material assumed."""
    from bimrobot.bim.unknown_weight import UnknownWeightRule, apply_unknown_weight_rule

    model = load_model(shared_ifc("ifcUnit.ifc"), unknown_weight=UnknownWeightRule())
    report = model.unknown_weights
    assert report.materials == {"steel 7850 kg/m3": 48}
    assert dict(report.classes) == {"IfcMechanicalFastener": 28, "IfcColumn": 16, "IfcPlate": 4}
    bolt = model.by_class("IfcMechanicalFastener")[0]
    assert bolt.weight_kg == pytest.approx(bolt.volume_m3 * 7850.0)
    assert "IfcMechanicalFastener is steel" in bolt.weight_basis
    assert "steel 7850 kg/m3 for 48" in report.message()
    # applied once at loading; applying it again (as a command did) changes nothing and reports the same
    again = apply_unknown_weight_rule(model.elements.values(), UnknownWeightRule(), "ifcUnit.ifc")
    assert again.as_dict() == report.as_dict()
    # a density given on the command line applies to all of them, as before
    uniform = load_model(shared_ifc("ifcUnit.ifc"), unknown_weight=UnknownWeightRule.parse("2400"))
    assert uniform.unknown_weights.materials == {"given 2400 kg/m3": 48}
    assert UnknownWeightRule.parse("auto") == UnknownWeightRule() and UnknownWeightRule().text == "auto"
    assert UnknownWeightRule.parse(UnknownWeightRule.parse("7850").text).density_kg_m3 == 7850.0


def test_archicad_rafters_without_a_material_density_are_timber(shared_ifc):
    """AC20-FZK-Haus's 42 roof members ('Sparren', material 'Solid') are timber, 500 kg/m3."""
    from bimrobot.bim.unknown_weight import UnknownWeightRule

    model = load_model(shared_ifc("AC20-FZK-Haus.ifc"), include="IfcMember", unknown_weight=UnknownWeightRule())
    assert model.unknown_weights.materials == {"timber 500 kg/m3": 42}
