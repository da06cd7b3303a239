"""GlobalIds become file- and SDF-safe names and come back unchanged; model text never carries control
characters into a terminal or an XML file."""

import re
import xml.etree.ElementTree as ET

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bimrobot.core.io import printable
from bimrobot.core.names import (
    MAX_NAME_LENGTH,
    global_id_from_safe_name,
    is_shortened,
    ros_package_name,
    safe_name,
)

GLOBAL_ID_ALPHABET = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_$"
PORTABLE = re.compile(r"[A-Za-z0-9_.\-]+")


def test_dollar_becomes_dash_and_back():
    assert safe_name("2O2Fr$t4X7Zf8NOew3FLOH") == "2O2Fr-t4X7Zf8NOew3FLOH"
    assert global_id_from_safe_name("2O2Fr-t4X7Zf8NOew3FLOH") == "2O2Fr$t4X7Zf8NOew3FLOH"


def test_duplicate_key_is_a_distinct_reversible_name():
    """bimrobot keys the second element of a duplicated GlobalId as <GlobalId>#<step id>."""
    assert safe_name("2O2Fr$t4X7Zf8NOew3FLOH#37") == "2O2Fr-t4X7Zf8NOew3FLOH.2337"
    assert global_id_from_safe_name("2O2Fr-t4X7Zf8NOew3FLOH.2337") == "2O2Fr$t4X7Zf8NOew3FLOH#37"


@given(st.text(alphabet=GLOBAL_ID_ALPHABET, min_size=22, max_size=22))
def test_every_global_id_round_trips_to_a_portable_name(global_id):
    name = safe_name(global_id)
    assert re.fullmatch(r"[A-Za-z0-9_\-]{22}", name)
    assert global_id_from_safe_name(name) == global_id


@given(st.text(min_size=1))
def test_any_id_becomes_a_portable_name_that_round_trips_unless_shortened(text):
    name = safe_name(text)
    assert PORTABLE.fullmatch(name) and name not in (".", "..") and len(name) <= MAX_NAME_LENGTH
    assert "::" not in name and "$" not in name
    if is_shortened(name):
        with pytest.raises(ValueError, match="shortened"):
            global_id_from_safe_name(name)
    else:
        assert global_id_from_safe_name(name) == text


@pytest.mark.parametrize(
    "text, expected",
    [
        ("__model__", "__model_.5f"),  # SDFormat reserves names that start and end with "__"
        ("world", "worl.64"),  # ... and "world"
        ("../..", ".2e.2e.2f.2e.2e"),
        ("a/b", "a.2fb"),
        ("tab\there", "tab.09here"),
        ("\x1b[31m", ".1b.5b31m"),
    ],
)
def test_reserved_and_path_like_ids_are_escaped_reversibly(text, expected):
    assert safe_name(text) == expected
    assert global_id_from_safe_name(expected) == text


def test_over_long_ids_are_shortened_with_a_hash_and_stay_distinct():
    long_a, long_b = "A" * 300, "A" * 299 + "B"
    name_a, name_b = safe_name(long_a), safe_name(long_b)
    assert len(name_a) <= MAX_NAME_LENGTH and len(name_b) <= MAX_NAME_LENGTH
    assert name_a != name_b and is_shortened(name_a)
    assert len(f"{name_a}_collision.stl") <= 255
    multibyte = safe_name("混" * 100)  # 9 characters per ideograph once escaped: never cut inside an escape
    assert re.fullmatch(r"(?:\.[0-9a-f]{2})+\.\.[0-9a-f]{20}", multibyte)
    assert not is_shortened(safe_name("A" * 200)) and safe_name("A" * 200) == "A" * 200


def test_names_it_cannot_have_produced_are_refused():
    for name in ("has space", "world", "__model__", "a.5fb", "a.zz"):
        with pytest.raises(ValueError):
            global_id_from_safe_name(name)


@given(st.text())
def test_printable_text_has_no_control_character_and_fits_in_xml(text):
    shown = printable(text)
    assert shown.isprintable()
    element = ET.Element("description")
    element.text = shown
    assert (ET.fromstring(ET.tostring(element, encoding="unicode")).text or "") == shown


def test_printable_keeps_letters_of_any_script():
    assert printable("标高 1 Gelände") == "标高 1 Gelände"
    assert printable("bad\x07\nname") == "bad\\x07\\nname"


def test_ros_package_name_is_valid():
    assert ros_package_name("Frame-Pkg 2") == "frame_pkg_2"
    assert ros_package_name("2024_site") == "bim_2024_site"
