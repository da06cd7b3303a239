"""The terms of the construction graph: the BOT, DiCon (``dice:``, ``dicp:``) and ``brc:`` namespaces, the
states a component or an activity can be in, and how identifiers, values and property names become IRIs
and literals (floats to 1e-9: metres and seconds).
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any
from urllib.parse import quote

from rdflib import RDFS, XSD, Literal, Namespace, URIRef

from bimrobot.core.errors import InputError


@functools.lru_cache(maxsize=None)
def _term(namespace: str, name: str) -> URIRef:
    return URIRef(namespace + name)


@functools.lru_cache(maxsize=1 << 16)
def quoted(identifier: str) -> str:
    """``identifier`` percent-encoded for an IRI (cached: an element's IRI is made for each of its triples)."""
    return quote(identifier, safe="")


class _Namespace(Namespace):
    """An rdflib Namespace that makes each term once: ``BOT.Element`` is looked up half a million times
    while a large graph is built, and rdflib validates a new URIRef on every attribute access."""

    def term(self, name: str) -> URIRef:
        return _term(str(self), name)


BOT = _Namespace("https://w3id.org/bot#")
DICE = _Namespace("https://w3id.org/digitalconstruction/0.5/Entities#")
DICP = _Namespace("https://w3id.org/digitalconstruction/0.5/Processes#")
BRC = _Namespace("https://bimrobot.example/ns#")
PROPS = _Namespace("https://bimrobot.example/props#")
#: Provenance of a joint and of its connection nodes (``brc:provenance``).
FROM_IFC_RELATION, FROM_GEOMETRY = "ifc-relation", "inferred-geometry"
DEFAULT_BASE = "https://bimrobot.example/data/"

PREFIXES = {
    "bot": str(BOT), "dice": str(DICE), "dicp": str(DICP), "brc": str(BRC), "props": str(PROPS),
    "xsd": str(XSD), "rdfs": str(RDFS),
}  # fmt: skip
VOCABULARY_FILE = Path(__file__).with_name("vocabulary.ttl")
QUERY_DIR = Path(__file__).with_name("queries")

#: The thesis' component / connection-node states (chapter 4, fig. 4.2), in construction order.
COMPONENT_STATES = (
    "OnYard",
    "InTransit",
    "Arrived",
    "InLocation",
    "WorkingInPositioning",
    "PositionFixed",
    "WaitForAssembly",
    "WorkingInAssembly",
    "Assembled",
)
#: Execution states of an activity.
ACTIVITY_STATES = ("NotStarted", "Started", "Completed", "Failed")

Triple = tuple[URIRef, URIRef, Any]


def state_name(state: Any, allowed: tuple[str, ...], what: str) -> str:
    name = getattr(state, "value", state)
    if name not in allowed:
        raise InputError(f"unknown {what} state {name!r}: use one of {', '.join(allowed)}")
    return name


@functools.lru_cache(maxsize=1 << 16, typed=True)  # typed: True and 1 are different literals
def literal(value: Any) -> Literal:
    if isinstance(value, bool):
        return Literal(value)
    if isinstance(value, float):
        # Nanometre / nanosecond precision: drops float noise (3.8200000000000007).
        return Literal(round(value, 9), datatype=XSD.double)
    return Literal(value)


def property_iri(key: str) -> URIRef:
    """``"Pset_ColumnCommon/Reference"`` -> ``props:Pset_ColumnCommon.Reference`` (other characters
    than letters, digits, ``_``, ``-`` percent-encoded)."""
    pset, _, name = key.rpartition("/")
    local = f"{pset}.{name}" if pset else name
    return PROPS[quote(local, safe="_-.")]
