"""With the site's `idle_robots: yard`, the replay drives idle robots back to the yard as `simulate` did."""

from __future__ import annotations

import re

import numpy as np
import pytest

from bimrobot.cli import main

SITE = """\
yard: [[12.5, 4.0], [12.5, 6.0], [12.5, 8.0], [12.5, 11.0]]
robot_home: [[18.5, 4.0], [18.5, 6.0], [18.5, 8.0], [18.5, 11.0]]
construction_area: [[3.0, 1.5], [10.5, 8.0]]
idle_robots: yard
"""
RETURN_LINE = re.compile(r"\[\s*([\d.]+) s\] (\S+) has no task and returns to the yard at \(([-\d.]+), ([-\d.]+)\)")


@pytest.fixture(scope="module")
def yard_build(tmp_path_factory):
    root = tmp_path_factory.mktemp("yard")
    (root / "site.yaml").write_text(SITE)
    assert main(["example", "steel-frame", "-o", str(root / "frame.ifc")]) == 0
    assert main(["build", str(root / "frame.ifc"), "--fleet", "fleet2", "--site", str(root / "site.yaml"),
                 "-o", str(root / "out")]) == 0
    return root / "out"


def test_idle_robots_return_to_the_yard_when_the_simulation_sent_them(yard_build):
    from bimrobot.replay.inputs import load_build
    from bimrobot.replay.motion import robot_tracks

    record = load_build([yard_build])
    tracks = robot_tracks(record)
    replayed = sorted((round(t, 2), name) for name, track in tracks.items()
                      for t, label, _ in track.activities if label == "idle: returning to the yard")
    log = (yard_build / "simulation" / "events.log").read_text()
    simulated = sorted((float(m[1]), m[2]) for m in RETURN_LINE.finditer(log))
    assert replayed == simulated and len(simulated) >= 6
    # the last trip of each robot is not cut short by a new task: it ends on a yard position
    for name, track in tracks.items():
        _, x, y = track.positions[-1]
        assert np.min(np.hypot(*(record.yard - [x, y]).T)) < 1e-6, name


def test_robots_stay_where_they_finished_on_the_default_site(frame_build):
    from bimrobot.replay.inputs import load_build
    from bimrobot.replay.motion import robot_tracks

    record = load_build([frame_build])
    assert record.idle_robots == "stay"
    labels = {label for track in robot_tracks(record).values() for _, label, _ in track.activities}
    assert "idle: returning to the yard" not in labels
