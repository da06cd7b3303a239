"""Split an IFC model into valid IFC files: one per precast/steel assembly, or one per building element
(thesis section 3.3, fig. 3.4).

**Units.** In Tekla precast and steel exports the ``IfcElementAssembly`` is what is cast, lifted and
placed, so by default (when the model has assemblies) every *outermost* assembly becomes one file
holding all its parts (nested sub-assemblies folded in); so does every other aggregate lifted as one
unit (a Tekla wide-slab floor plate, a window with its frame and pane: the model's
:attr:`~bimrobot.bim.model.BuildingModel.assemblies`); an element that belongs to no assembly gets a
file of its own. ``by_element=True`` writes one file per element, assemblies included, as a model
without assemblies always is.

Each file has the source's schema and header description and holds:

- the unit's elements with their GlobalIds, placement chains and representations (with mapped type
  geometry), and the openings that cut them (``IfcRelVoidsElement``), so their bodies are the original
  ones; for an assembly, the assembly and its sub-assemblies (no body of their own) with the
  ``IfcRelAggregates`` that tie the parts to them;
- their spatial context: project (units, representation contexts), site, building, storey (or space),
  each with its GlobalId and placement but without its own representation (no terrain), linked by
  ``IfcRelAggregates`` / ``IfcRelContainedInSpatialStructure`` relations that name only this unit's
  elements; a parent that is not part of the unit (e.g. the stair of a flight) is copied the same way;
- their property sets and quantity sets, types (and the types' property sets), material and
  classification associations;
- every connection relation that involves them (``IfcRelConnectsElements`` and subclasses such as
  ``IfcRelConnectsWithRealizingElements``, as relating, related or realizing element). Elements outside
  the unit appear as reference stubs: same class, GlobalId and Name, no placement or geometry, so the
  file still says what the unit connects to without carrying the neighbours' bodies.

Files are named ``<safe key>.ifc`` (:func:`bimrobot.core.names.safe_name` of the assembly's or
element's GlobalId; a GlobalId that the file uses twice is keyed ``<GlobalId>#<step id>`` as in
:func:`bimrobot.bim.load_model`) and written atomically into the output folder together with
``index.json`` (key -> file, class, name, and for assemblies their parts).
"""

from __future__ import annotations

import json
import logging
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import ifcopenshell
import ifcopenshell.util.element

from bimrobot.core import io
from bimrobot.bim.reader import (
    as_selector,
    duplicate_global_ids,
    duplicates_message,
    open_ifc,
    is_unit_whole,
    outermost_unit,
    product_key,
    product_keys,
)
from bimrobot.bim.selection import describe, select_products
from bimrobot.core.errors import InputError
from bimrobot.core.io import printable
from bimrobot.core.names import safe_name

log = logging.getLogger(__name__)

_SPATIAL_ATTRIBUTES_TO_DROP = {"Representation"}


@dataclass(frozen=True)
class SplitPart:
    """An element inside an assembly's file: key (GlobalId), IFC class and name."""

    global_id: str
    ifc_class: str
    name: str


@dataclass(frozen=True)
class SplitFile:
    """One written file: the unit's key (the element's or assembly's GlobalId), IFC class, name, the
    file's path and, for an assembly, the parts it holds (empty for a single element)."""

    global_id: str
    ifc_class: str
    name: str
    path: Path
    parts: tuple[SplitPart, ...] = ()


@dataclass
class _Unit:
    """What goes into one file: ``head`` names it; ``members`` are copied with their bodies and data."""

    head: object
    members: list
    parts: list


