"""Choosing elements: ``--include`` / ``--exclude`` in IfcOpenShell's selector syntax, the same everywhere.

A selector is what ``ifcopenshell.util.selector.filter_elements`` reads, e.g. ``"IfcBeam, IfcColumn"``,
``"IfcElement, ! IfcFurnishingElement"`` or ``"IfcWall, /Pset_WallCommon/.IsExternal=True"``. Class
names take their subclasses. ``include`` picks the elements, ``exclude`` then removes some.

Commands that decide what robots build (``simulate``, ``graph``, ``rcan``) exclude
:data:`NOT_ASSEMBLED` by default: furniture, doors, windows, coverings and openings are fitted by
trades, not assembled by the structure's robots. ``convert`` and ``split`` exclude nothing by default.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from bimrobot.errors import InputError

#: What the structure's robots do not assemble unless asked (a selector).
NOT_ASSEMBLED = "IfcFurnishingElement, IfcDoor, IfcWindow, IfcCovering, IfcOpeningElement"

#: ``--exclude none`` turns the default exclusion off.
NO_EXCLUSION = "none"

_CLASS_TOKEN = re.compile(r"(?<![\w/.\"'])(Ifc[A-Za-z0-9]+)\b")


def add_selection_options(parser: argparse.ArgumentParser, *, built: bool) -> None:
    """Add ``--include`` and ``--exclude`` (selector syntax) to a sub-command.

    ``built``: the command chooses what robots build, so ``--exclude`` defaults to :data:`NOT_ASSEMBLED`.
    """
    parser.add_argument(
        "--include", metavar="SELECTOR",
        help="only these elements, in IfcOpenShell selector syntax, e.g. 'IfcBeam, IfcColumn' (subclasses count)",
    )
    default = NOT_ASSEMBLED if built else None
    parser.add_argument(
        "--exclude", metavar="SELECTOR", default=default,
        help="leave these elements out, e.g. 'IfcFurnishingElement, IfcStair'"
        + (f" (default: '{NOT_ASSEMBLED}'; 'none' keeps everything)" if built else ""),
    )


def _check_classes(ifc, selector: str, source: Path, option: str) -> None:
    """Refuse a selector that names a class the schema does not have (ifcopenshell would match nothing)."""
    import ifcopenshell

    schema = ifcopenshell.ifcopenshell_wrapper.schema_by_name(ifc.schema_identifier)
    for name in _CLASS_TOKEN.findall(selector):
        try:
            schema.declaration_by_name(name)
        except Exception:
            present = sorted({e.is_a() for e in ifc.by_type("IfcElement")})
            raise InputError(
                f"{source}: {option} names '{name}', which is not an {ifc.schema_identifier} class "
                f"(this model's element classes: {', '.join(present) or 'none'})"
            ) from None


def _filter(ifc, selector: str, source: Path, option: str) -> set:
    import ifcopenshell.util.selector

    _check_classes(ifc, selector, source, option)
    try:
        return ifcopenshell.util.selector.filter_elements(ifc, selector)
    except Exception as exc:  # lark's parse errors: several lines; keep the first
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{option} '{selector}' is not a valid IfcOpenShell selector ({first})") from None


def select_products(ifc, include: str | None, exclude: str | None, source: Path) -> list:
    """IfcElements that may carry a body, chosen by ``include`` / ``exclude``, in file order.

    Feature elements (openings, projections: part of their host's body) and virtual elements are never
    products of their own. Raises InputError for an invalid selector or one naming an unknown class.
    """
    products = [
        p for p in ifc.by_type("IfcElement") if not (p.is_a("IfcFeatureElement") or p.is_a("IfcVirtualElement"))
    ]
    include = (include or "").strip()
    exclude = (exclude or "").strip()
    if include:
        chosen = _filter(ifc, include, source, "--include")
        products = [p for p in products if p in chosen]
    if exclude and exclude.lower() != NO_EXCLUSION:
        removed = _filter(ifc, exclude, source, "--exclude")
        products = [p for p in products if p not in removed]
    products.sort(key=lambda p: p.id())
    return products


def describe(include: str | None, exclude: str | None) -> str:
    """The selection in words for messages, e.g. ``include 'IfcBeam', exclude 'IfcDoor'``."""
    parts = []
    if include:
        parts.append(f"include '{include}'")
    if exclude and exclude.lower() != NO_EXCLUSION:
        parts.append(f"exclude '{exclude}'")
    return ", ".join(parts) or "all elements"
