"""Read an IFC file into a :class:`~bimrobot.bim.model.BuildingModel` in one geometry-iterator pass.

All geometry comes from ifcopenshell's geometry iterator in local coordinates, one pass over the products
(shared by one forked process per core, each with its own iterator over every n-th product): each shape's
matrix is the element's placement (local -> world, metres) and its vertices are in the element's local
frame, so ``world = placement @ local``. Shapes that share a representation (mapped items, types) share
their vertex and face arrays. Kernel: ``hybrid-cgal-simple-opencascade`` (CGAL where it can, OpenCASCADE
where it must): about twice as fast as the default OpenCASCADE kernel with the same volumes.

Which products become elements: every ``IfcElement`` except feature elements (openings, projections,
which are part of their host's body) and virtual elements. A product with no solid body (e.g. a weld
modelled as a curve) is reported in ``BuildingModel.skipped`` with the reason.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import re
import shutil
import zlib
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.element
import ifcopenshell.util.placement
import ifcopenshell.util.shape
import ifcopenshell.util.unit

from bimrobot.bim.model import Assembly, BuildingModel, Connection, Element, SkippedProduct, Storey, mesh_volume
from bimrobot.bim.quantities import WEIGHT_PROPERTY_NAMES, MaterialDensities, resolve_weight
from bimrobot.bim.selection import describe, select_products
from bimrobot.core.errors import InputError

log = logging.getLogger(__name__)

GEOMETRY_LIBRARY = "hybrid-cgal-simple-opencascade"
SUPPORTED_SCHEMAS = ("IFC2X3", "IFC4", "IFC4X3_ADD2")
_CURVE_ONLY_TYPES = {
    "Curve", "Curve2D", "Curve3D", "GeometricCurveSet", "GeometricSet", "Point", "PointCloud", "Annotation2D",
}  # fmt: skip
_WEIGHT_NAMES = frozenset(WEIGHT_PROPERTY_NAMES)


_WRONG_TYPE = re.compile(r"entity instance of type '([^']*)' has no attribute '([^']*)'")


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


def _refused_wrong_type(shown: str, exc: AttributeError, product=None) -> InputError:
    """The InputError for IfcOpenShell's AttributeError on an entity of the wrong type (a reference of
    a malformed file: IfcOpenShell does not check the types of references), naming the file and, where
    known, the product whose data holds it."""
    found = _WRONG_TYPE.search(str(exc))
    where = f"{product.is_a()} #{product.id()}" if product is not None else "an entity"
    return InputError(
        f"{shown}: {where} refers to an {found.group(1).split('.')[-1]} where an entity with '{found.group(2)}' "
        "belongs (a reference of the wrong type: the file is malformed; validate it, or --exclude that product)"
    )


def _names_wrong_types(function):
    """Decorator of :func:`load_model`: IfcOpenShell's AttributeError on a reference of the wrong type,
    wherever it comes from, becomes an InputError naming the file."""
    import functools

    @functools.wraps(function)
    def reading(path, *args, **kwargs):
        try:
            return function(path, *args, **kwargs)
        except AttributeError as exc:
            if not _WRONG_TYPE.search(str(exc)):
                raise
            raise _refused_wrong_type(_shown(path), exc) from None

    return reading


@_names_wrong_types
def load_model(
    path: str | os.PathLike,
    include: Iterable[str] | str | None = None,
    exclude: Iterable[str] | str | None = None,
    progress: bool = False,
    threads: int | None = None,
    properties: bool = True,
    processes: int | None = None,
    prebuilt: str | None = None,
    unknown_weight=None,
    ifc: ifcopenshell.file | None = None,
) -> BuildingModel:
    """Read ``path`` (IFC2X3, IFC4 or IFC4X3_ADD2) into a BuildingModel (metres, z up, kg).

    ``include`` / ``exclude``: IfcOpenShell selectors (see :mod:`bimrobot.bim.selection`), e.g.
    ``"IfcColumn, IfcBeam"`` or ``"IfcElement, ! IfcFurnishingElement"``, or lists of class names;
    subclasses count, so ``"IfcBuildingElement"`` takes walls, beams, ...
    ``progress``: show a tqdm bar over the geometry pass. ``processes``: forked processes that share the
    geometry pass, each with its own iterator over every n-th product (default: every core, at most 8;
    one below :data:`MIN_PRODUCTS_TO_SHARE` products or where fork is unsafe). ``threads``: the
    iterator's own threads in each process (default: one where several processes share the pass, else
    every core, at most 8). Geometry iterators in separate processes scale where the iterator's threads
    do not: on this project's 2-core build machine two threads bought 0-35 % over one thread (and on
    files of 1-3 ms per element nothing, at twice the CPU), two processes 33-73 % (docs/world.md).
    ``properties``: read every property and quantity value into ``Element.properties``; False leaves
    those empty and reads only what the weights need (weight quantities, weight properties by name),
    which is what ``convert`` does: reading every value costs up to 0.7 ms per element.
    ``prebuilt``: a ``--prebuilt`` selector, evaluated here (``model.prebuilt_ids``) for
    :func:`bimrobot.sco.build.prebuilt_rule`. ``unknown_weight``: an
    :class:`~bimrobot.bim.unknown_weight.UnknownWeightRule` applied once, here, to every element without
    a weight in the model (``model.unknown_weights`` says what it did); None leaves them unknown.
    An element whose local placement lies away from its body (Revit's stair flights, columns and slabs
    placed at (0, 0, 0) with their bodies metres away) gets its origin moved onto the body
    (:func:`anchor_to_bodies`; ``model.relocated`` lists them), so every consumer reads the body's place.
    ``ifc``: the file ``path`` already parsed by :func:`open_ifc` (``bimrobot build`` parses it once to
    check its selectors, then reads the model from that parse); None parses it here.
    Raises :class:`~bimrobot.core.errors.InputError` naming the file when it is missing, not IFC, truncated,
    of an unsupported schema, or holds no element with solid geometry.
    """
    path = Path(path)
    ifc = open_ifc(path) if ifc is None else ifc
    READS.geometry[READS.key(path)] += 1
    length_scale = ifcopenshell.util.unit.calculate_unit_scale(ifc)
    mass_scale, mass_name = _mass_unit(ifc)
    candidates = select_products(ifc, as_selector(include), as_selector(exclude), path)
    if not candidates:
        raise InputError(f"{_shown(path)} contains no building element ({describe(as_selector(include), as_selector(exclude))})")
    keys = product_keys(ifc)  # a duplicated GlobalId must not make one element replace another
    duplicates = duplicate_global_ids(ifc)
    if duplicates:
        log.warning("%s", duplicates_message(path, duplicates, keys))

    materials = MaterialDensities(ifc)  # each material definition walked once, before any fork
    shares = _shares(candidates, processes, threads)
    read = _ShareReader(ifc, _shown(path), mass_scale, keys, materials, properties)
    found = _read_shares(read, shares, progress, threads)
    elements, storey_cache = found.elements, found.storeys
    seen, empty_bodies = found.seen, found.empty_bodies

    skipped = [
        dataclasses.replace(_skipped(p, p.id() in empty_bodies), global_id=product_key(p, keys))
        for p in candidates
        if p.id() not in seen or p.id() in empty_bodies
    ]
    if not elements:
        raise InputError(f"{_shown(path)} contains no element with solid geometry ({len(skipped)} products without a solid body)")

    order = {product_key(p, keys): i for i, p in enumerate(candidates)}
    elements = dict(sorted(elements.items(), key=lambda item: order[item[0]]))
    check_plausible_geometry(elements, _shown(path))
    model = BuildingModel(
        source=path,
        schema=ifc.schema_identifier,
        project_name=_name_of_first(ifc, "IfcProject"),
        site_name=_name_of_first(ifc, "IfcSite"),
        units={
            "length": _length_unit_name(ifc),
            "length_scale_to_m": length_scale,
            "mass": mass_name,
            "mass_scale_to_kg": mass_scale,
        },
        storeys=_storeys(ifc, length_scale),
        elements=elements,
        connections=_connections(ifc, elements, keys),
        skipped=skipped,
        assemblies=_assemblies(ifc, elements, storey_cache, keys),
    )
    return _finish(model, ifc, keys, prebuilt, unknown_weight)


MAX_ELEMENT_SIZE_M = 10_000.0
"""The largest an element may be across (metres): a body larger than this comes from a broken profile,
extrusion depth or unit (issue 35: a profile point at 1e20 made an element 2.5e18 m long)."""
MAX_SITE_SIZE_M = 10_000.0
"""The largest the elements together may span (metres): beyond it an element is misplaced."""
MAX_DISTANCE_M = 2.0e7
"""The farthest an element may lie from the origin (metres): half the Earth's circumference, beyond any
projected coordinate system."""


def check_plausible_geometry(elements: dict[str, Element], shown: str) -> None:
    """InputError, in one sentence naming the element, when an element's world geometry is not finite,
    larger than :data:`MAX_ELEMENT_SIZE_M`, farther than :data:`MAX_DISTANCE_M` from the origin, or when
    the elements span more than :data:`MAX_SITE_SIZE_M` (naming the one farthest from the others).
    Everything downstream (site layout, maps, meshes, physics) sizes its work from these numbers."""
    centres, keys = [], []
    for key, element in elements.items():
        local = np.array([element.vertices.min(axis=0), element.vertices.max(axis=0)]) if len(element.vertices) else np.zeros((2, 3))
        with np.errstate(over="ignore", invalid="ignore"):
            corners = np.array([[x, y, z] for x in local[:, 0] for y in local[:, 1] for z in local[:, 2]])
            world = corners @ element.placement[:3, :3].T + element.placement[:3, 3]
            size = float(np.max(world.max(axis=0) - world.min(axis=0)))
        what = f"{shown}: {element.ifc_class} {printable_name(element)} ({key})"
        if not (np.isfinite(world).all() and np.isfinite(size)):
            raise InputError(f"{what} has coordinates that are not finite numbers (a value overflows): check its geometry and placement")
        if size > MAX_ELEMENT_SIZE_M:
            raise InputError(f"{what} is {size:.3g} m across, more than the {MAX_ELEMENT_SIZE_M:g} m an element may be: "
                             "check its profile, extrusion and the file's length unit, or --exclude it")
        distance = float(np.abs(world).max())
        if distance > MAX_DISTANCE_M:
            raise InputError(f"{what} lies {distance:.3g} m from the origin, farther than the {MAX_DISTANCE_M:g} m any "
                             "place on Earth may: check its placement and the file's length unit, or --exclude it")
        centres.append(world.mean(axis=0))
        keys.append(key)
    if len(centres) > 1:
        centres = np.array(centres)
        span = float(np.max(centres.max(axis=0) - centres.min(axis=0)))
        if span > MAX_SITE_SIZE_M:
            stray = keys[int(np.argmax(np.abs(centres - np.median(centres, axis=0)).max(axis=1)))]
            element = elements[stray]
            raise InputError(
                f"{shown}: the elements span {span:.3g} m, more than the {MAX_SITE_SIZE_M:g} m a site may: "
                f"{element.ifc_class} {printable_name(element)} ({stray}) lies farthest from the others; check its "
                "placement, or --exclude it"
            )


def printable_name(element: Element) -> str:
    """The element's name, quoted, with control characters escaped (or 'unnamed')."""
    from bimrobot.core.io import printable

    return repr(printable(element.name)) if element.name else "(unnamed)"


