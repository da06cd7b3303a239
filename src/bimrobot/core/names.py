"""Reversible, file- and SDF-safe names for IFC GlobalIds, and text that is safe to print or put in XML.

An IFC GlobalId is 22 characters of the alphabet ``0-9 A-Z a-z _ $``. ``$`` is awkward in file names
(shell expansion) and URIs, so :func:`safe_name` maps it to ``-``, which the GlobalId alphabet never
uses; letters, digits and ``_`` are kept. Any other character (only possible for ids that are not
GlobalIds: a malformed file, or bimrobot's ``<GlobalId>#<step id>`` key for a duplicated GlobalId)
becomes ``.`` followed by the two hex digits of each of its UTF-8 bytes. The mapping is one-to-one,
so :func:`global_id_from_safe_name` recovers the GlobalId exactly::

    >>> safe_name("2O2Fr$t4X7Zf8NOew3FLOH")
    '2O2Fr-t4X7Zf8NOew3FLOH'
    >>> global_id_from_safe_name("2O2Fr-t4X7Zf8NOew3FLOH")
    '2O2Fr$t4X7Zf8NOew3FLOH'
    >>> safe_name("2O2Fr$t4X7Zf8NOew3FLOH#37")
    '2O2Fr-t4X7Zf8NOew3FLOH.2337'

Two more rules keep every result usable:

* SDFormat reserves ``world`` and names that start *and* end with ``__`` (``__model__``): for those
  the last character is escaped (``__model__`` -> ``__model_.5f``), so they stay reversible.
* A name is at most :data:`MAX_NAME_LENGTH` characters, so that ``<name>_collision.stl`` fits in a
  255-byte file name. A longer one keeps its first characters and ends with ``..`` and 20 hex digits
  of its SHA-256 (``..`` never occurs otherwise): still unique and portable, but no longer reversible
  by itself; the full id is recorded next to it (``index.json``, ``report.json``, ``model.config``).

The result never contains ``/``, ``\\``, ``::``, ``$``, spaces or control characters, is never ``.`` or
``..``, is a valid SDF model/link name, a ``model://`` URI segment and a portable file name.
"""

from __future__ import annotations

import hashlib
import re
import string

_KEPT = frozenset(string.ascii_letters + string.digits + "_")
#: Longest name :func:`safe_name` returns (characters, all ASCII).
MAX_NAME_LENGTH = 200
_HASH_DIGITS = 20
_SHORTENED = re.compile(r"\.\.[0-9a-f]{%d}$" % _HASH_DIGITS)
_SDF_RESERVED = "world"


def _escape(char: str) -> str:
    return "".join(f".{byte:02x}" for byte in char.encode("utf-8", "surrogatepass"))


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
            out.append(_escape(char))
    if global_id == _SDF_RESERVED or (len(global_id) >= 4 and global_id.startswith("__") and global_id.endswith("__")):
        out[-1] = _escape(global_id[-1])
    name = "".join(out)
    if len(name) <= MAX_NAME_LENGTH:
        return name
    digest = hashlib.sha256(global_id.encode("utf-8", "surrogatepass")).hexdigest()[:_HASH_DIGITS]
    keep = MAX_NAME_LENGTH - 2 - _HASH_DIGITS
    head = name[:keep]
    cut = head.rfind(".", max(0, keep - 2))  # never cut an escape (".xx") in two
    if cut != -1:
        head = head[:cut]
    return f"{head}..{digest}"


def is_shortened(name: str) -> bool:
    """True when ``name`` is a :func:`safe_name` shortened with a hash (its id is recorded elsewhere)."""
    return bool(_SHORTENED.search(name))


def global_id_from_safe_name(name: str) -> str:
    """Invert :func:`safe_name`: the original GlobalId (ValueError on a name it cannot have produced,
    or on a shortened name, whose full id is in the index or report written beside it)."""
    if is_shortened(name):
        raise ValueError(f"{name!r} is a shortened name; its full id is recorded in index.json / report.json")
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
        text = raw.decode("utf-8", "surrogatepass")
    except UnicodeDecodeError:
        raise ValueError(f"{name!r} is not a name produced by safe_name") from None
    if safe_name(text) != name:  # e.g. "world" written raw: safe_name never produces that
        raise ValueError(f"{name!r} is not a name produced by safe_name")
    return text


def slug(text: str, fallback: str = "site") -> str:
    """A short lowercase file name for a human label (site, storey): ``"Level 1"`` -> ``"level_1"``.

    Not reversible; used only where the label is also recorded elsewhere (report.json).
    """
    cleaned = re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")[:80].strip("_")
    return cleaned or fallback


def ros_package_name(text: str) -> str:
    """A valid ROS package name (lowercase letters, digits, underscores, starting with a letter)."""
    name = slug(text, fallback="bim_world")
    if not name[0].isalpha():
        name = f"bim_{name}"
    return name
