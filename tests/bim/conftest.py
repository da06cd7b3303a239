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