MIN_PRODUCTS_TO_SHARE = 32
"""Below this many products one process reads the geometry: forking (10-30 ms) would cost more than it saves."""


@dataclasses.dataclass
class _Found:
    """What reading some products' geometry gave: elements by key (with their meshes' geometry ids,
    which tell shared meshes apart across processes), the step ids seen and those with an empty body,
    and the storey of every product looked up on the way (step id -> storey GlobalId)."""

    elements: dict[str, Element] = dataclasses.field(default_factory=dict)
    geometry_ids: dict[str, str] = dataclasses.field(default_factory=dict)
    seen: set[int] = dataclasses.field(default_factory=set)
    empty_bodies: set[int] = dataclasses.field(default_factory=set)
    storeys: dict[int, str | None] = dataclasses.field(default_factory=dict)

    def add(self, other: "_Found") -> None:
        """Take in another share's findings; a mesh both read (a shared representation) is kept once."""
        meshes = {gid: (self.elements[key].vertices, self.elements[key].faces) for key, gid in self.geometry_ids.items()}
        for key, element in other.elements.items():
            gid = other.geometry_ids[key]
            if gid in meshes:
                element = dataclasses.replace(element, vertices=meshes[gid][0], faces=meshes[gid][1])
            else:  # read-only again, as this process's own meshes (pickling dropped the flag)
                element.vertices.setflags(write=False)
                element.faces.setflags(write=False)
                meshes[gid] = (element.vertices, element.faces)
            self.elements[key] = element
            self.geometry_ids[key] = gid
        self.seen |= other.seen
        self.empty_bodies |= other.empty_bodies
        self.storeys.update(other.storeys)


