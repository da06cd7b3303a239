"""Shared test fixtures: paths to the project's shared real data (skipped when absent)."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED = REPO_ROOT.parent / "shared"
SHARED_IFC = SHARED / "data" / "ifc"
SHARED_ONTOLOGIES = SHARED / "data" / "ontologies"


def shared_file(*parts: str) -> Path:
    """Path to a file under ../shared/data, or skip the test with the reason when it is absent."""
    path = SHARED.joinpath("data", *parts)
    if not path.exists():
        pytest.skip(f"{path} is absent: the shared test data lives beside the repository, not in it")
    return path


@pytest.fixture
def shared_ifc():
    """A function: shared_ifc("ifcUnit.ifc") -> Path (skips when ../shared is absent)."""
    return lambda name: shared_file("ifc", name)


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
