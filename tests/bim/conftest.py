"""Fixtures for the bim tests: the built-in example buildings, written once per session."""

from __future__ import annotations

import pytest

from bimrobot.bim import load_model
from bimrobot.bim.examples import greenhouse, steel_frame


@pytest.fixture(scope="session")
def steel_frame_ifc(tmp_path_factory):
    return steel_frame(tmp_path_factory.mktemp("examples") / "steel_frame.ifc")


@pytest.fixture(scope="session")
def greenhouse_ifc(tmp_path_factory):
    return greenhouse(tmp_path_factory.mktemp("examples") / "greenhouse.ifc")


@pytest.fixture(scope="session")
def steel_frame_model(steel_frame_ifc):
    return load_model(steel_frame_ifc)


@pytest.fixture(scope="session")
def greenhouse_model(greenhouse_ifc):
    return load_model(greenhouse_ifc)


@pytest.fixture(scope="session")
def ifc_unit_model():
    """../shared/data/ifc/ifcUnit.ifc read once for the session (skipped when ../shared is absent)."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "ifc" / "ifcUnit.ifc"
    if not path.exists():
        pytest.skip(f"{path} is absent: the shared test data lives beside the repository, not in it")
    return load_model(path)
