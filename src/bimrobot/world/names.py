"""Reversible, file- and SDF-safe names for IFC GlobalIds.

An IFC GlobalId is 22 characters of the alphabet ``0-9 A-Z a-z _ $``. ``$`` is awkward in file names
(shell expansion) and URIs, so :func:`safe_name` maps it to ``-``, which the GlobalId alphabet never
uses; letters, digits and ``_`` are kept. Any other character (only possible for ids that are not
GlobalIds) becomes ``.`` followed by the two hex digits of each of its UTF-8 bytes. The mapping is
one-to-one, so :func:`global_id_from_safe_name` recovers the GlobalId exactly::

    >>> safe_name("2O2Fr$t4X7Zf8NOew3FLOH")
    '2O2Fr-t4X7Zf8NOew3FLOH'
    >>> global_id_from_safe_name("2O2Fr-t4X7Zf8NOew3FLOH")
    '2O2Fr$t4X7Zf8NOew3FLOH'

The result is a valid SDF model/link name (no ``::``, never starts with ``__`` for a GlobalId, whose
first character is ``0``-``3``), a valid ``model://`` URI path segment and a portable file name.
"""

from __future__ import annotations

import re
import string

_KEPT = frozenset(string.ascii_letters + string.digits + "_")
_ESCAPE = re.compile(r"\.([0-9a-f]{2})")


def safe_name(global_id: str) -> str:
    """The file- and SDF-safe form of ``global_id`` (see the module docstring for the mapping)."""
    if not global_id:
        raise ValueError("an empty id has no safe name")
    out = []
    for char in global_id:
        if char in _KEPT:
            out.append(char)
        elif char == "$":
            out.append("-")
        else:
            out.extend(f".{byte:02x}" for byte in char.encode("utf-8"))
    return "".join(out)


def global_id_from_safe_name(name: str) -> str:
    """Invert :func:`safe_name`: the original GlobalId (ValueError on a name it cannot have produced)."""
    if not name or not re.fullmatch(r"(?:[A-Za-z0-9_\-]|\.[0-9a-f]{2})+", name):
        raise ValueError(f"{name!r} is not a name produced by safe_name")
    raw = bytearray()
    position = 0
    while position < len(name):
        char = name[position]
        if char == ".":
            raw.append(int(name[position + 1 : position + 3], 16))
            position += 3
            continue
        raw.extend(b"$" if char == "-" else char.encode("ascii"))
        position += 1
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{name!r} is not a name produced by safe_name") from None


def slug(text: str, fallback: str = "site") -> str:
    """A short lowercase file name for a human label (site, storey): ``"Level 1"`` -> ``"level_1"``.

    Not reversible; used only where the label is also recorded elsewhere (report.json).
    """
    cleaned = re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")
    return cleaned or fallback


def ros_package_name(text: str) -> str:
    """A valid ROS package name (lowercase letters, digits, underscores, starting with a letter)."""
    name = slug(text, fallback="bim_world")
    if not name[0].isalpha():
        name = f"bim_{name}"
    return name