@dataclasses.dataclass
class _ShareReader:
    """Reads one share of the products: the geometry iterator over them, and each element's weight,
    material and storey (everything here is made before any fork, so every process has it)."""

    ifc: ifcopenshell.file
    shown: str  # the file, as messages name it
    mass_scale: float
    keys: dict[int, str]
    materials: MaterialDensities
    properties: bool

    def __call__(self, products: list, threads: int | None, bar=None) -> _Found:
        found = _Found()
        meshes: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        volumes: dict[str, float] = {}
        type_cache: dict[int, tuple[dict, dict, dict]] = {}
        for shape in iterate_shapes(self.ifc, products, threads=threads):
            if bar is not None:
                bar.update(1)
            product = self.ifc.by_id(shape.id)
            found.seen.add(shape.id)
            geometry_id = shape.geometry.id
            if geometry_id not in meshes:
                vertices = ifcopenshell.util.shape.get_vertices(shape.geometry).astype(np.float64)
                faces = ifcopenshell.util.shape.get_faces(shape.geometry).astype(np.int64)
                vertices.setflags(write=False)
                faces.setflags(write=False)
                meshes[geometry_id] = (vertices, faces)
            vertices, faces = meshes[geometry_id]
            if len(faces) == 0:
                found.empty_bodies.add(shape.id)
                continue
            placement = np.asarray(ifcopenshell.util.shape.get_shape_matrix(shape), dtype=np.float64)
            volume = _lazy_volume(volumes, geometry_id, vertices, faces)
            try:
                element = _element(product, placement, vertices, faces, volume, self.mass_scale,
                                   (found.storeys, type_cache, self.materials), self.properties)
            except AttributeError as exc:  # a reference of the wrong type in the product's data
                if not _WRONG_TYPE.search(str(exc)):
                    raise
                raise _refused_wrong_type(self.shown, exc, product) from None
            element.global_id = product_key(product, self.keys)
            found.elements[element.global_id] = element
            found.geometry_ids[element.global_id] = geometry_id
        return found


