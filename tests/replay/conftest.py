"""Fixtures of the replay tests: the built-in steel frame built once, and its replay."""

from __future__ import annotations

import pytest

from bimrobot.cli import main


def pytest_configure(config):
    # Registered here too so that this folder runs under --strict-markers before pyproject lists it.
    config.addinivalue_line("markers", "browser: needs Debian's chromium and chromium-driver (headless, WebGL via SwiftShader)")


@pytest.fixture(scope="session")
def frame_build(tmp_path_factory):
    """A `bimrobot build` output folder of the built-in steel frame with fleet2 (the thesis' site)."""
    root = tmp_path_factory.mktemp("frame")
    assert main(["example", "steel-frame", "-o", str(root / "frame.ifc")]) == 0
    assert main(["build", str(root / "frame.ifc"), "--fleet", "fleet2", "-o", str(root / "out")]) == 0
    return root / "out"


@pytest.fixture(scope="session")
def frame_replay(frame_build, tmp_path_factory):
    """(rrd path, summary) of the steel frame's replay."""
    from bimrobot.replay import write_replay

    rrd = tmp_path_factory.mktemp("replay") / "build.rrd"
    summary = write_replay(frame_build, rrd)
    return rrd, summary


@pytest.fixture(scope="session")
def frame_pair(steel_frame_ifc, tmp_path_factory):
    """(package, simulation): the steel frame's `convert --layout yard` package and its `simulate` folder
    with fleet2 on the thesis' site, without the rest of a build (graph, RCAN, report, replay): what
    a replay of the schedule needs, in a third of a build's time."""
    root = tmp_path_factory.mktemp("frame-pair")
    common = ["--no-progress"]
    assert main(["convert", str(steel_frame_ifc), "-o", str(root / "pkg"), "--layout", "yard", "--no-preview",
                 "--no-maps", *common]) == 0
    assert main(["simulate", str(steel_frame_ifc), "--fleet", "fleet2", "-o", str(root / "sim"), "--no-gantt",
                 *common]) == 0
    return root / "pkg", root / "sim"


@pytest.fixture(scope="session")
def frame_pair_replay(frame_pair, tmp_path_factory):
    """(rrd path, summary) of the steel frame's replay from its `convert` package and `simulate` folder
    (:func:`frame_pair`: no RCAN timelines, a lighter recording for the browser)."""
    from bimrobot.replay import write_replay

    package, simulation = frame_pair
    rrd = tmp_path_factory.mktemp("pair-replay") / "frame.rrd"
    summary = write_replay(package, rrd, simulation=simulation)
    return rrd, summary


@pytest.fixture(scope="session")
def prefab_pair_replay(shared_ifc, tmp_path_factory):
    """(rrd path, summary) of MULTICOM-Prefab, the shared model with the most elements (301 in 118
    components), built by the site crane from its `convert --layout yard` package and `simulate` folder
    (as bench/replay_load.py builds it): a large model, drawn as boxes by state (bimrobot.replay.compact).
    Skipped without ../shared."""
    from bimrobot.replay import write_replay

    model = shared_ifc("MULTICOM-Prefab.ifc")
    root = tmp_path_factory.mktemp("prefab")
    common = ["--no-progress", "--unknown-weight", "2400"]
    assert main(["convert", str(model), "-o", str(root / "pkg"), "--layout", "yard", "--no-preview", "--no-maps",
                 *common]) == 0
    assert main(["simulate", str(model), "--fleet", "site-crane", "-o", str(root / "sim"), "--no-gantt",
                 "--prebuilt", "IfcFooting,IfcPile", *common]) == 0
    rrd = root / "prefab.rrd"
    return rrd, write_replay(root / "pkg", rrd, simulation=root / "sim")
