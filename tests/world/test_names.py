"""GlobalIds become file- and SDF-safe names and come back unchanged."""

import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bimrobot.world.names import global_id_from_safe_name, ros_package_name, safe_name

GLOBAL_ID_ALPHABET = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_$"


def test_dollar_becomes_dash_and_back():
    assert safe_name("2O2Fr$t4X7Zf8NOew3FLOH") == "2O2Fr-t4X7Zf8NOew3FLOH"
    assert global_id_from_safe_name("2O2Fr-t4X7Zf8NOew3FLOH") == "2O2Fr$t4X7Zf8NOew3FLOH"


@given(st.text(alphabet=GLOBAL_ID_ALPHABET, min_size=22, max_size=22))
def test_every_global_id_round_trips_to_a_portable_name(global_id):
    name = safe_name(global_id)
    assert re.fullmatch(r"[A-Za-z0-9_\-]{22}", name)
    assert global_id_from_safe_name(name) == global_id


@given(st.text(min_size=1))
def test_any_id_round_trips(text):
    name = safe_name(text)
    assert "::" not in name and "/" not in name and "$" not in name
    assert global_id_from_safe_name(name) == text


def test_names_it_cannot_have_produced_are_refused():
    with pytest.raises(ValueError):
        global_id_from_safe_name("has space")


def test_ros_package_name_is_valid():
    assert ros_package_name("Frame-Pkg 2") == "frame_pkg_2"
    assert ros_package_name("2024_site") == "bim_2024_site"