def _shares(candidates: list, processes: int | None, threads: int | None) -> list[list]:
    """The products each process reads: every n-th one (neighbours in a file are alike, so the shares
    cost about the same). One share where forking would not pay, or cannot be done safely."""
    from bimrobot.core.cores import can_fork

    count = processes or (1 if threads else default_threads())
    if count <= 1 or len(candidates) < MIN_PRODUCTS_TO_SHARE or not can_fork():
        return [candidates]
    return [candidates[start::count] for start in range(count)]


def _read_shares(read: _ShareReader, shares: list[list], progress: bool, threads: int | None) -> _Found:
    """Read every share in a forked process of its own, all at the same time (the parsed file is
    inherited, not reread); their findings come back pickled and errors in a child are raised here.
    The geometry kernel never runs in this process: where it crashes on a malformed product (a
    reference of the wrong type, say: SIGSEGV or SIGFPE in its C++), the child dies and this process
    raises InputError naming the file. Where fork is unsafe, the one share is read here."""
    import multiprocessing
    import pickle

    from bimrobot.core.cores import can_fork, frozen_heap

    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=sum(len(share) for share in shares), unit="element", desc="geometry")
    if not can_fork():
        try:
            return read(shares[0], threads, bar)
        finally:
            if bar is not None:
                bar.close()
    context = multiprocessing.get_context("fork")
    children = []
    child_threads = threads if len(shares) == 1 else (threads or 1)  # one share: the iterator's own threads
    try:
        with frozen_heap():  # the children's collections do not copy every page of the file they inherit
            for share in shares:
                receiving, sending = context.Pipe(duplex=False)
                # the child closes the read ends it inherits (its own, earlier children's): a child whose
                # parent is gone then fails to write instead of blocking forever on a pipe it holds open
                read_ends = [*(end for _, end in children), receiving]
                child = context.Process(target=_read_in_child, daemon=True,
                                        args=(read, share, child_threads, sending, os.getpid(), read_ends))
                child.start()
                sending.close()
                children.append((child, receiving))
        found = _Found()
        for child, receiving in children:
            try:
                outcome, payload = pickle.loads(receiving.recv_bytes())
            except EOFError:  # the process died: IfcOpenShell's geometry kernel crashed on one of its products
                child.join()
                raise InputError(
                    f"{read.shown}: IfcOpenShell's geometry kernel crashed (exit code {child.exitcode}) on one of "
                    f"its {sum(len(share) for share in shares)} products (read in {len(children)} share(s)); the "
                    "file may be malformed (validate it), or exclude products (--exclude) to find the one it cannot mesh"
                ) from None
            if outcome == "error":
                raise payload
            found.add(payload)
            if bar is not None:
                bar.update(len(payload.seen))
        return found
    finally:
        for child, receiving in children:
            receiving.close()
            if child.is_alive():
                child.terminate()
            child.join()
        if bar is not None:
            bar.close()


def _read_in_child(read: _ShareReader, share: list, threads: int, sending, parent: int, read_ends: list) -> None:
    """A forked process's part of :func:`_read_shares`: read ``share``, send back ("ok", findings) or
    ("error", the exception), pickled. It dies with ``parent`` (:func:`bimrobot.core.cores.bind_to_parent`)
    and first closes its copies of the pipes' ``read_ends``, so that only the parent can read them."""
    import pickle

    from bimrobot.core.cores import bind_to_parent

    bind_to_parent(parent)
    for end in read_ends:
        end.close()
    try:
        message = ("ok", read(share, threads))
    except Exception as exc:  # handed to the parent, which raises it
        message = ("error", exc)
    try:
        try:
            payload = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:  # an unpicklable exception still reaches the parent, as its text
            payload = pickle.dumps(("error", RuntimeError(f"geometry process failed: {exc}")))
        sending.send_bytes(payload)
    except OSError:  # the parent is gone (it stopped, or was stopped): nobody is left to tell
        pass
    finally:
        sending.close()


def _lazy_volume(cache: dict[str, float], key: str, vertices: np.ndarray, faces: np.ndarray):
    """A function giving the mesh volume (m3), computed once per geometry and only when asked for."""

    def volume() -> float:
        if key not in cache:
            cache[key] = mesh_volume(vertices, faces)
        return cache[key]

    return volume


def open_ifc(path: str | os.PathLike) -> ifcopenshell.file:
    """Open an IFC-SPF file or an ``.ifczip`` holding one; InputError with one sentence when it cannot.

    Messages name the file with control characters escaped (:func:`bimrobot.core.io.printable`).
    """
    path = Path(path)
    shown = _shown(path)
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


def _shown(path) -> str:
    from bimrobot.core.io import printable

    return printable(str(path))


