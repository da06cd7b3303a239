"""Fixtures for the bim tests: the greenhouse example, written and read once per session (the steel
frame and ifcUnit.ifc come from tests/conftest.py)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def greenhouse_ifc(tmp_path_factory):
    from bimrobot.bim.examples import greenhouse

    return greenhouse(tmp_path_factory.mktemp("examples") / "greenhouse.ifc")


@pytest.fixture(scope="session")
def greenhouse_model(greenhouse_ifc):
    from bimrobot.bim import load_model

    return load_model(greenhouse_ifc)

