"""Fixtures of every test: the built-in steel frame (written and read once per session), the shared
real data beside the repository (skipped when absent) and a free loopback port; and how ``make test``
shares the files between its workers.

Paths and helpers for module-level use (parametrize lists) are in ``shared_data``.

Collecting the tests imports every test module, so a module imports at its top only what collection needs.
Heavy libraries (torch and Stable-Baselines3, numba, trimesh and SciPy, MuJoCo, rdflib) are imported by an
autouse module fixture, ``_heavy_imports``, that binds them as the module's globals when its tests run; a
module that needs an optional extra skips with a reason found by ``importlib.util.find_spec`` (found, not
imported). ``pytest --collect-only -q -p no:cacheprovider`` stays under 10 s of CPU.
"""

from __future__ import annotations

import socket

import pytest

from shared_data import REPO_ROOT, SHARED, SHARED_IFC, SHARED_ONTOLOGIES, shared_file  # noqa: F401 (re-exported)

def _still_ignored(signum, frame) -> None:
    """A stop signal the test run was started to ignore: still ignored here (see pytest_configure)."""


def pytest_configure(config):
    """Stop signals reach the commands the tests start as they do from a terminal. A suite started as a
    background job inherits SIGINT ignored, one under ``nohup`` SIGHUP; every command it starts would
    inherit that too, and bimrobot rightly keeps a signal its caller ignores, so the tests that stop a
    command with that signal would wait for nothing (``replay --serve`` "not exited within 60 s", a
    SIGHUP'd command exiting 0). Such a signal gets a handler that does nothing: this run still ignores
    it, and a command it starts begins with the signal at its default (exec resets handled signals)."""
    import signal

    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(signum) is signal.SIG_IGN:
            signal.signal(signum, _still_ignored)


REAL_MODELS = "tests/test_real_models.py"
"""The file that runs every shared model through every command: ~11 minutes of module fixtures."""

REAL_MODEL_SETUP_S = {"AC20-FZK-Haus.ifc": 228.0, "ROOT-staal.ifczip": 97.0}
"""Measured set-up of REAL_MODELS' pipeline per model (s, CI, two workers); the others take less."""


def work_unit(nodeid: str) -> str:
    """What one xdist worker runs together under ``--dist loadfile`` (``make test``): a test file (its
    module fixtures are computed once), but one model of REAL_MODELS (``<file>[<model>]``), so that
    two workers share that file and still compute no model twice."""
    path, _, rest = nodeid.partition("::")
    if path == REAL_MODELS and rest.endswith("]"):
        return f"{path}[{rest[rest.index('[') + 1:-1]}]"
    return path


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile`` with :func:`work_unit` as the unit, handed out in the order the workers
    collected (:func:`pytest_collection_modifyitems`), not by their number of tests."""
    if config.getoption("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class ByWorkUnit(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return work_unit(nodeid)

    config.option.loadscopereorder = False
    return ByWorkUnit(config, log)


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    """On an xdist worker: the real models first, the dearest first, so that the two workers start on
    them; then the files with the most tests first (xdist's own order otherwise). The order within a
    unit is kept. Every worker sorts alike, as xdist requires."""
    if not hasattr(config, "workerinput"):
        return
    sizes: dict[str, int] = {}
    for item in items:
        sizes[work_unit(item.nodeid)] = sizes.get(work_unit(item.nodeid), 0) + 1
    first_seen = {unit: index for index, unit in enumerate(sizes)}

    def rank(item) -> tuple:
        unit = work_unit(item.nodeid)
        if unit.startswith(REAL_MODELS + "["):
            model = unit[len(REAL_MODELS) + 1:-1]
            size = (SHARED_IFC / model).stat().st_size if (SHARED_IFC / model).exists() else 0  # absent: its tests skip
            return (0, -REAL_MODEL_SETUP_S.get(model, 0.0), -size, first_seen[unit])
        return (1, -sizes[unit], first_seen[unit])

    items.sort(key=rank)


@pytest.fixture(scope="session")
def steel_frame_ifc(tmp_path_factory):
    """The thesis' chapter-4 steel frame (``bimrobot example steel-frame``: IFC4, metres, bolted joints),
    written once for the session. Read it, never change it: a test that edits the file copies it first."""
    from bimrobot.bim.examples import steel_frame

    return steel_frame(tmp_path_factory.mktemp("examples") / "steel_frame.ifc")


@pytest.fixture(scope="session")
def steel_frame_model(steel_frame_ifc):
    """The steel frame's BuildingModel (``load_model``), read once for the session: do not change it."""
    from bimrobot.bim import load_model

    return load_model(steel_frame_ifc)


@pytest.fixture(scope="session")
def ifc_unit_model():
    """../shared/data/ifc/ifcUnit.ifc read once for the session (skipped when ../shared is absent)."""
    from bimrobot.bim import load_model

    return load_model(shared_file("ifc", "ifcUnit.ifc"))


@pytest.fixture(scope="session")
def shared_ifc():
    """A function: shared_ifc("ifcUnit.ifc") -> Path (skips when ../shared is absent)."""
    return lambda name: shared_file("ifc", name)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="session")
def free_port():
    """A function: free_port() -> a TCP port on 127.0.0.1 that nothing listens on now (for a server
    the test starts; a call per server)."""
    return _free_port


@pytest.fixture(autouse=True, scope="session")
def _sb3_logs_in_the_test_folder(tmp_path_factory):
    """Stable-Baselines3 makes a ``SB3-<date>`` folder in the system temp folder for every model that
    learns without its own logger; tests that build bare SB3 models keep those inside pytest's folder."""
    import os

    previous = os.environ.get("SB3_LOGDIR")
    os.environ["SB3_LOGDIR"] = str(tmp_path_factory.mktemp("sb3-logs"))
    yield
    if previous is None:
        os.environ.pop("SB3_LOGDIR", None)
    else:
        os.environ["SB3_LOGDIR"] = previous
