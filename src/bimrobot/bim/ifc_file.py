"""Open an IFC file: IFC-SPF or ``.ifczip``, checked before parsing, with one-sentence errors.

Also what identifies a product in a :class:`~bimrobot.bim.model.BuildingModel` (its GlobalId, made
distinct where a file repeats one) and how many times each file was parsed (:data:`READS`).
"""

from __future__ import annotations

import os
import re
import shutil
import zlib
from pathlib import Path

import ifcopenshell

from bimrobot.core.errors import InputError

SUPPORTED_SCHEMAS = ("IFC2X3", "IFC4", "IFC4X3_ADD2")


class ReadCounts:
    """How many times this process parsed each IFC file (:func:`open_ifc`) and read its geometry
    (:func:`load_model`'s geometry pass), by resolved path. Counting only: ``bimrobot build`` records the
    counts of its model in ``build.json`` (``ifc_reads``, ``geometry_passes``) to show it read it once."""

    def __init__(self) -> None:
        from collections import Counter

        self.parses: Counter = Counter()
        self.geometry: Counter = Counter()

    @staticmethod
    def key(path) -> str:
        """The counters' key of ``path``: its resolved path as text."""
        return str(Path(path).resolve())

    def of(self, path) -> tuple[int, int]:
        """(parses, geometry passes) of ``path`` so far."""
        key = self.key(path)
        return self.parses[key], self.geometry[key]


READS = ReadCounts()


def open_ifc(path: str | os.PathLike) -> ifcopenshell.file:
    """Open an IFC-SPF file or an ``.ifczip`` holding one; InputError with one sentence when it cannot.

    Messages name the file with control characters escaped (:func:`bimrobot.core.io.printable`).
    """
    path = Path(path)
    shown = shown_name(path)
    if not path.exists():
        raise InputError(f"{shown}: no such file")
    if not path.is_file():
        raise InputError(f"{shown} is not a file")
    READS.parses[READS.key(path)] += 1
    try:
        with open(path, "rb") as stream:
            head = stream.read(4096)
            stream.seek(max(0, path.stat().st_size - 4096))
            tail = stream.read()
    except OSError as exc:
        raise InputError(f"{shown} cannot be read ({exc.strerror})") from None
    if head.startswith(b"PK"):
        return _open_ifczip(path)
    return _open_spf(path, shown, head, tail)


def header_schema(path: str | Path) -> str | None:
    """The schema an IFC-SPF file (or the one model in an ``.ifczip``) names in its header (``IFC2X3``,
    ``IFC4``, ...), read from its first 4 KB without parsing the model; None when it names none or
    cannot be read (opening it says why)."""
    import zipfile

    try:
        with open(path, "rb") as stream:
            head = stream.read(4096)
        if head.startswith(b"PK"):
            with zipfile.ZipFile(path) as archive:
                members = [m for m in archive.namelist() if m.lower().endswith(".ifc") and not m.startswith("__MACOSX/")]
                if len(members) != 1:
                    return None
                with archive.open(members[0]) as stream:
                    head = stream.read(4096)
    except (OSError, zipfile.BadZipFile, NotImplementedError, EOFError, zlib.error):
        return None
    match = re.search(rb"FILE_SCHEMA\s*\(\s*\(\s*'([^']*)'", head)
    return match.group(1).decode("ascii", "replace").upper() if match else None


def shown_name(path) -> str:
    from bimrobot.core.io import printable

    return printable(str(path))


