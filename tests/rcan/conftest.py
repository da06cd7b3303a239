"""Fixtures of the RCAN tests (helpers in rcan_helpers.py)."""

from __future__ import annotations

import pytest

from rcan_helpers import TABLE_5_2, frame_schedule, two_crane_capabilities


def pytest_configure(config):
    config.addinivalue_line("markers", "chaos: fault injection against a whole RCAN deployment (bounded, about 3 minutes)")


@pytest.fixture
def cranes():
    """Capability table with two 1000 kg mobile manipulators (crane_a, crane_b)."""
    return two_crane_capabilities()


@pytest.fixture
def table_5_2():
    return TABLE_5_2


@pytest.fixture
def schedule_csv(tmp_path):
    """A 4-column schedule CSV (12 rows -> 24 RCAN activities) in tmp_path."""
    return frame_schedule(tmp_path / "schedule.csv")