def _open_ifczip(path: Path) -> ifcopenshell.file:
    """Open the one IFC-SPF file inside a zip archive (``.ifczip``, as many tools export).

    macOS metadata entries (``__MACOSX/``, ``._*``) are not models and are ignored.
    """
    import tempfile
    import zipfile

    shown = _shown(path)
    try:
        with zipfile.ZipFile(path) as archive:
            members = [
                m for m in archive.infolist()
                if not m.is_dir() and m.filename.lower().endswith(".ifc")
                and not m.filename.startswith("__MACOSX/") and not Path(m.filename).name.startswith("._")
            ]
            if not members:
                names = ", ".join(archive.namelist()[:5]) or "nothing"
                raise InputError(f"{shown} is a zip archive without an .ifc file inside (it holds {_shown(names)})")
            if len(members) > 1:
                names = ", ".join(m.filename for m in members[:5])
                raise InputError(
                    f"{shown} is a zip archive with {len(members)} .ifc files ({_shown(names)}); give one model per archive"
                )
            member = members[0]
            inner_shown = f"{shown}!{_shown(member.filename)}"
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
        raise InputError(f"{shown} looks like a zip archive but cannot be read ({_shown(exc)})") from None
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
    schema = _shown(match.group(1).decode("ascii", "replace").upper()) if match else "unknown"
    ifcopenshell.get_log()  # emptied: a parse error's details are read from it below
    try:
        ifc = ifcopenshell.open(str(path), format=".ifc")
    except ifcopenshell.SchemaError:
        raise InputError(
            f"{shown} uses the unsupported IFC schema {schema} (supported: {', '.join(SUPPORTED_SCHEMAS)})"
        ) from None
    except Exception as exc:  # ifcopenshell raises its own Error or RuntimeError on malformed files
        raise InputError(f"{shown} could not be parsed as IFC: {_shown(_parse_failure(exc, path))}") from None
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


def geometry_settings() -> ifcopenshell.geom.settings:
    """Iterator settings: local coordinates (shape matrix = placement), metres."""
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", False)
    return settings


def default_threads() -> int:
    """Geometry threads, or processes sharing the geometry pass: every core this process may use, at
    most 8 (the iterator's gain flattens beyond)."""
    from bimrobot.core.cores import cores

    return max(1, min(8, cores()))


def iterate_shapes(ifc: ifcopenshell.file, products: list, threads: int | None = None) -> Iterator:
    """Yield the iterator's shapes for ``products`` (one pass, local coordinates)."""
    iterator = ifcopenshell.geom.iterator(
        geometry_settings(), ifc, threads or default_threads(), include=products, geometry_library=GEOMETRY_LIBRARY
    )
    if not iterator.initialize():
        return
    while True:
        yield iterator.get()
        if not iterator.next():
            break


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


def as_selector(value: Iterable[str] | str | None) -> str | None:
    """A selector string from a selector, or from a list of class names (joined with ', ')."""
    if value is None or isinstance(value, str):
        return value
    return ", ".join(v.strip() for v in value if v.strip()) or None


def _element(product, placement, vertices, faces, volume, mass_scale, caches, every_property: bool = True) -> Element:
    storey_cache, type_cache, materials = caches
    material = materials.of(product)
    properties, quantities, weight_properties = _property_values(product, mass_scale, type_cache, every_property)
    weight = resolve_weight(quantities, weight_properties, material, volume)
    return Element(
        global_id=product.GlobalId,
        ifc_class=product.is_a(),
        name=product.Name or "",
        storey_id=_storey_of(product, storey_cache),
        placement=placement,
        vertices=vertices,
        faces=faces,
        material=", ".join(material.names) or None,
        weight_kg=weight.kg,
        weight_source=weight.source,
        properties=properties,
        density_kg_m3=material.body_density_kg_m3,
        weight_basis=weight.basis,
    )


def _property_values(
    product, mass_scale: float, type_cache: dict, every_property: bool = True
) -> tuple[dict, dict[str, float], dict[str, float]]:
    """One pass over the element's (and its type's) property and quantity sets.

    Returns ``({"Pset/Name": value}`` in file units, occurrence values overriding type values``},
    {IfcQuantityWeight name: kg}, {"Pset/Name" of an IfcMassMeasure property: kg})``. Attributes are
    read by position (faster than by name in IfcOpenShell): this runs once per element. With
    ``every_property`` False the first dict stays empty and only the weights are read (the same two
    weight dicts, in the same order).
    """
    flat: dict = {}
    quantities: dict[str, float] = {}
    masses: dict[str, float] = {}
    read = _read_definition if every_property else _read_weights
    for relation in getattr(product, "IsDefinedBy", ()) or ():
        if relation.is_a("IfcRelDefinesByProperties"):
            read(relation.RelatingPropertyDefinition, mass_scale, flat, quantities, masses)
    product_type = ifcopenshell.util.element.get_type(product)
    if product_type is not None:
        key = product_type.id()
        if key not in type_cache:
            type_values: tuple[dict, dict, dict] = ({}, {}, {})
            for definition in product_type.HasPropertySets or ():
                read(definition, mass_scale, *type_values)
            type_cache[key] = type_values
        for mine, inherited in zip((flat, quantities, masses), type_cache[key]):
            for name, value in inherited.items():
                mine.setdefault(name, value)
    return flat, quantities, masses


