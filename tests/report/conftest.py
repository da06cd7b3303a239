"""One build of the built-in steel frame, shared by the report's tests (about 20 s on 2 cores).

The build starts on a Friday at 15:50, so its 27 minutes of work run over the weekend on the default
work calendar (Monday-Friday 07:00-16:00): the dates must jump from Friday 16:00 to Monday 07:00.
"""

from __future__ import annotations

import pytest

#: t = 0 s of the test build: Friday 5 March 2027, 10 minutes before the end of the working day.
START = "2027-03-05T15:50"


@pytest.fixture(scope="session")
def frame_build(tmp_path_factory):
    """The output folder of `bimrobot build` on the steel frame (fleet2, default site), started at START."""
    pytest.importorskip("plotly", reason="the report extra is not installed (pip install 'bimrobot[report]')")
    pytest.importorskip("jinja2", reason="the report extra is not installed (pip install 'bimrobot[report]')")
    from bimrobot.cli import main

    root = tmp_path_factory.mktemp("report")
    model, out = root / "frame.ifc", root / "build"
    assert main(["example", "steel-frame", "-o", str(model)]) == 0
    assert main(["build", str(model), "-o", str(out), "--start", START]) == 0
    return out
