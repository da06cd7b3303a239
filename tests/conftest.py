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
