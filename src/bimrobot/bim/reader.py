"""Read an IFC file into a :class:`~bimrobot.bim.model.BuildingModel` in one geometry-iterator pass.

All geometry comes from ifcopenshell's geometry iterator in local coordinates, one pass over the products
(shared by one forked process per core, each with its own iterator over a share of about equal cost): each shape's
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
from pathlib import Path
from typing import Callable, Iterable, Iterator

import numpy as np

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.shape
import ifcopenshell.util.unit

from bimrobot.bim.entities import (
    BUILT_IN_PLACE_WHOLES,
    is_unit_whole,
    length_unit_name,
    mass_unit,
    name_of_first,
    outermost_assembly,
    outermost_unit,
    read_assemblies,
    read_connections,
    read_element,
    read_storeys,
    skipped_product,
)
from bimrobot.bim.ifc_file import (
    READS,
    SUPPORTED_SCHEMAS,
    ReadCounts,
    class_lineage,
    duplicate_global_ids,
    duplicates_message,
    header_schema,
    open_ifc,
    product_key,
    product_keys,
    shown_name,
)
from bimrobot.bim.model import BuildingModel, Element, mesh_volume
from bimrobot.bim.quantities import MaterialDensities
from bimrobot.bim.selection import describe, select_products
from bimrobot.bim.shares import balanced_shares, geometry_costs
from bimrobot.core.errors import InputError

# The file (ifc_file.py) and the entities' data (entities.py) have their own modules (issue 37); callers
# import these names from here, where they were before.
__all__ = [
    "load_model", "check_plausible_geometry", "anchor_to_bodies", "iterate_shapes", "geometry_settings",
    "default_threads", "as_selector", "GEOMETRY_LIBRARY", "READS", "ReadCounts", "SUPPORTED_SCHEMAS", "open_ifc",
    "header_schema", "class_lineage", "product_key", "product_keys", "duplicate_global_ids", "duplicates_message",
    "BUILT_IN_PLACE_WHOLES", "is_unit_whole", "outermost_unit", "outermost_assembly",
]

log = logging.getLogger(__name__)

GEOMETRY_LIBRARY = "hybrid-cgal-simple-opencascade"


_WRONG_TYPE = re.compile(r"entity instance of type '([^']*)' has no attribute '([^']*)'")


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
            raise _refused_wrong_type(shown_name(path), exc) from None

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
    assemblies: bool = True,
    meanwhile: Callable[[], object] | None = None,
) -> BuildingModel:
    """Read ``path`` (IFC2X3, IFC4 or IFC4X3_ADD2) into a BuildingModel (metres, z up, kg).

    ``include`` / ``exclude``: IfcOpenShell selectors (see :mod:`bimrobot.bim.selection`), e.g.
    ``"IfcColumn, IfcBeam"`` or ``"IfcElement, ! IfcFurnishingElement"``, or lists of class names;
    subclasses count, so ``"IfcBuildingElement"`` takes walls, beams, ...
    ``progress``: show a tqdm bar over the geometry pass. ``processes``: forked processes that share the
    geometry pass, each with its own iterator over a share of about equal guessed cost (default: every
    core, at most 8; one below :data:`MIN_PRODUCTS_TO_SHARE` products or where fork is unsafe). ``threads``: the
    iterator's own threads in each process (default: one where several processes share the pass, else
    every core, at most 8). Geometry iterators in separate processes scale where the iterator's threads
    do not: on this project's 2-core build machine two threads bought 0-35 % over one thread (and on
    files of 1-3 ms per element nothing, at twice the CPU), two processes 33-73 % (docs/world.md).
    ``properties``: read every property and quantity value into ``Element.properties``; False leaves
    those empty and reads only what the weights need (weight quantities, weight properties by name),
    which is what ``convert`` does: reading every value costs up to 0.7 ms per element.
    ``prebuilt``: a ``--prebuilt`` selector, evaluated here (``model.prebuilt_ids``) for
    :func:`bimrobot.sco.build.prebuilt_rule`. ``unknown_weight``: an :class:`~bimrobot.bim.unknown_weight.UnknownWeightRule`
    applied once, here, to every element without a weight (``model.unknown_weights`` says what it did).
    An element whose local placement lies away from its body (Revit's stair flights, columns and slabs
    placed at (0, 0, 0) with their bodies metres away) gets its origin moved onto the body
    (:func:`anchor_to_bodies`; ``model.relocated`` lists them), so every consumer reads the body's place.
    ``ifc``: the file ``path`` already parsed by :func:`open_ifc` (``bimrobot build`` parses it once to check
    its selectors); None parses it here. ``assemblies``: False leaves ``model.assemblies`` empty (``convert`` has no use for them: 0.1-0.2 s on Tekla precast).
    ``meanwhile``: called once while forked processes compute the geometry (after the read without fork).
    Raises :class:`~bimrobot.core.errors.InputError` naming the file when it is missing, not IFC, truncated,
    of an unsupported schema, or holds no element with solid geometry.
    """
    path = Path(path)
    ifc = open_ifc(path) if ifc is None else ifc
    READS.geometry[READS.key(path)] += 1
    length_scale = ifcopenshell.util.unit.calculate_unit_scale(ifc)
    mass_scale, mass_name = mass_unit(ifc)
    candidates, keys = _candidates(ifc, path, include, exclude)
    materials = MaterialDensities(ifc)  # each material definition walked once, before any fork
    shares = _shares(ifc, candidates, processes, threads)
    read = _ShareReader(ifc, shown_name(path), mass_scale, keys, materials, properties)
    found = _read_shares(read, shares, progress, threads, meanwhile)
    skipped = _skipped(candidates, found, keys)
    if not found.elements:
        raise InputError(f"{shown_name(path)} contains no element with solid geometry ({len(skipped)} products without a solid body)")
    order = {product_key(p, keys): i for i, p in enumerate(candidates)}
    elements = dict(sorted(found.elements.items(), key=lambda item: order[item[0]]))
    check_plausible_geometry(elements, shown_name(path))
    units = {"length": length_unit_name(ifc), "length_scale_to_m": length_scale, "mass": mass_name, "mass_scale_to_kg": mass_scale}
    model = _building_model(path, ifc, keys, units, elements, skipped, found.storeys, assemblies)
    return _finish(model, ifc, keys, prebuilt, unknown_weight)


def _candidates(ifc: ifcopenshell.file, path: Path, include, exclude) -> tuple[list, dict[int, str]]:
    """The products to read and the keys of those a GlobalId alone cannot name (a duplicated GlobalId must
    not make one element replace another; duplicates are logged). InputError when nothing is selected."""
    candidates = select_products(ifc, as_selector(include), as_selector(exclude), path)
    if not candidates:
        raise InputError(f"{shown_name(path)} contains no building element ({describe(as_selector(include), as_selector(exclude))})")
    keys = product_keys(ifc)
    duplicates = duplicate_global_ids(ifc)
    if duplicates:
        log.warning("%s", duplicates_message(path, duplicates, keys))
    return candidates, keys


def _skipped(candidates: list, found: _Found, keys: dict[int, str]) -> list:
    """The selected products that gave no element (no solid body, or one of no faces), in file order."""
    return [
        dataclasses.replace(skipped_product(p, p.id() in found.empty_bodies), global_id=product_key(p, keys))
        for p in candidates
        if p.id() not in found.seen or p.id() in found.empty_bodies
    ]


def _building_model(path: Path, ifc: ifcopenshell.file, keys: dict[int, str], units: dict, elements: dict[str, Element],
                    skipped: list, storey_cache: dict, assemblies: bool = True) -> BuildingModel:
    """The model of the elements read, with the file's ``units``, storeys, connections and (unless
    ``assemblies`` is False) assemblies."""
    return BuildingModel(
        source=path,
        schema=ifc.schema_identifier,
        project_name=name_of_first(ifc, "IfcProject"),
        site_name=name_of_first(ifc, "IfcSite"),
        units=units,
        storeys=read_storeys(ifc, units["length_scale_to_m"]),
        elements=elements,
        connections=read_connections(ifc, elements, keys),
        skipped=skipped,
        assemblies=read_assemblies(ifc, elements, storey_cache, keys) if assemblies else {},
    )


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
                element = read_element(product, placement, vertices, faces, volume, self.mass_scale,
                                   (found.storeys, type_cache, self.materials), self.properties)
            except AttributeError as exc:  # a reference of the wrong type in the product's data
                if not _WRONG_TYPE.search(str(exc)):
                    raise
                raise _refused_wrong_type(self.shown, exc, product) from None
            element.global_id = product_key(product, self.keys)
            element.volume_m3 = volume()  # once per geometry, here: pickling does not keep the elements sharing it
            found.elements[element.global_id] = element
            found.geometry_ids[element.global_id] = geometry_id
        return found


def _shares(ifc: ifcopenshell.file, candidates: list, processes: int | None, threads: int | None) -> list[list]:
    """The products each process reads: shares of about equal guessed geometry cost
    (:mod:`bimrobot.bim.shares`), each in file order. One share where forking would not pay, or
    cannot be done safely."""
    from bimrobot.core.cores import can_fork

    count = processes or (1 if threads else default_threads())
    if count <= 1 or len(candidates) < MIN_PRODUCTS_TO_SHARE or not can_fork():
        return [candidates]
    return balanced_shares(candidates, count, geometry_costs(ifc, candidates))


def _read_shares(read: _ShareReader, shares: list[list], progress: bool, threads: int | None,
                 meanwhile: Callable[[], object] | None = None) -> _Found:
    """Read every share in a forked process of its own, all at the same time (the parsed file is
    inherited, not reread), while this process does ``meanwhile`` (in this thread: nothing else runs here
    when it forks); their findings come back pickled and errors in a child are raised here.
    The geometry kernel never runs in this process: where it crashes on a malformed product (a
    reference of the wrong type, say: SIGSEGV or SIGFPE in its C++), the child dies and this process
    raises InputError naming the file. Where fork is unsafe, the one share is read here."""
    from bimrobot.core.cores import can_fork

    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=sum(len(share) for share in shares), unit="element", desc="geometry")
    if not can_fork():
        try:
            found = read(shares[0], threads, bar)
        finally:
            if bar is not None:
                bar.close()
        if meanwhile is not None:  # the iterator holds the GIL: a thread would not overlap it
            meanwhile()
        return found
    children: list = []
    child_threads = threads if len(shares) == 1 else (threads or 1)  # one share: the iterator's own threads
    try:
        _fork_children(read, shares, child_threads, children)
        if meanwhile is not None:
            meanwhile()
        return _collect(read, shares, children, bar)
    finally:
        for child in children:
            child.stop()
        if bar is not None:
            bar.close()


def _fork_children(read: _ShareReader, shares: list[list], threads: int | None, children: list) -> None:
    """Start one forked process per share (:class:`bimrobot.core.forked.Forked`), each appended to
    ``children`` as soon as it runs, so that the caller ends every started one whatever happens."""
    from bimrobot.core.cores import frozen_heap
    from bimrobot.core.forked import Forked

    with frozen_heap():  # the children's collections do not copy every page of the file they inherit
        for share in shares:
            children.append(Forked(read, (share, threads), others=tuple(c.receiving for c in children)))


def _collect(read: _ShareReader, shares: list[list], children: list, bar) -> _Found:
    """The children's findings, in share order; a child's error is raised here, its death is an InputError."""

    def died(exit_code: int | None) -> InputError:  # IfcOpenShell's geometry kernel crashed on one of its products
        return InputError(
            f"{read.shown}: IfcOpenShell's geometry kernel crashed (exit code {exit_code}) on one of "
            f"its {sum(len(share) for share in shares)} products (read in {len(children)} share(s)); the "
            "file may be malformed (validate it), or exclude products (--exclude) to find the one it cannot mesh")

    found = _Found()
    for child in children:
        payload = child.outcome(died)
        found.add(payload)
        if bar is not None:
            bar.update(len(payload.seen))
    return found


def _lazy_volume(cache: dict[str, float], key: str, vertices: np.ndarray, faces: np.ndarray):
    """A function giving the mesh volume (m3), computed once per geometry and only when asked for."""

    def volume() -> float:
        if key not in cache:
            cache[key] = mesh_volume(vertices, faces)
        return cache[key]

    return volume


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


def as_selector(value: Iterable[str] | str | None) -> str | None:
    """A selector string from a selector, or from a list of class names (joined with ', ')."""
    if value is None or isinstance(value, str):
        return value
    return ", ".join(v.strip() for v in value if v.strip()) or None


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
                 shown_name(model.source), len(model.relocated))
    if prebuilt is not None and str(prebuilt).strip():
        from bimrobot.bim.selection import select_ids

        selector = as_selector(prebuilt) if not isinstance(prebuilt, str) else prebuilt
        ids = select_ids(ifc, selector, model.source, "--prebuilt")
        model.prebuilt_selector = selector
        model.prebuilt_ids = frozenset(product_key(ifc.by_id(i), keys) for i in ids)
    if unknown_weight is not None:
        from bimrobot.bim.unknown_weight import apply_unknown_weight_rule

        model.unknown_weights = apply_unknown_weight_rule(model.elements.values(), unknown_weight, shown_name(model.source))
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


