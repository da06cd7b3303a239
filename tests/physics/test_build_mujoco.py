"""`bimrobot build --backend mujoco`: the chapter-4 steel frame's schedule executed by robots acting
physically in MuJoCo."""

import importlib.util
import json
import os

import pytest

# found, not imported: MuJoCo and mink cost about 1 s of imports, paid when the tests run, not at collection
MISSING = [name for name in ("mujoco", "mink", "pyastar2d") if importlib.util.find_spec(name) is None]
if MISSING:
    pytest.skip(f"{', '.join(MISSING)} not installed (the physics extra)", allow_module_level=True)

from bimrobot.bim.examples import steel_frame  # noqa: E402
from bimrobot.cli import main  # noqa: E402


@pytest.mark.slow
@pytest.mark.timeout(3600)  # the project's 600 s would cut it
@pytest.mark.skipif(os.environ.get("BIMROBOT_PHYSICS_FRAME") != "1",
                    reason="runs for about 20 min on a 2-core machine (6,400 simulated s); BIMROBOT_PHYSICS_FRAME=1 runs it")
def test_build_with_the_mujoco_backend_assembles_the_steel_frame_at_its_bim_poses(tmp_path):
    model = steel_frame(tmp_path / "frame.ifc")
    out = tmp_path / "out"
    code = main(["build", str(model), "--fleet", "fleet2", "--backend", "mujoco", "-o", str(out)])
    report = json.loads((out / "rcan" / "report.json").read_text())
    assert json.loads((out / "build.json").read_text())["backend"] == "mujoco"
    assert (out / "rcan" / "state.db.trajectory.csv").exists()
    assert "state.db.trajectory.csv" in (out / "README.md").read_text()
    assert code == 0 and report["status"] == "completed", report["escalations"][:2]
    assert len(report["component_states"]) == 12 and set(report["component_states"].values()) == {"Assembled"}
    placed = report["backend_summary"]["placement_error"]
    assert set(placed) == set(report["component_states"])
    assert all(e["position_mm"] < 10.0 and e["angle_deg"] < 1.0 for e in placed.values()), placed
    assert report["backend_summary"]["chassis_overlap_s"] == {}  # no robot drove through another
