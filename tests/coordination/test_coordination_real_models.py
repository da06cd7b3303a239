"""simulate on every shared real model with its walls and slabs cast in place (the documented --prebuilt
workaround that used to end in a KeyError), and the pre-flight check that lists everything at once."""

import json

import pytest

from bimrobot.cli import main
from bimrobot.coordination.schedule import load_schedule_csv
from shared_data import SHARED_IFC, shared_models

MODELS = [path.name for path in shared_models()]
CAST_IN_PLACE = "IfcFooting,IfcSlab,IfcWall,IfcWallStandardCase"

pytestmark = pytest.mark.skipif(not MODELS, reason=f"{SHARED_IFC} is absent: the shared real models live beside the repository")


def _simulate(capsys, *argv) -> tuple[int, str, str]:
    code = main(["simulate", *argv, "--no-gantt", "--no-progress"])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.slow
@pytest.mark.parametrize("name", MODELS)
def test_every_model_with_walls_and_slabs_prebuilt_finishes_or_says_why_in_one_sentence(name, tmp_path, capsys):
    import ifcopenshell

    ifc = ifcopenshell.open(str(SHARED_IFC / name))
    if not any(ifc.by_type(c) for c in CAST_IN_PLACE.split(",")):
        pytest.skip(f"{name} has no footing, slab or wall: --prebuilt changes nothing (tests/test_real_models.py simulates it)")
    out = tmp_path / "sim"
    code, printed, err = _simulate(capsys, str(SHARED_IFC / name), "--fleet", "site-crane", "--prebuilt", CAST_IN_PLACE, "-o", str(out))
    assert code in (0, 2), err
    if code == 2:
        assert err.count("\n") == 1 and err.startswith("bimrobot simulate: error: "), err
        assert not out.exists()
        return
    summary = json.loads((out / "summary.json").read_text())
    assert summary["makespan_s"] > 0
    rows = load_schedule_csv(out / "schedule.csv")  # bimrobot's own loader takes what simulate wrote
    built = {c for c in summary["smart_components"]["prebuilt"]}
    assert not [r for r in rows if r["GlobalId"] in built and r["Activity"] != "assemble"]  # prebuilt: no robot transport
    states = json.loads((out / "states.json").read_text())
    assert all(history[-1][1] == "Assembled" for history in states.values())


@pytest.mark.parametrize(
    "name, extra",
    [
        ("AC20-FZK-Haus.ifc", []),  # the upper slab rests on a robot-built downstand beam and the stair
        # its one IfcBuildingElementProxy is a 25 m polyline beam no 15 m crane crew can place: leave it out
        ("engine_web-ifc_example.ifc", ["--exclude", "IfcFurnishingElement, IfcDoor, IfcWindow, IfcCovering, IfcOpeningElement, IfcBuildingElementProxy"]),
    ],
)
def test_the_prebuilt_workaround_builds_the_house_and_the_office(name, extra, tmp_path, capsys):
    out = tmp_path / "sim"
    # per joint: a component's PositionFixed state is the moment what rests on it may be made (per node it
    # is its first fixed node, which has no state event of its own)
    code, printed, err = _simulate(capsys, str(SHARED_IFC / name), "--fleet", "site-crane", "--prebuilt", CAST_IN_PLACE,
                                   "--per-joint", "-o", str(out), *extra)
    assert code == 0, err
    summary = json.loads((out / "summary.json").read_text())
    later = summary["smart_components"]["prebuilt_after_supports"]
    if name == "AC20-FZK-Haus.ifc":
        assert later  # the upper slab and the walls on it wait for the beam under the slab
        events = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
        made = {e["component"]: e["time"] for e in events if e["event"] == "prebuilt_in_place"}
        assert set(made) == set(later)
        fixed = {}
        for e in events:
            if e["event"] == "state" and e["state"] == "PositionFixed":
                fixed.setdefault(e["component"], e["time"])
        supporters = {}
        for e in events:
            if e["event"] == "prebuilt_in_place":
                supporters[e["component"]] = e["supporters"]
        for gid, time in made.items():  # made exactly when the last thing it rests on was fixed
            assert time == pytest.approx(max(fixed.get(s, 0.0) for s in supporters[gid]), abs=1e-3)
    lbd_schedule = pytest.importorskip("bimrobot.schedule.csv")
    from bimrobot.bim import load_model

    schedule = lbd_schedule.load_schedule_csv(out / "schedule.csv", load_model(SHARED_IFC / name))
    assert len(schedule.activities) == len(load_schedule_csv(out / "schedule.csv"))


def test_the_pre_flight_check_lists_every_class_the_fleet_cannot_build_in_one_message(tmp_path, capsys):
    code, _, err = _simulate(capsys, str(SHARED_IFC / "engine_web-ifc_example.ifc"), "--fleet", "fleet2", "-o", str(tmp_path / "sim"))
    assert code == 2 and err.count("\n") == 1
    assert "fleet fleet2 cannot build 70 of 115 components: " in err
    for phrase in ("IfcColumn need a carrier for up to", "IfcBeam need a carrier", "IfcWallStandardCase need", "IfcSlab need"):
        assert phrase in err
    assert "the fleet carries at most 300 kg on up to 4 x 1 m" in err and "--fleet site-crane" in err


def test_precast_units_are_simulated_as_units_and_by_element_on_request(tmp_path, capsys):
    model = str(SHARED_IFC / "MULTICOM-Prefab.ifc")
    code, printed, err = _simulate(capsys, model, "--fleet", "site-crane", "-o", str(tmp_path / "units"))
    assert code == 0, err
    assert printed.startswith("118 components, 118 of them assembly units")
    rows = load_schedule_csv(tmp_path / "units" / "schedule.csv")
    assert len({r["GlobalId"] for r in rows if r["Activity"] == "transport"}) == 118  # one lift per unit
    lbd_schedule = pytest.importorskip("bimrobot.schedule.csv")
    from bimrobot.bim import load_model

    # the rcan/graph side takes the assemblies' GlobalIds as the model's own
    assert len(lbd_schedule.load_schedule_csv(tmp_path / "units" / "schedule.csv", load_model(model)).activities) == len(rows)
    code, printed, err = _simulate(capsys, model, "--fleet", "site-crane", "--by-element", "-o", str(tmp_path / "parts"))
    assert code == 0, err
    parts = json.loads((tmp_path / "parts" / "summary.json").read_text())["smart_components"]
    assert parts["components"] > 200 and parts["assembly_units"] == 0
