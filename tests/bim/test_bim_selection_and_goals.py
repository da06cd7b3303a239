"""Issue 34, the model's side: one selection syntax (--include, --exclude and --prebuilt are selectors;
--exclude adds to the defaults), refusals before any geometry, and goals taken from where the body is."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from bimrobot.bim import load_model
from bimrobot.bim import reader
from bimrobot.bim.selection import (
    DEFAULT_PREBUILT, NOT_ASSEMBLED, add_prebuilt_option, add_selection_options, check_selection, exclusion,
)
from bimrobot.core.errors import InputError


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser()
    add_selection_options(parser, built=True)
    add_prebuilt_option(parser)
    return parser


def test_exclude_adds_to_the_default_exclusions_and_one_option_clears_them():
    parse = _parser().parse_args
    assert parse([]).exclude == NOT_ASSEMBLED
    assert parse(["--exclude", "IfcStair"]).exclude == f"{NOT_ASSEMBLED} + IfcStair"
    # either order, and the old spelling: the defaults are cleared, the user's exclusion is kept
    assert parse(["--exclude", "IfcStair", "--no-default-exclusions"]).exclude == "none + IfcStair"
    assert parse(["--no-default-exclusions", "--exclude", "IfcStair"]).exclude == "none + IfcStair"
    assert parse(["--exclude", "none"]).exclude == parse(["--no-default-exclusions"]).exclude == "none"
    # the whole exclusion handed on to a stage's --exclude gives the same exclusion again
    assert exclusion(exclusion("IfcStair")) == exclusion("IfcStair")
    assert exclusion("none + IfcStair") == "none + IfcStair"
    assert parse([]).prebuilt == DEFAULT_PREBUILT == "IfcFooting, IfcPile"


def test_an_office_excluding_stairs_still_leaves_out_its_doors_windows_and_coverings(shared_ifc):
    """Before, `--exclude IfcStair` replaced the defaults and the doors and windows were built."""
    house = shared_ifc("AC20-FZK-Haus.ifc")  # 5 doors, 11 windows, 1 stair, 4 slabs ...
    everything = check_selection(house, exclude="none")["products"]
    defaults = check_selection(house, exclude=exclusion(None))["products"]
    with_stair = check_selection(house, exclude=exclusion("IfcStair"))["products"]
    assert everything - defaults == 16  # 5 doors + 11 windows
    assert defaults - with_stair == 1  # the stair, and nothing of the defaults comes back
    assert check_selection(house, exclude=exclusion("IfcStair", defaults=False))["products"] == everything - 1


def test_excluding_a_window_leaves_out_its_frame_members_and_panes(shared_ifc):
    """IfcOpenHouse's 5 windows aggregate 20 IfcMember and 5 IfcPlate: they go with their window."""
    path = shared_ifc("IfcOpenHouse_IFC4.ifc")
    kept = load_model(path, exclude=NOT_ASSEMBLED)
    assert not kept.by_class("IfcMember") and not kept.by_class("IfcPlate")
    assert len(load_model(path, exclude="none").by_class("IfcMember")) == 20


@pytest.mark.parametrize("prebuilt", ["IfcFooting,IfcSlab", "IfcFooting, IfcSlab", "IfcFooting + IfcSlab"])
def test_prebuilt_takes_the_old_comma_list_and_selectors(shared_ifc, prebuilt):
    counts = check_selection(shared_ifc("AC20-FZK-Haus.ifc"), prebuilt=prebuilt)
    assert counts["prebuilt"] == 4  # the house's 4 slabs (no footing)


@pytest.mark.parametrize("option, value, message", [
    ("prebuilt", "IfcFootin", "--prebuilt names 'IfcFootin', which is not an IFC4 class"),
    ("include", "IfcBeam, /Pset", "--include 'IfcBeam, /Pset' is not a valid IfcOpenShell selector"),
    ("exclude", "IfcDoorr", "--exclude names 'IfcDoorr', which is not an IFC4 class"),
])
def test_selection_typos_are_refused_before_any_geometry(shared_ifc, monkeypatch, option, value, message):
    """check_selection parses the file and evaluates the selectors; the geometry is never read."""
    monkeypatch.setattr(reader, "iterate_shapes", lambda *a, **k: pytest.fail("geometry was read"))
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace("+", r"\+")) as refused:
        check_selection(shared_ifc("AC20-FZK-Haus.ifc"), **{option: value})
    assert "\n" not in str(refused.value)


def test_revit_elements_placed_at_the_origin_get_their_goal_where_their_body_is(shared_ifc, monkeypatch):
    """engine_web's Revit export places 30 concrete columns, 7 slabs and footings and 4 beams (proxies)
    at (0, 0, 0) while their bodies stand 96-110 m away (and 11 steel columns 3.5 m below their bodies):
    their origin is moved onto the body, which does not move."""
    path = shared_ifc("engine_web-ifc_example.ifc")
    model = load_model(path)
    moved = {r.global_id: r for r in model.relocated}
    by_class = {}
    for r in model.relocated:
        by_class[r.ifc_class] = by_class.get(r.ifc_class, 0) + 1
    assert by_class == {"IfcColumn": 30, "IfcSlab": 7, "IfcBuildingElementProxy": 4}
    monkeypatch.setattr(reader, "ORIGIN_OFF_BODY_M", float("inf"))  # the file's placements, as read before
    as_placed = load_model(path)
    for gid, relocation in moved.items():
        element, before = model.element(gid), as_placed.element(gid)
        np.testing.assert_allclose(element.world_bounds, before.world_bounds, atol=1e-9)  # the body stays
        low, high = element.world_bounds
        assert np.all(element.position[:2] >= low[:2] - 1e-9) and np.all(element.position[:2] <= high[:2] + 1e-9)
        assert element.position[2] == pytest.approx(low[2], abs=1e-6)  # the body's bottom centre
        assert np.allclose(before.position, relocation.file_origin, atol=1e-3)
        assert relocation.distance_m > 1.0
    far = max(model.relocated, key=lambda r: r.distance_m)
    assert far.file_origin == (0.0, 0.0, 0.0) and far.distance_m > 100


def test_ifc_unit_bolts_placed_at_the_origin_are_found_where_they_fasten(ifc_unit_model):
    """ifcUnit's 28 bolts are placed at (0, 0, 0), 7-12 m from the joints they fasten."""
    assert len(ifc_unit_model.relocated) == 28
    assert {r.ifc_class for r in ifc_unit_model.relocated} == {"IfcMechanicalFastener"}
    for r in ifc_unit_model.relocated:
        low, high = ifc_unit_model.element(r.global_id).world_bounds
        assert np.linalg.norm(np.array(r.origin) - (low + high) / 2) < 0.2  # within the bolt's own size


def test_inspect_says_which_elements_were_placed_away_from_their_bodies(shared_ifc, capsys):
    import json

    from bimrobot.cli import main

    path = str(shared_ifc("engine_web-ifc_example.ifc"))
    assert main(["inspect", path, "--no-progress"]) == 0
    assert "placed away from their bodies: 41 elements (30 IfcColumn, 7 IfcSlab, 4 IfcBuildingElementProxy)" in capsys.readouterr().out
    assert main(["inspect", path, "--json", "--no-progress"]) == 0
    goals = json.loads(capsys.readouterr().out)["goals_from_body"]
    assert goals["count"] == len(goals["elements"]) == 41
    assert all(e["moved_m"] > 1.0 and e["name"] for e in goals["elements"])