def _read_weights(definition, mass_scale: float, flat: dict, quantities: dict, masses: dict) -> None:
    """What :func:`_read_definition` reads into ``quantities`` and ``masses``, without reading any other
    value: weight quantities, and single values whose name is a weight property name. ``flat`` is unused."""
    if definition is None or isinstance(definition, tuple):
        return
    if definition.is_a("IfcElementQuantity"):
        for quantity in definition.Quantities or ():
            if quantity.is_a("IfcQuantityWeight"):
                name, value = quantity[0], quantity[3]
                if value is not None:
                    scale = _unit_scale_to_kg(quantity[2]) if quantity[2] is not None else mass_scale
                    quantities.setdefault(name, float(value) * scale)
    elif definition.is_a("IfcPropertySet"):
        set_name = definition.Name
        for prop in definition.HasProperties or ():
            # as pick_weight_property compares: the part of "Pset/Name" after the last "/" (the name
            # first: most properties are not weights, and reading it is cheaper than the class)
            if str(prop[0]).rsplit("/", 1)[-1].lower() not in _WEIGHT_NAMES or prop.is_a() != "IfcPropertySingleValue":
                continue
            nominal = prop[2]
            if nominal is not None and nominal.is_a("IfcMassMeasure"):
                masses.setdefault(f"{set_name}/{prop[0]}", float(nominal.wrappedValue) * mass_scale)


def _read_definition(definition, mass_scale: float, flat: dict, quantities: dict, masses: dict) -> None:
    if definition is None or isinstance(definition, tuple):  # IFC4 property set definition sets: rare
        return
    set_name = definition.Name
    if definition.is_a("IfcElementQuantity"):
        for quantity in definition.Quantities or ():
            if not quantity.is_a("IfcPhysicalSimpleQuantity"):
                continue
            name, value = quantity[0], quantity[3]
            flat.setdefault(f"{set_name}/{name}", value)
            if value is not None and quantity.is_a("IfcQuantityWeight"):
                scale = _unit_scale_to_kg(quantity[2]) if quantity[2] is not None else mass_scale
                quantities.setdefault(name, float(value) * scale)
    elif definition.is_a("IfcPropertySet"):
        for prop in definition.HasProperties or ():
            kind = prop.is_a()
            key = f"{set_name}/{prop[0]}"
            if kind == "IfcPropertySingleValue":
                nominal = prop[2]
                flat.setdefault(key, nominal.wrappedValue if nominal is not None else None)
                if nominal is not None and nominal.is_a("IfcMassMeasure"):
                    masses.setdefault(key, float(nominal.wrappedValue) * mass_scale)
            elif kind in ("IfcPropertyEnumeratedValue", "IfcPropertyListValue"):
                flat.setdefault(key, tuple(v.wrappedValue for v in prop[2] or ()))
            elif kind == "IfcPropertyBoundedValue":
                bounds = (prop[3], prop[2])  # (lower, upper)
                flat.setdefault(key, tuple(b.wrappedValue if b is not None else None for b in bounds))
    else:  # pre-defined property sets (e.g. IfcDoorLiningProperties): their own attributes are the values
        for index in range(4, len(definition)):
            value = definition[index]
            if value is not None and not isinstance(value, (ifcopenshell.entity_instance, tuple)):
                flat.setdefault(f"{set_name}/{definition.attribute_name(index)}", value)


def _storey_of(product, cache: dict[int, str | None]) -> str | None:
    """GlobalId of the storey that contains the product (directly, or through its container/aggregate)."""
    key = product.id()
    if key in cache:
        return cache[key]
    result = None
    node = product
    for _ in range(32):  # spatial trees are shallow; the bound guards against cyclic files
        if node.is_a("IfcBuildingStorey"):
            result = node.GlobalId
            break
        parent = ifcopenshell.util.element.get_container(node) if node.is_a("IfcElement") else None
        parent = parent or ifcopenshell.util.element.get_aggregate(node)
        if parent is None:
            break
        node = parent
    cache[key] = result
    return result


def _skipped(product, empty_body: bool) -> SkippedProduct:
    if empty_body:
        reason = "its body triangulates to no faces"
    elif product.Representation is None:
        parts = [p for rel in getattr(product, "IsDecomposedBy", ()) or () for p in rel.RelatedObjects]
        reason = f"an assembly without its own body ({len(parts)} parts)" if parts else "no representation"
    else:
        types = sorted({r.RepresentationType or "unknown" for r in product.Representation.Representations})
        if set(types) <= _CURVE_ONLY_TYPES:
            reason = f"curve-only geometry ({', '.join(types)}), no solid body"
        else:
            reason = f"no solid body could be built from its representation ({', '.join(types)})"
    return SkippedProduct(product.GlobalId, product.is_a(), product.Name or "", reason)


