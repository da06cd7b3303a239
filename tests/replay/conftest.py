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
