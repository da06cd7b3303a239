"""One site for every part: `convert --layout yard` lays the components out on the site file's yard."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from bimrobot.cli import main
from bimrobot.site.site import default_site, load_site


@pytest.fixture(scope="module")
def frame(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("model") / "frame.ifc"
    assert main(["example", "steel-frame", "-o", str(path)]) == 0
    return path


def _model_poses(package: Path) -> dict[str, np.ndarray]:
    """Model name -> (x, y, z) of its pose in the world file, metres."""
    world = (package / "worlds" / "construction_site.sdf").read_text()
    poses = {}
    for name, pose in re.findall(r"<include>\s*<uri>[^<]*</uri>\s*<name>([^<]+)</name>\s*<pose>([^<]+)</pose>", world):
        poses[name] = np.array([float(v) for v in pose.split()[:3]])
    return poses


def test_yard_of_a_site_file_is_where_the_components_wait(frame, tmp_path):
    site = tmp_path / "site.yaml"
    site.write_text("yard: [[40.0, -5.0], [40.0, 5.0]]\nmodel_offset: [0.0, 0.0]\n")
    out = tmp_path / "pkg"
    assert main(["convert", str(frame), "-o", str(out), "--layout", "yard", "--site", str(site), "--no-progress"]) == 0
    poses = _model_poses(out)
    assert len(poses) == 88
    xy = np.array([p[:2] for p in poses.values()])
    # model offset 0: the model frame is the site frame, so the yard starts at (40, -5)
    assert xy[:, 0].min() >= 40.0 - 1e-6
    assert xy[:, 1].min() >= -5.0 - 1e-6 and xy[:, 1].min() < -4.0


def test_default_yard_is_the_thesis_site_in_the_model_frame(frame, tmp_path):
    out = tmp_path / "pkg"
    assert main(["convert", str(frame), "-o", str(out), "--layout", "yard", "--no-progress"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["options"]["layout"] == "yard"
    poses = _model_poses(out)
    installed = tmp_path / "installed"
    assert main(["convert", str(frame), "-o", str(installed), "--no-progress"]) == 0
    building = np.array([p[:2] for p in _model_poses(installed).values()])
    site = default_site()
    # the building's centre sits in the middle of fig. 4.11's construction area, the yard at x = 12.5 m
    offset = site.construction_area[0][0] + site.construction_area[1][0]
    yard_x = min(p[0] for p in poses.values())
    centre_x = (building[:, 0].min() + building[:, 0].max()) / 2
    assert yard_x - centre_x == pytest.approx(12.5 - offset / 2, abs=0.5)


def test_site_option_needs_the_yard_layout(frame, tmp_path, capsys):
    site = tmp_path / "site.yaml"
    site.write_text("yard: [[40.0, -5.0]]\n")
    assert main(["convert", str(frame), "-o", str(tmp_path / "pkg"), "--site", str(site)]) == 2
    assert "--layout yard" in capsys.readouterr().err


def test_a_bad_site_file_is_one_sentence_with_its_line(tmp_path):
    site = tmp_path / "site.yaml"
    site.write_text("yard: [[40.0, -5.0]]\nidle_robots: sometimes\n")
    with pytest.raises(Exception, match=r"site.yaml line 2.*idle_robots"):
        load_site(site)


def test_a_real_building_gets_a_site_of_its_own_and_the_frame_keeps_fig_4_11(tmp_path, shared_ifc):
    """With no site file: the thesis' frame fits fig. 4.11's 7.5 x 6.5 m area and keeps it; a house of
    13 x 11 m gets a derived site whose yard and robot homes lie off its footprint."""
    from bimrobot.bim import load_model
    from bimrobot.bim.examples import steel_frame
    from bimrobot.site.site import derive_site, footprint, on_the_building, site_for

    frame = load_model(steel_frame(tmp_path / "frame.ifc"))
    assert site_for(None, frame.elements.values()).source == default_site().source
    house = load_model(shared_ifc("AC20-FZK-Haus.ifc")).elements.values()
    site = site_for(None, house)
    assert site == derive_site(house) and "derived from the building" in site.source
    low, high = (corner + np.asarray(site.model_offset) for corner in footprint(house))
    (ax0, ay0), (ax1, ay1) = site.construction_area
    assert ax0 <= low[0] - 2.99 and ax1 >= high[0] + 2.99 and ay0 <= low[1] - 2.99 and ay1 >= high[1] + 2.99
    for x, y in (*site.yard, *site.robot_home):  # none on the construction area, let alone the building
        assert not (ax0 <= x <= ax1 and ay0 <= y <= ay1), (x, y)
    assert on_the_building(site, house) is None
    # fig. 4.11 forced on the house puts its yard inside the building: said in one sentence
    thesis = site_for("thesis", house)
    warning = on_the_building(thesis, house)
    assert warning and "lie on the building" in warning and "yard position (12.5, 4)" in warning