def _connections(ifc: ifcopenshell.file, elements: dict[str, Element], keys: dict[int, str]) -> list[Connection]:
    """Every IfcRelConnectsWithRealizingElements whose relating and related elements were loaded.

    Realizing ids are kept even when those products are not elements (e.g. curve-only welds).
    Elements are named by their key (:func:`product_key`: the GlobalId, made distinct for duplicates).
    """
    connections = []
    for relation in ifc.by_type("IfcRelConnectsWithRealizingElements"):
        relating, related = relation.RelatingElement, relation.RelatedElement
        if relating is None or related is None:
            continue
        relating_id, related_id = product_key(relating, keys), product_key(related, keys)
        if relating_id not in elements or related_id not in elements:
            log.debug("connection %s involves an element that was not loaded", relation.GlobalId)
            continue
        connections.append(
            Connection(
                relating_id=relating_id,
                related_id=related_id,
                realizing_ids=tuple(product_key(r, keys) for r in relation.RealizingElements or ()),
                connection_type=relation.ConnectionType or "",
                global_id=relation.GlobalId,
            )
        )
    return connections


def _assemblies(
    ifc: ifcopenshell.file, elements: dict[str, Element], storey_cache: dict, keys: dict[int, str]
) -> dict[str, Assembly]:
    """Outermost aggregates lifted as one unit (:func:`is_unit_whole`) with at least one loaded part
    (parts of nested aggregates included, and the whole itself when it has a body of its own)."""
    order = {gid: index for index, gid in enumerate(elements)}
    assemblies = {}
    wholes = {rel.RelatingObject for rel in ifc.by_type("IfcRelAggregates") if is_unit_whole(rel.RelatingObject)}
    for whole in sorted(wholes, key=lambda w: w.id()):
        if outermost_unit(whole).id() != whole.id():
            continue  # a sub-assembly: its parts belong to the outer unit
        below = [whole, *ifcopenshell.util.element.get_decomposition(whole, is_recursive=True)]
        parts = sorted({key for p in below if (key := product_key(p, keys)) in order}, key=order.__getitem__)
        if parts:
            storey = _storey_of(whole, storey_cache)
            key = product_key(whole, keys)
            assemblies[key] = Assembly(key, whole.Name or "", storey, tuple(parts), whole.is_a())
    return assemblies


#: Aggregates whose parts are installed one by one on site (a roof of rafters and slabs, a curtain wall
#: of mullions and panels, a stair or ramp of flights and landings): never one lifted unit.
BUILT_IN_PLACE_WHOLES = ("IfcRoof", "IfcCurtainWall", "IfcStair", "IfcRamp")


def is_unit_whole(entity) -> bool:
    """Whether ``entity`` is an aggregate lifted and placed as one unit: an IfcElement (not spatial, not
    a feature) that aggregates parts and is not one of :data:`BUILT_IN_PLACE_WHOLES`. IfcElementAssembly
    always is; so are Tekla's precast floor plates (an IfcSlab of proxies) and a window of members."""
    if entity is None or not entity.is_a("IfcElement") or entity.is_a("IfcFeatureElement"):
        return False
    if entity.is_a("IfcElementAssembly"):
        return True
    return not any(entity.is_a(name) for name in BUILT_IN_PLACE_WHOLES)


def outermost_unit(product):
    """The outermost aggregate lifted as one unit (:func:`is_unit_whole`) that holds ``product`` (itself
    when it is one), or None: the climb stops at a whole built in place (a roof) or a spatial element."""
    found = product if is_unit_whole(product) and getattr(product, "IsDecomposedBy", None) else None
    node = product
    for _ in range(32):  # aggregation trees are shallow; the bound guards against cyclic files
        parent = ifcopenshell.util.element.get_aggregate(node)
        if parent is None or not is_unit_whole(parent):
            break
        found = node = parent
    return found


def outermost_assembly(product):
    """The outermost IfcElementAssembly that holds ``product`` (itself when it is one), or None."""
    found = product if product.is_a("IfcElementAssembly") else None
    node = product
    for _ in range(32):  # aggregation trees are shallow; the bound guards against cyclic files
        parent = ifcopenshell.util.element.get_aggregate(node)
        if parent is None or not parent.is_a("IfcElementAssembly"):
            break
        found = node = parent
    return found


# ---- finishing a model: bodies' origins, prebuilt selection, unknown weights --------------------------

#: An origin farther than this outside its body's local bounding box lies elsewhere (metres). Real
#: exports put an origin up to about 0.5 m off the body on purpose (Revit's beam ends at the column's
#: axis, ArchiCAD's wall reference lines); Revit's columns, slabs and stair flights placed at (0, 0, 0)
#: lie 3-110 m away.
ORIGIN_OFF_BODY_M = 1.0


