"""Choosing elements: ``--include`` / ``--exclude`` / ``--prebuilt`` in IfcOpenShell's selector syntax, the same everywhere.

A selector is what ``ifcopenshell.util.selector.filter_elements`` reads, e.g. ``"IfcBeam, IfcColumn"``,
``"IfcElement, ! IfcFurnishingElement"``, ``"IfcWall, /Pset_WallCommon/.IsExternal=True"`` or the union
``"IfcStair + IfcRailing"``. Class names take their subclasses. ``include`` picks the elements,
``exclude`` then removes some; ``--prebuilt`` names the elements that are work of others (default
:data:`DEFAULT_PREBUILT`, foundations). The old comma list of classes (``IfcFooting,IfcSlab``) is a
selector too.

Commands that decide what robots build (``simulate``, ``graph``, ``rcan``, ``build``) always exclude
:data:`NOT_ASSEMBLED` unless told not to: furniture, doors, windows, coverings, openings and MEP
(every ``IfcDistributionElement``: terminals, fittings, pipes, ducts, devices) are fitted by trades, not
assembled by the structure's robots. ``--exclude X`` leaves X out *as well*; ``--no-default-exclusions``
(or ``--exclude none``) keeps the defaults in, and ``--exclude 'none + X'`` leaves out X alone.
``convert``, ``inspect`` and ``split`` exclude nothing by default.

:func:`check_selection` checks every selector of a command against the model's schema in the first
seconds (it parses the file, no geometry), so a typo is refused before any long work.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from bimrobot.core.errors import InputError

#: What the structure's robots do not assemble unless asked (a selector).
NOT_ASSEMBLED = "IfcFurnishingElement, IfcDoor, IfcWindow, IfcCovering, IfcOpeningElement, IfcDistributionElement"

#: ``--exclude none`` turns the default exclusion off; ``--exclude 'none + X'`` excludes X alone.
NO_EXCLUSION = "none"

#: Elements that are work of others, on site before the robots start (thesis 4.5.2): foundations. The one
#: place this default is written; ``--prebuilt`` takes a selector in its place.
DEFAULT_PREBUILT = "IfcFooting, IfcPile"

_NONE_PREFIX = re.compile(r"^\s*none\s*(?:\+\s*(?P<rest>.*))?$", re.IGNORECASE | re.DOTALL)
_CLASS_TOKEN = re.compile(r"(?<![\w/.\"'])(Ifc[A-Za-z0-9]+)\b")


def add_selection_options(parser: argparse.ArgumentParser, *, built: bool) -> None:
    """Add ``--include`` and ``--exclude`` (selector syntax) to a sub-command.

    ``built``: the command chooses what robots build: :data:`NOT_ASSEMBLED` is always excluded,
    ``--exclude`` adds to it, and ``--no-default-exclusions`` clears it. ``args.exclude`` is then the
    whole exclusion as one selector (see :func:`exclusion`), what :func:`select_products` reads.
    """
    parser.add_argument(
        "--include", metavar="SELECTOR",
        help="only these elements, in IfcOpenShell selector syntax, e.g. 'IfcBeam, IfcColumn' (subclasses count)",
    )
    if not built:
        parser.add_argument(
            "--exclude", metavar="SELECTOR", help="leave these elements out, e.g. 'IfcFurnishingElement, IfcStair'"
        )
        return
    parser.set_defaults(exclude_given=None)
    parser.add_argument(
        "--exclude", metavar="SELECTOR", default=NOT_ASSEMBLED, action=_ExclusionAction,
        help=f"also leave these elements out, e.g. 'IfcStair + IfcRailing' (always left out unless "
        f"--no-default-exclusions: '{NOT_ASSEMBLED}'; 'none' keeps them in)",
    )
    parser.add_argument(
        "--no-default-exclusions", action=_ExclusionAction, nargs=0, default=False,
        help="build furniture, doors, windows, coverings and MEP too (what --exclude leaves out by default)",
    )


def exclusion(given: str | None, defaults: bool = True) -> str:
    """The whole exclusion of a building command as one selector.

    ``given``: what the user gave to ``--exclude`` (None: nothing); a leading ``none`` (``"none"`` or
    ``"none + IfcStair"``) drops the defaults. ``defaults``: False for ``--no-default-exclusions``.
    Returns ``NOT_ASSEMBLED + given``, or ``"none + given"`` / ``"none"`` without the defaults: text
    that gives the same exclusion when handed to ``--exclude`` again.
    """
    given = (given or "").strip() or None
    if given is not None and given.startswith(NOT_ASSEMBLED):  # already a whole exclusion: the same again
        given = given[len(NOT_ASSEMBLED):].strip().lstrip("+").strip() or None
    if given is not None:
        match = _NONE_PREFIX.match(given)
        if match:
            defaults, given = False, (match.group("rest") or "").strip() or None
    if defaults:
        return NOT_ASSEMBLED if given is None or given == NOT_ASSEMBLED else f"{NOT_ASSEMBLED} + {given}"
    return NO_EXCLUSION if given is None else f"{NO_EXCLUSION} + {given}"


class _ExclusionAction(argparse.Action):
    """``--exclude`` and ``--no-default-exclusions`` of a building command, in any order: both set
    ``namespace.exclude`` to the whole exclusion (:func:`exclusion`)."""

    def __call__(self, parser, namespace, values, option_string=None):
        if self.dest == "exclude":
            namespace.exclude_given = values
        else:
            namespace.no_default_exclusions = True
        namespace.exclude = exclusion(
            getattr(namespace, "exclude_given", None), not getattr(namespace, "no_default_exclusions", False)
        )


def add_prebuilt_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--prebuilt SELECTOR`` (default :data:`DEFAULT_PREBUILT`) to a building command."""
    parser.add_argument(
        "--prebuilt", default=DEFAULT_PREBUILT, metavar="SELECTOR",
        help="elements that are work of others, in IfcOpenShell selector syntax like --include, e.g. cast-in-place "
        "slabs and walls: 'IfcFooting, IfcSlab, IfcWall' (the comma list IfcFooting,IfcSlab works too; "
        f"IfcElementAssembly marks every assembly unit; default '{DEFAULT_PREBUILT}')",
    )