def split_model(
    path: str | os.PathLike,
    output_dir: str | os.PathLike,
    include: Iterable[str] | str | None = None,
    exclude: Iterable[str] | str | None = None,
    progress: bool = False,
    by_element: bool | None = None,
) -> list[SplitFile]:
    """Write one IFC file per assembly or element of ``path`` into ``output_dir`` (written atomically).

    ``include`` / ``exclude``: IfcOpenShell selectors as in :func:`bimrobot.bim.load_model`.
    ``by_element``: one file per element; ``None`` (default) splits by outermost lifted aggregate
    (an IfcElementAssembly, a Tekla wide-slab plate, a window: see
    :func:`~bimrobot.bim.reader.is_unit_whole`) when the model has any, else by element. Every ``IfcElement`` except openings and virtual
    elements is written, including products without a solid body (e.g. curve-only welds), since their
    IFC data is still worth keeping. ``output_dir`` follows :mod:`bimrobot.core.io`'s policy.
    """
    path = Path(path)
    io.check_output(output_dir, folder=True, inputs=[path])
    source = open_ifc(path)
    products = select_products(source, as_selector(include), as_selector(exclude), path)
    if not products:
        raise InputError(f"{printable(str(path))} contains no building element to split ({describe(as_selector(include), as_selector(exclude))})")
    keys = product_keys(source)
    duplicates = duplicate_global_ids(source)
    if duplicates:
        log.warning("%s", duplicates_message(path, duplicates, keys))
    if by_element is None:
        by_element = not any(outermost_unit(p) is not None for p in products)
    units = _units_by_element(products) if by_element else _units_by_assembly(products)

    iterable = units
    if progress:
        from tqdm import tqdm

        iterable = tqdm(units, unit="file", desc="split")
    written: list[SplitFile] = []
    with io.atomic_output_dir(output_dir, kind="split", inputs=[path]) as tmp:
        for unit in iterable:
            key = product_key(unit.head, keys)
            name = f"{safe_name(key)}.ifc"
            _Extraction(source, unit.members, name).run().write(str(tmp / name))
            parts = tuple(SplitPart(product_key(p, keys), p.is_a(), p.Name or "") for p in unit.parts)
            written.append(SplitFile(key, unit.head.is_a(), unit.head.Name or "", Path(output_dir) / name, parts))
        on_disk = sorted(p.name for p in tmp.glob("*.ifc"))
        if len(on_disk) != len(written):  # two keys with one file name would lose a unit: never silently
            raise RuntimeError(f"bimrobot bug: {len(written)} files were written but {len(on_disk)} are in {tmp}")
        (tmp / "index.json").write_text(json.dumps(_index(path, source, written, by_element), indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    return written


def _units_by_element(products: list) -> list[_Unit]:
    return [_Unit(p, [p], []) for p in products]


def _units_by_assembly(products: list) -> list[_Unit]:
    """One unit per outermost lifted aggregate (:func:`~bimrobot.bim.reader.outermost_unit`: an
    IfcElementAssembly, a wide-slab floor plate, a window) holding a selected product; a product in no
    such aggregate alone.

    A unit's members are its whole, its sub-wholes and its selected parts (file order); a whole chosen
    by the selection whose parts all were left out is written alone, like any element.
    """
    units: dict[int, _Unit] = {}
    wholes: set[int] = set()
    for product in products:
        outer = outermost_unit(product)
        if outer is None:
            units[product.id()] = _Unit(product, [product], [])
            continue
        unit = units.get(outer.id())
        if unit is None:
            below = ifcopenshell.util.element.get_decomposition(outer, is_recursive=True)
            subwholes = sorted((e for e in below if is_unit_whole(e) and e.IsDecomposedBy), key=lambda e: e.id())
            wholes.update(e.id() for e in (outer, *subwholes))
            unit = units[outer.id()] = _Unit(outer, [outer, *subwholes], [])
        if product.id() not in wholes:
            unit.members.append(product)
            unit.parts.append(product)
    return sorted(units.values(), key=lambda u: u.head.id())


def _index(path: Path, source: ifcopenshell.file, written: list[SplitFile], by_element: bool) -> dict:
    rows = []
    for f in written:
        row = {"GlobalId": f.global_id, "file": f.path.name, "class": f.ifc_class, "name": f.name}
        if f.parts and not by_element:
            row["parts"] = [{"GlobalId": p.global_id, "class": p.ifc_class, "name": p.name} for p in f.parts]
        rows.append(row)
    return {
        "generator": io.signature("split"),
        "source": str(path),
        "schema": source.schema_identifier,
        "split_by": "element" if by_element else "assembly",
        "files": len(written),
        "elements": rows,
    }


def extract_element(source: ifcopenshell.file, element) -> ifcopenshell.file:
    """A new IFC file (same schema) holding ``element`` and its context, as the module docstring lists."""
    return _Extraction(source, [element], f"{element.GlobalId}.ifc").run()


def extract_assembly(source: ifcopenshell.file, assembly) -> ifcopenshell.file:
    """A new IFC file holding ``assembly``, its sub-assemblies and all its parts, with their context."""
    below = ifcopenshell.util.element.get_decomposition(assembly, is_recursive=True)
    parts = (e for e in below if e.is_a("IfcElement") and not (e.is_a("IfcFeatureElement") or e.is_a("IfcVirtualElement")))
    members = [assembly, *sorted(parts, key=lambda e: e.id())]
    return _Extraction(source, members, f"{assembly.GlobalId}.ifc").run()


class _Extraction:
    """Copy ``members`` (the first names the file) and their context from ``source`` into a new file."""

    def __init__(self, source: ifcopenshell.file, members: list, file_name: str):
        self.source = source
        self.members = members
        self.file_name = file_name
        self.target = ifcopenshell.file(schema=source.schema_identifier)
        self.copies: dict[int, ifcopenshell.entity_instance] = {}
        self.relations: dict[int, ifcopenshell.entity_instance] = {}  # source relation id -> its copy

    def run(self) -> ifcopenshell.file:
        self._copy_header()
        for member in self.members:  # all members first: a relation between two of them joins the copies
            self.copies[member.id()] = self.target.add(member)
        for member in self.members:
            self._spatial_context(member)
        for project in self.source.by_type("IfcProject"):
            self._spatial(project)
        for member in self.members:
            self._openings(member)
            self._definitions(member)
            self._associations(member, self.copies[member.id()])
        self._connections()
        return self.target

    def _copy_header(self) -> None:
        description = self.source.header.file_description.description
        if description:
            self.target.header.file_description.description = tuple(description)
        self.target.header.file_name.name = self.file_name
        self.target.header.file_name.preprocessor_version = f"{io.signature('split')}, IfcOpenShell {ifcopenshell.version}"
        system = self.source.header.file_name.originating_system
        if system:
            self.target.header.file_name.originating_system = system

    def _spatial(self, spatial):
        """Copy a project / spatial element / outside parent without its own representation (placement kept)."""
        key = spatial.id()
        if key not in self.copies:
            values = {}
            for index in range(len(spatial)):
                attribute = spatial.attribute_name(index)
                value = spatial[index]
                if attribute in _SPATIAL_ATTRIBUTES_TO_DROP or value is None:
                    continue
                values[attribute] = self._value(value)
            self.copies[key] = self.target.create_entity(spatial.is_a(), **values)
        return self.copies[key]

    def _value(self, value):
        if isinstance(value, ifcopenshell.entity_instance):
            return self.target.add(value)
        if isinstance(value, tuple):
            return tuple(self._value(v) for v in value)
        return value

    def _spatial_context(self, node) -> None:
        """Recreate the containment / aggregation chain from ``node`` up to the project."""
        for _ in range(32):
            contained = [r for r in getattr(node, "ContainedInStructure", ()) or ()]
            decomposes = [r for r in getattr(node, "Decomposes", ()) or () if r.is_a("IfcRelAggregates")]
            nests = [r for r in getattr(node, "Nests", ()) or ()]
            if contained:
                relation, related, relating = contained[0], "RelatedElements", "RelatingStructure"
            elif decomposes:
                relation, related, relating = decomposes[0], "RelatedObjects", "RelatingObject"
            elif nests:
                relation, related, relating = nests[0], "RelatedObjects", "RelatingObject"
            else:
                return
            parent = getattr(relation, relating)
            if not self._shared(relation, related, self._node(node), **{relating: self._node(parent)}):
                return  # the chain above was recreated by an earlier member
            node = parent

    def _node(self, entity):
        """The copy of a member, or of a spatial node or outside parent on the way up (without its body)."""
        if entity.id() in self.copies:
            return self.copies[entity.id()]
        return self._spatial(entity)

    def _relation(self, relation, **overrides):
        """Create a copy of ``relation`` (GlobalId, OwnerHistory, Name kept) with the given attributes."""
        values = {"GlobalId": relation.GlobalId, "Name": relation.Name, "Description": relation.Description}
        if relation.OwnerHistory is not None:
            values["OwnerHistory"] = self.target.add(relation.OwnerHistory)
        values.update(overrides)
        return self.target.create_entity(relation.is_a(), **values)

    def _shared(self, relation, related: str, copy, **overrides) -> bool:
        """Copy a one-to-many relation once and add ``copy`` to its ``related`` list; True when new.

        Several members often share one relation (the storey's containment, a type, a property set,
        a material): one copy keeps the file free of duplicate GlobalIds.
        """
        existing = self.relations.get(relation.id())
        if existing is None:
            self.relations[relation.id()] = self._relation(relation, **{related: [copy]}, **overrides)
            return True
        current = tuple(getattr(existing, related) or ())
        if copy not in current:
            setattr(existing, related, current + (copy,))
        return False

    def _openings(self, member) -> None:
        for relation in getattr(member, "HasOpenings", ()) or ():
            self._relation(
                relation,
                RelatingBuildingElement=self.copies[member.id()],
                RelatedOpeningElement=self.target.add(relation.RelatedOpeningElement),
            )
        for relation in getattr(member, "HasProjections", ()) or ():
            self._relation(
                relation,
                RelatingElement=self.copies[member.id()],
                RelatedFeatureElement=self.target.add(relation.RelatedFeatureElement),
            )

    def _definitions(self, member) -> None:
        """Property / quantity sets and the type (IFC2X3 keeps the type in IsDefinedBy, IFC4 in IsTypedBy)."""
        element = self.copies[member.id()]
        relations = list(getattr(member, "IsDefinedBy", ()) or ()) + list(getattr(member, "IsTypedBy", ()) or ())
        for relation in relations:
            if relation.is_a("IfcRelDefinesByProperties"):
                definition = self._value(relation.RelatingPropertyDefinition)
                self._shared(relation, "RelatedObjects", element, RelatingPropertyDefinition=definition)
            elif relation.is_a("IfcRelDefinesByType"):
                original_type = relation.RelatingType
                copied_type = self.target.add(original_type)
                if self._shared(relation, "RelatedObjects", element, RelatingType=copied_type):
                    self._associations(original_type, copied_type)

    def _associations(self, original, copy) -> None:
        """Material and classification associations of a member (or of its type)."""
        for relation in getattr(original, "HasAssociations", ()) or ():
            if relation.id() in self.relations:  # one relation for several members or a type: merge
                self._shared(relation, "RelatedObjects", copy)
                continue
            values = {}
            for index in range(len(relation)):
                attribute = relation.attribute_name(index)
                if attribute.startswith("Relating") and relation[index] is not None:
                    values[attribute] = self._value(relation[index])
            self._shared(relation, "RelatedObjects", copy, **values)

    def _connections(self) -> None:
        done = set()
        for member in self.members:
            for inverse in ("ConnectedTo", "ConnectedFrom", "IsConnectionRealization"):
                for relation in getattr(member, inverse, ()) or ():
                    if relation.id() in done:
                        continue
                    done.add(relation.id())
                    values = {}
                    for index in range(len(relation)):
                        attribute = relation.attribute_name(index)
                        if attribute in ("GlobalId", "OwnerHistory", "Name", "Description") or relation[index] is None:
                            continue
                        values[attribute] = self._connection_value(relation[index])
                    self._relation(relation, **values)

    def _connection_value(self, value):
        if isinstance(value, tuple):
            return tuple(self._connection_value(v) for v in value)
        if isinstance(value, ifcopenshell.entity_instance) and value.is_a("IfcProduct"):
            return self._stub(value)
        return self._value(value)

    def _stub(self, product):
        """A member itself, or a reference stub of another product (class, GlobalId, Name only)."""
        key = product.id()
        if key not in self.copies:
            values = {"GlobalId": product.GlobalId, "Name": product.Name}
            if product.OwnerHistory is not None:
                values["OwnerHistory"] = self.target.add(product.OwnerHistory)
            self.copies[key] = self.target.create_entity(product.is_a(), **values)
        return self.copies[key]