def _finish(model: BuildingModel, ifc, keys: dict[int, str], prebuilt: str | None, unknown_weight) -> BuildingModel:
    """What :func:`load_model` does once the elements are read: origins onto bodies, the prebuilt
    selection, the unknown-weight rule."""
    model.relocated = anchor_to_bodies(model.elements.values(), ORIGIN_OFF_BODY_M)
    if model.relocated:
        log.info("%s: %d element(s) are placed away from their bodies; their origins were moved onto them",
                 _shown(model.source), len(model.relocated))
    if prebuilt is not None and str(prebuilt).strip():
        from bimrobot.bim.selection import select_ids

        selector = as_selector(prebuilt) if not isinstance(prebuilt, str) else prebuilt
        ids = select_ids(ifc, selector, model.source, "--prebuilt")
        model.prebuilt_selector = selector
        model.prebuilt_ids = frozenset(product_key(ifc.by_id(i), keys) for i in ids)
    if unknown_weight is not None:
        from bimrobot.bim.unknown_weight import apply_unknown_weight_rule

        model.unknown_weights = apply_unknown_weight_rule(model.elements.values(), unknown_weight, _shown(model.source))
    return model


def anchor_to_bodies(elements: Iterable[Element], off_body_m: float = ORIGIN_OFF_BODY_M) -> list:
    """Move the origin of every element whose placement lies away from its body onto the body.

    An origin more than ``off_body_m`` (metres) outside the body's local bounding box is moved to the
    bottom centre of that box: the placement's translation becomes that point in the world and the
    vertices are shifted by the opposite amount, so the body stays exactly where it is in the world
    while ``Element.position`` (and every goal, schedule row, graph node and pose taken from it) is
    where the body is. The rotation is kept. Changes the elements in place; returns a
    :class:`~bimrobot.bim.model.Relocation` per moved element, in the order given.
    """
    from bimrobot.bim.model import Relocation

    moved = []
    for element in elements:
        if not len(element.vertices):
            continue
        low, high = element.local_bounds
        distance = float(np.linalg.norm(np.maximum(0.0, np.maximum(low, -high))))  # origin to the box
        if distance <= off_body_m:
            continue
        anchor = np.array([(low[0] + high[0]) / 2.0, (low[1] + high[1]) / 2.0, low[2]])
        placement = element.placement.copy()
        file_origin = placement[:3, 3].copy()
        placement[:3, 3] = (placement @ np.append(anchor, 1.0))[:3]
        vertices = element.vertices - anchor
        vertices.setflags(write=False)
        element.placement, element.vertices = placement, vertices
        for cached in ("world_vertices", "mesh", "volume_m3"):
            element.__dict__.pop(cached, None)
        moved.append(Relocation(element.global_id, element.ifc_class, element.name, round(distance, 3),
                                tuple(round(float(v), 4) for v in file_origin),
                                tuple(round(float(v), 4) for v in placement[:3, 3])))
    return moved


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


def _storeys(ifc: ifcopenshell.file, length_scale: float) -> list[Storey]:
    """Storeys sorted by elevation; the elevation is the world z of the storey's placement (metres)."""
    storeys = []
    for storey in ifc.by_type("IfcBuildingStorey"):
        if storey.ObjectPlacement is not None:
            matrix = ifcopenshell.util.placement.get_local_placement(storey.ObjectPlacement)
            elevation = float(matrix[2, 3]) * length_scale
        else:
            elevation = float(storey.Elevation or 0.0) * length_scale
        storeys.append(Storey(storey.GlobalId, storey.Name or "", round(elevation, 9)))
    return sorted(storeys, key=lambda s: s.elevation)


def _length_unit_name(ifc: ifcopenshell.file) -> str:
    """The project's length unit as IFC names it (``MILLIMETRE``, ``INCH``); METRE when undeclared."""
    unit = ifcopenshell.util.unit.get_project_unit(ifc, "LENGTHUNIT")
    return ifcopenshell.util.unit.get_full_unit_name(unit) if unit is not None else "METRE"


def _unit_scale_to_kg(unit) -> float:
    """Kilograms in one ``unit`` of mass: an IfcSIUnit (GRAM with its prefix) or an
    IfcConversionBasedUnit (a pound, a tonne: its chain of factors), scaled by ifcopenshell.util.unit,
    whose SI mass unit is the gram; a unit of neither kind (context dependent) is taken as kilograms."""
    if not (unit.is_a("IfcSIUnit") or unit.is_a("IfcConversionBasedUnit")):
        return 1.0
    grams = ifcopenshell.util.unit.get_named_unit_scale(unit)
    return ifcopenshell.util.unit.convert(grams, None, "GRAM", "KILO", "GRAM")


def _mass_unit(ifc: ifcopenshell.file) -> tuple[float, str]:
    """(kilograms per unit, unit name) of the project's mass unit; kilograms when the file declares none."""
    unit = ifcopenshell.util.unit.get_project_unit(ifc, "MASSUNIT")
    if unit is None:
        return 1.0, "KILOGRAM (not declared)"
    return _unit_scale_to_kg(unit), ifcopenshell.util.unit.get_full_unit_name(unit)


def _name_of_first(ifc: ifcopenshell.file, ifc_class: str) -> str:
    found = ifc.by_type(ifc_class)
    return (found[0].Name or "") if found else ""