def _open_ifczip(path: Path) -> ifcopenshell.file:
    """Open the one IFC-SPF file inside a zip archive (``.ifczip``, as many tools export).

    macOS metadata entries (``__MACOSX/``, ``._*``) are not models and are ignored.
    """
    import tempfile
    import zipfile

    shown = shown_name(path)
    try:
        with zipfile.ZipFile(path) as archive:
            members = [
                m for m in archive.infolist()
                if not m.is_dir() and m.filename.lower().endswith(".ifc")
                and not m.filename.startswith("__MACOSX/") and not Path(m.filename).name.startswith("._")
            ]
            if not members:
                names = ", ".join(archive.namelist()[:5]) or "nothing"
                raise InputError(f"{shown} is a zip archive without an .ifc file inside (it holds {shown_name(names)})")
            if len(members) > 1:
                names = ", ".join(m.filename for m in members[:5])
                raise InputError(
                    f"{shown} is a zip archive with {len(members)} .ifc files ({shown_name(names)}); give one model per archive"
                )
            member = members[0]
            inner_shown = f"{shown}!{shown_name(member.filename)}"
            with archive.open(member) as stream:
                head = stream.read(4096)
            with tempfile.TemporaryDirectory(prefix="bimrobot-ifczip-") as folder:
                inner = Path(folder) / "model.ifc"  # not the member's own name: it may hold any path
                with archive.open(member) as stream, open(inner, "wb") as copy:
                    shutil.copyfileobj(stream, copy)
                with open(inner, "rb") as stream:
                    stream.seek(max(0, inner.stat().st_size - 4096))
                    tail = stream.read()
                return _open_spf(inner, inner_shown, head, tail)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, EOFError, zlib.error) as exc:
        raise InputError(f"{shown} looks like a zip archive but cannot be read ({shown_name(exc)})") from None
    except OSError as exc:
        raise InputError(f"{shown} cannot be read ({exc.strerror or exc})") from None


def _open_spf(path: Path, shown: str, head: bytes, tail: bytes) -> ifcopenshell.file:
    """Check the header and the end of an IFC-SPF file, then parse it; ``shown`` names it in messages."""
    stripped = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if stripped.startswith(b"<"):
        raise InputError(f"{shown} is XML (ifcXML?), which is not supported: export IFC-SPF (.ifc) instead")
    if not stripped.startswith(b"ISO-10303-21"):
        raise InputError(f"{shown} is not an IFC file (an IFC-SPF file starts with 'ISO-10303-21;')")
    if b"END-ISO-10303-21" not in tail:
        raise InputError(f"{shown} is truncated: it does not end with 'END-ISO-10303-21;'")
    match = re.search(rb"FILE_SCHEMA\s*\(\s*\(\s*'([^']*)'", head)
    schema = shown_name(match.group(1).decode("ascii", "replace").upper()) if match else "unknown"
    ifcopenshell.get_log()  # emptied: a parse error's details are read from it below
    try:
        ifc = ifcopenshell.open(str(path), format=".ifc")
    except ifcopenshell.SchemaError:
        raise InputError(
            f"{shown} uses the unsupported IFC schema {schema} (supported: {', '.join(SUPPORTED_SCHEMAS)})"
        ) from None
    except Exception as exc:  # ifcopenshell raises its own Error or RuntimeError on malformed files
        raise InputError(f"{shown} could not be parsed as IFC: {shown_name(_parse_failure(exc, path))}") from None
    overwritten = sorted({int(n) for n in re.findall(r"Overwriting instance with name #(\d+)", ifcopenshell.get_log())})
    if overwritten:  # the parser kept the last definition, but references and inverses mix both
        raise InputError(f"{shown} defines {_duplicate_ids(path, overwritten)}, which IFC-SPF forbids")
    return ifc


def _duplicate_ids(path: Path, ids: list[int], shown: int = 3) -> str:
    """Words for the entity ids that ``path`` defines more than once, with the lines that define them."""
    text = path.read_bytes()
    found = {n: [] for n in ids[:shown]}
    for m in re.finditer(rb"(?m)^\s*#(\d+)\s*=", text):
        if int(m.group(1)) in found:
            found[int(m.group(1))].append(text.count(b"\n", 0, m.start()) + 1)
    words = "; ".join(f"#{n} on lines {', '.join(map(str, where))}" if where else f"#{n}" for n, where in found.items())
    more = f" and {len(ids) - shown} more" if len(ids) > shown else ""
    return f"{len(ids)} entity id(s) more than once ({words}{more})"


def _parse_failure(exc: Exception, path: Path) -> str:
    """Why IfcOpenShell could not parse ``path``: the exception's first line, unless that only says
    "Syntax error during parse, check logs": then the log's last error ("Unexpected 'p' at offset
    235") with the line of the file that offset is on."""
    message = str(exc).strip()
    first = message.splitlines()[0] if message else type(exc).__name__
    if "check logs" not in first:
        return first
    for line in reversed(ifcopenshell.get_log().splitlines()):
        if line.startswith("[error]"):
            detail = re.sub(r"^\[error\](?: \[[^\]]*\])* ", "", line)
            match = re.search(r"at offset (\d+)", detail)
            return f"syntax error: {detail} (line {_line_at(path, int(match.group(1)))})" if match else detail
    return first


