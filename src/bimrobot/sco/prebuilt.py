"""Which components are work of others: the ``--prebuilt`` rule (thesis 4.5.2: foundations on site).

A comma list of IFC class names (``"IfcFooting, IfcPile"``) is read without the IFC file, a class taking
its subclasses in the model's schema; any other IfcOpenShell selector is evaluated on the model's file.
"""

from __future__ import annotations

import logging
import re
from typing import Iterable

from bimrobot.bim.model import BuildingModel
from bimrobot.bim.selection import DEFAULT_PREBUILT
from bimrobot.core.errors import InputError

log = logging.getLogger(__name__)

#: Classes that are foundations already built on site when the simulation starts (thesis 4.5.2): the
#: default ``--prebuilt`` selector (:data:`bimrobot.bim.selection.DEFAULT_PREBUILT`) as a tuple.
PREBUILT_CLASSES = tuple(name.strip() for name in DEFAULT_PREBUILT.split(","))
#: The class name that, given to ``prebuilt_classes``, marks every assembly unit prebuilt.
ASSEMBLY_CLASS = "IfcElementAssembly"
#: Schemas whose class names ``prebuilt_classes`` may use (a name valid in any of them is accepted).
KNOWN_SCHEMAS = ("IFC2X3", "IFC4", "IFC4X3_ADD2")


def _schema(name: str):
    import ifcopenshell

    try:
        return ifcopenshell.ifcopenshell_wrapper.schema_by_name(name)
    except Exception:  # an unknown schema (e.g. a generated model): fall back to IFC4 where used
        return None


def _declaration(schema, name: str):
    if schema is None:
        return None
    try:
        return schema.declaration_by_name(name)
    except Exception:
        return None


_CLASS_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")  # a bare name: the old class list


class PrebuiltRule:
    """Which components are prebuilt (work of others), from a ``--prebuilt`` selector.

    Called with an IFC class name it says whether that class is prebuilt (subclasses count), as the
    plain class rule always did; :meth:`of` decides for a component: an element or unit the selector
    picked, one of a prebuilt class, or a unit whose whole is of a prebuilt class (or, with
    ``IfcElementAssembly`` among the classes, any unit), or whose parts the selector all picked.
    """

    def __init__(self, classes: set[str], own_schema, ids: frozenset[str] = frozenset()):
        self.classes, self.ids, self._own, self._cache = classes, ids, own_schema, {}
        self.assemblies = ASSEMBLY_CLASS in classes

    def __call__(self, ifc_class: str) -> bool:
        if ifc_class not in self._cache:
            declaration = _declaration(self._own, ifc_class)
            names = {ifc_class}
            while declaration is not None:
                names.add(declaration.name())
                declaration = declaration.supertype()
            self._cache[ifc_class] = bool(names & self.classes)
        return self._cache[ifc_class]

    def of(self, component_id: str, ifc_class: str, whole_class: str | None = None, part_ids=()) -> bool:
        """Whether the component (an element, or a unit of ``part_ids`` whose whole is ``whole_class``) is prebuilt."""
        if component_id in self.ids or self(ifc_class):
            return True
        if part_ids:
            if self.assemblies or (whole_class and self(whole_class)):
                return True
            return bool(self.ids) and all(p in self.ids for p in part_ids)
        return False


def prebuilt_selector(text: str | None) -> str | None:
    """The ``--prebuilt`` text when it is a selector that is evaluated on the IFC file (give it to
    ``load_model(prebuilt=...)``, which evaluates it on the one parse of the file), or None when it is a
    comma list of IFC class names, which :func:`prebuilt_rule` reads without the file."""
    names = [name.strip() for name in (text or "").split(",") if name.strip()]
    return None if all(_CLASS_NAME.match(name) for name in names) else text


def prebuilt_rule(model: BuildingModel, classes: Iterable[str] | str) -> PrebuiltRule:
    """The :class:`PrebuiltRule` of a ``--prebuilt`` selector (or of IFC class names).

    A comma list of class names (``"IfcFooting, IfcPile"``, the old ``--prebuilt`` syntax) is read
    without the IFC file: a class takes its subclasses in the model's schema (``IfcWall`` takes
    ``IfcWallStandardCase``), and a name valid in another IFC schema only matches nothing. Any other
    selector (``"IfcSlab, /Pset_SlabCommon/.IsExternal=False"``, ``"IfcWall + IfcSlab"``) is evaluated
    with IfcOpenShell: from ``model.prebuilt_ids`` when the model was loaded with that selector
    (``load_model(prebuilt=...)``), else on the model's file. Raises InputError for a name that is no
    IFC class at all (listing the classes the model has) or an invalid selector.
    """
    text = classes if isinstance(classes, str) else ", ".join(str(c) for c in classes)
    names = [name.strip() for name in text.split(",") if name.strip()]
    own = _schema(model.schema) or _schema("IFC4")
    if all(_CLASS_NAME.match(name) for name in names):
        known = [s for s in (_schema(n) for n in KNOWN_SCHEMAS) if s is not None]
        wanted: set[str] = set()
        for name in names:
            declarations = [d for d in (_declaration(s, name) for s in known) if d is not None]
            if not declarations:
                present = sorted(set(model.class_counts()) | ({ASSEMBLY_CLASS} if model.assemblies else set()))
                raise InputError(
                    f"--prebuilt names '{name}', which is not an IFC class "
                    f"(this model's classes: {', '.join(present) or 'none'})"
                )
            wanted.add(declarations[0].name())
        return PrebuiltRule(wanted, own)
    if getattr(model, "prebuilt_selector", None) == text:
        return PrebuiltRule(set(), own, model.prebuilt_ids)
    if model.source is None or not str(model.source).lower().endswith((".ifc", ".ifczip")):
        raise InputError(f"--prebuilt '{text}' is a selector, which needs the model's IFC file; give IFC class names instead")
    from bimrobot.bim.reader import open_ifc, product_key, product_keys
    from bimrobot.bim.selection import select_ids

    log.info("evaluating --prebuilt '%s' on %s", text, model.source)
    ifc = open_ifc(model.source)
    keys = product_keys(ifc)
    ids = frozenset(product_key(ifc.by_id(i), keys) for i in select_ids(ifc, text, model.source, "--prebuilt"))
    return PrebuiltRule(set(), own, ids)