def _without_none(selector: str | None) -> str:
    """The selector with a leading ``none`` / ``none +`` (no default exclusions) taken off."""
    selector = (selector or "").strip()
    match = _NONE_PREFIX.match(selector)
    return (match.group("rest") or "").strip() if match else selector


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
    products of their own. Excluding a whole (a window, an assembly) excludes its parts. Raises InputError for an invalid selector or one naming an unknown class.
    """
    products = [
        p for p in ifc.by_type("IfcElement") if not (p.is_a("IfcFeatureElement") or p.is_a("IfcVirtualElement"))
    ]
    include = (include or "").strip()
    exclude = (exclude or "").strip()
    if include:
        chosen = _filter(ifc, include, source, "--include")
        products = [p for p in products if p in chosen]
    exclude = _without_none(exclude)
    if exclude:
        removed = _filter(ifc, exclude, source, "--exclude")
        products = [p for p in products if p not in removed and not _inside(p, removed)]
    products.sort(key=lambda p: p.id())
    return products


def _inside(product, wholes: set) -> bool:
    """Whether ``product`` is a part (at any depth) of one of ``wholes``: excluding a window excludes its
    frame members and panes, excluding an assembly its parts."""
    import ifcopenshell.util.element

    node = product
    for _ in range(32):  # aggregation trees are shallow; the bound guards against cyclic files
        node = ifcopenshell.util.element.get_aggregate(node)
        if node is None or not node.is_a("IfcElement"):
            return False
        if node in wholes:
            return True
    return False


def describe(include: str | None, exclude: str | None) -> str:
    """The selection in words for messages, e.g. ``include 'IfcBeam', exclude 'IfcDoor'``."""
    parts = []
    if include:
        parts.append(f"include '{include}'")
    exclude = _without_none(exclude)
    if exclude:
        parts.append(f"exclude '{exclude}'")
    return ", ".join(parts) or "all elements"


def select_ids(ifc, selector: str, source: Path, option: str) -> set[int]:
    """Step ids of the entities ``selector`` picks in ``ifc`` (InputError for an invalid selector or a
    class the schema does not have, naming ``option``)."""
    return {entity.id() for entity in _filter(ifc, selector, source, option)}


def check_selection(model_path, include: str | None = None, exclude: str | None = None,
                    prebuilt: str | None = None, ifc=None) -> dict[str, int]:
    """Refuse a bad ``--include``, ``--exclude`` or ``--prebuilt`` before any geometry is read.

    Parses ``model_path`` (no geometry: seconds, not minutes, on a large model) and evaluates each
    selector against it. Returns how many products each selects (``{"include": n, "exclude": n,
    "prebuilt": n, "products": n}``, products being what the build would read). Raises InputError, one
    sentence, for an unreadable file, a selector IfcOpenShell cannot parse, a class the schema does not
    have (listing the model's element classes), or a selection that leaves no product. ``ifc``: the file
    already parsed (:func:`bimrobot.bim.ifc_file.open_ifc`), which ``bimrobot build`` then reads the model
    from; None parses it here.
    """
    from bimrobot.bim.ifc_file import open_ifc

    path = Path(model_path)
    ifc = open_ifc(path) if ifc is None else ifc
    counts: dict[str, int] = {}
    for option, selector in (("--include", include), ("--exclude", _without_none(exclude)), ("--prebuilt", prebuilt)):
        if selector and selector.strip():
            counts[option.lstrip("-")] = len(select_ids(ifc, selector, path, option))
    products = select_products(ifc, include, exclude, path)
    if not products:
        raise InputError(f"{path} contains no building element ({describe(include, exclude)})")
    counts["products"] = len(products)
    return counts