def _line_at(path: Path, offset: int) -> int:
    """The 1-based line of ``path`` that holds byte ``offset``."""
    newlines, read = 0, 0
    with open(path, "rb") as stream:
        while read < offset:
            chunk = stream.read(min(1 << 20, offset - read))
            if not chunk:
                break
            newlines += chunk.count(b"\n")
            read += len(chunk)
    return newlines + 1


def class_lineage(schema: str, ifc_class: str) -> tuple[str, ...] | None:
    """``ifc_class`` and its supertypes in ``schema`` (e.g. IfcBeamStandardCase, IfcBeam, IfcBuiltElement,
    ..., IfcRoot), or None when the schema has no such class. Lets other parts match class names with
    subclasses, as selectors do, without importing ifcopenshell."""
    try:
        declaration = ifcopenshell.ifcopenshell_wrapper.schema_by_name(schema).declaration_by_name(ifc_class)
    except Exception:  # unknown schema or class
        return None
    names = []
    while declaration is not None:
        names.append(declaration.name())
        declaration = declaration.supertype() if hasattr(declaration, "supertype") else None
    return tuple(names)


# ---- duplicate GlobalIds ---------------------------------------------------------------------------
#
# Some exporters write the same GlobalId on two entities (copied objects, merged files). bimrobot keys
# elements by GlobalId everywhere, so a duplicate would silently replace an element. Instead, the first
# product (in file order) keeps its GlobalId and every later one is keyed ``<GlobalId>#<step id>``,
# which names it uniquely in the model, in file names (``#`` is escaped by ``safe_name``) and in reports,
# and the duplicates are reported in one line.


def product_keys(ifc: ifcopenshell.file) -> dict[int, str]:
    """Step id -> key of every IfcProduct that cannot be keyed by its GlobalId alone.

    That is a product whose GlobalId an earlier IfcProduct of the file already carries (key
    ``<GlobalId>#<step id>``), or one without a GlobalId (key ``#<step id>``). Products not listed
    are keyed by their GlobalId (see :func:`product_key`). The keys do not depend on any selection.
    """
    keys: dict[int, str] = {}
    seen: set[str] = set()
    for product in sorted(ifc.by_type("IfcProduct"), key=lambda p: p.id()):
        global_id = product[0] or ""  # GlobalId, read by position (faster)
        if global_id and global_id not in seen:
            seen.add(global_id)
        else:
            keys[product.id()] = f"{global_id}#{product.id()}"
    return keys


def product_key(product, keys: dict[int, str]) -> str:
    """The product's key in a BuildingModel: its GlobalId, or the distinct key :func:`product_keys` gave it."""
    return keys.get(product.id()) or product.GlobalId


def duplicate_global_ids(ifc: ifcopenshell.file) -> dict[str, list]:
    """GlobalId -> the entities (IfcRoot, in file order) that carry it, for every GlobalId used more than once."""
    holders: dict[str, list] = {}
    for entity in ifc.by_type("IfcRoot"):
        holders.setdefault(entity[0] or "", []).append(entity)  # [0]: GlobalId, read by position (faster)
    return {gid: sorted(found, key=lambda e: e.id()) for gid, found in holders.items() if len(found) > 1}


def duplicates_message(source, duplicates: dict[str, list], keys: dict[int, str], shown: int = 3) -> str:
    """One line naming the duplicated GlobalIds and their entities, and what bimrobot does about them."""
    from bimrobot.core.io import printable

    def entities(found: list) -> str:
        return " and ".join(f"#{e.id()} {e.is_a()}" for e in found)

    listed = "; ".join(f"'{printable(gid) or '(empty)'}' by {entities(found)}" for gid, found in list(duplicates.items())[:shown])
    more = f" and {len(duplicates) - shown} more" if len(duplicates) > shown else ""
    renamed = [key for found in duplicates.values() for e in found if (key := keys.get(e.id()))]
    if renamed:
        action = f"every element is kept, the later ones keyed as <GlobalId>#<step id> (e.g. '{printable(renamed[0])}')"
    else:
        action = "no two elements share one, so every element keeps its GlobalId"
    return (
        f"{printable(str(source))}: {len(duplicates)} GlobalId(s) are used by more than one entity, "
        f"which IFC forbids: {listed}{more}; {action}"
    )
