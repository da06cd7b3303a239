"""Split an IFC model into one valid IFC file per building element (thesis section 3.3, fig. 3.4).

Each file has the source's schema and header description and holds:

- the element itself with its GlobalId, placement chain and representation (with mapped type
  geometry), and the openings that cut it (``IfcRelVoidsElement``), so its body is the original one;
- its spatial context: project (units, representation contexts), site, building, storey (or space),
  each with its GlobalId and placement but without its own representation (no terrain), linked by
  ``IfcRelAggregates`` / ``IfcRelContainedInSpatialStructure`` relations that name only this element;
- its property sets and quantity sets, its type (and the type's property sets), material and
  classification associations;
- every connection relation that involves it (``IfcRelConnectsElements`` and subclasses such as
  ``IfcRelConnectsWithRealizingElements``, as relating, related or realizing element). The other
  elements of a connection appear as reference stubs: same class, GlobalId and Name, no placement or
  geometry, so the file still says what the element connects to without carrying the neighbours' bodies.

Files are named ``<safe GlobalId>.ifc`` (:func:`bimrobot.world.names.safe_name`) and written
atomically into the output directory together with ``index.json`` (GlobalId -> file, class, name).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import ifcopenshell

from bimrobot.bim.reader import as_selector, open_ifc
from bimrobot.bim.selection import select_products
from bimrobot.errors import InputError
from bimrobot.io import atomic_output_dir

_SPATIAL_ATTRIBUTES_TO_DROP = {"Representation"}


@dataclass(frozen=True)
class SplitFile:
    """One written file: the element's GlobalId, IFC class, name and the file's path."""

    global_id: str
    ifc_class: str
    name: str
    path: Path


def split_model(
    path: str | os.PathLike,
    output_dir: str | os.PathLike,
    include: Iterable[str] | str | None = None,
    exclude: Iterable[str] | str | None = None,
    progress: bool = False,
) -> list[SplitFile]:
    """Write one IFC file per building element of ``path`` into ``output_dir`` (replaced atomically).

    ``include`` / ``exclude`` filter by IFC class as in :func:`bimrobot.bim.load_model`. Every
    ``IfcElement`` except openings and virtual elements is split, including products without a solid
    body (e.g. curve-only welds), since their IFC data is still worth keeping.
    """
    path = Path(path)
    source = open_ifc(path)
    products = select_products(source, as_selector(include), as_selector(exclude), path)
    if not products:
        raise InputError(f"{path} contains no building element to split")
    from bimrobot.world.names import safe_name

    iterable = products
    if progress:
        from tqdm import tqdm

        iterable = tqdm(products, unit="element", desc="split")
    written = []
    with atomic_output_dir(output_dir) as tmp:
        for product in iterable:
            name = f"{safe_name(product.GlobalId)}.ifc"
            extract_element(source, product).write(str(tmp / name))
            written.append(SplitFile(product.GlobalId, product.is_a(), product.Name or "", Path(output_dir) / name))
        index = {
            "source": str(path),
            "schema": source.schema_identifier,
            "elements": [
                {"GlobalId": f.global_id, "file": f.path.name, "class": f.ifc_class, "name": f.name} for f in written
            ],
        }
        (tmp / "index.json").write_text(json.dumps(index, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    return written


def extract_element(source: ifcopenshell.file, element) -> ifcopenshell.file:
    """A new IFC file (same schema) holding ``element`` and its context, as the module docstring lists."""
    return _Extraction(source, element).run()


class _Extraction:
    def __init__(self, source: ifcopenshell.file, element):
        self.source = source
        self.element = element
        self.target = ifcopenshell.file(schema=source.schema_identifier)
        self.copies: dict[int, ifcopenshell.entity_instance] = {}
        self.associations: dict[int, ifcopenshell.entity_instance] = {}

    def run(self) -> ifcopenshell.file:
        self._copy_header()
        element = self.target.add(self.element)
        self.copies[self.element.id()] = element
        self._spatial_context(self.element)
        for project in self.source.by_type("IfcProject"):
            self._spatial(project)
        self._openings()
        self._definitions()
        self._associations()
        self._connections()
        return self.target

    def _copy_header(self) -> None:
        description = self.source.header.file_description.description
        if description:
            self.target.header.file_description.description = tuple(description)
        self.target.header.file_name.name = f"{self.element.GlobalId}.ifc"
        self.target.header.file_name.preprocessor_version = f"bimrobot split (IfcOpenShell {ifcopenshell.version})"

    def _spatial(self, spatial):
        """Copy a project / spatial element without its own representation (placement chain kept)."""
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
                relation = contained[0]
                parent = relation.RelatingStructure
                self._relation(relation, RelatedElements=[self._node(node)], RelatingStructure=self._node(parent))
            elif decomposes:
                relation = decomposes[0]
                parent = relation.RelatingObject
                self._relation(relation, RelatedObjects=[self._node(node)], RelatingObject=self._node(parent))
            elif nests:
                relation = nests[0]
                parent = relation.RelatingObject
                self._relation(relation, RelatedObjects=[self._node(node)], RelatingObject=self._node(parent))
            else:
                return
            node = parent

    def _node(self, entity):
        """The copy of an element or spatial node on the way up (the element itself, or a spatial copy)."""
        if entity.id() in self.copies:
            return self.copies[entity.id()]
        if entity.is_a("IfcSpatialElement") or entity.is_a("IfcSpatialStructureElement") or entity.is_a("IfcProject"):
            return self._spatial(entity)
        copy = self.target.add(entity)  # e.g. an IfcElementAssembly that the element is part of
        self.copies[entity.id()] = copy
        return copy

    def _relation(self, relation, **overrides):
        """Create a copy of ``relation`` (GlobalId, OwnerHistory, Name kept) with the given attributes."""
        values = {"GlobalId": relation.GlobalId, "Name": relation.Name, "Description": relation.Description}
        if relation.OwnerHistory is not None:
            values["OwnerHistory"] = self.target.add(relation.OwnerHistory)
        values.update(overrides)
        return self.target.create_entity(relation.is_a(), **values)

    def _openings(self) -> None:
        for relation in getattr(self.element, "HasOpenings", ()) or ():
            self._relation(
                relation,
                RelatingBuildingElement=self.copies[self.element.id()],
                RelatedOpeningElement=self.target.add(relation.RelatedOpeningElement),
            )
        for relation in getattr(self.element, "HasProjections", ()) or ():
            self._relation(
                relation,
                RelatingElement=self.copies[self.element.id()],
                RelatedFeatureElement=self.target.add(relation.RelatedFeatureElement),
            )

    def _definitions(self) -> None:
        """Property / quantity sets and the type (IFC2X3 keeps the type in IsDefinedBy, IFC4 in IsTypedBy)."""
        element = self.copies[self.element.id()]
        relations = list(getattr(self.element, "IsDefinedBy", ()) or ()) + list(getattr(self.element, "IsTypedBy", ()) or ())
        for relation in relations:
            if relation.is_a("IfcRelDefinesByProperties"):
                self._relation(
                    relation,
                    RelatedObjects=[element],
                    RelatingPropertyDefinition=self._value(relation.RelatingPropertyDefinition),
                )
            elif relation.is_a("IfcRelDefinesByType"):
                original_type = relation.RelatingType
                copied_type = self.target.add(original_type)
                self._relation(relation, RelatedObjects=[element], RelatingType=copied_type)
                self._associations(original_type, copied_type)

    def _associations(self, original=None, copy=None) -> None:
        """Material and classification associations of the element (or of its type)."""
        original = original or self.element
        copy = copy or self.copies[self.element.id()]
        for relation in getattr(original, "HasAssociations", ()) or ():
            if relation.id() in self.associations:  # one relation for the element and its type: merge
                merged = self.associations[relation.id()]
                merged.RelatedObjects = tuple(merged.RelatedObjects) + (copy,)
                continue
            values = {"RelatedObjects": [copy]}
            for index in range(len(relation)):
                attribute = relation.attribute_name(index)
                if attribute.startswith("Relating") and relation[index] is not None:
                    values[attribute] = self._value(relation[index])
            self.associations[relation.id()] = self._relation(relation, **values)

    def _connections(self) -> None:
        relations = []
        for inverse in ("ConnectedTo", "ConnectedFrom", "IsConnectionRealization"):
            relations.extend(getattr(self.element, inverse, ()) or ())
        done = set()
        for relation in relations:
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
        """The element itself, or a reference stub of another product (class, GlobalId, Name only)."""
        key = product.id()
        if key not in self.copies:
            values = {"GlobalId": product.GlobalId, "Name": product.Name}
            if product.OwnerHistory is not None:
                values["OwnerHistory"] = self.target.add(product.OwnerHistory)
            self.copies[key] = self.target.create_entity(product.is_a(), **values)
        return self.copies[key]
