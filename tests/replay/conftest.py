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
def frame_pair_replay(frame_build, tmp_path_factory):
    """(rrd path, summary) of the steel frame's replay from its `convert` package and `simulate` folder
    (the build without RCAN's timelines: a lighter recording for the browser)."""
    from bimrobot.replay import write_replay

    rrd = tmp_path_factory.mktemp("pair-replay") / "frame.rrd"
    summary = write_replay(frame_build / "package", rrd, simulation=frame_build / "simulation")
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
