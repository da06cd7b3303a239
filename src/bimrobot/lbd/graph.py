"""The construction knowledge graph (thesis chapter 5, fig. 5.5): BOT topology + DiCon processes + live states.

What :func:`build_graph` writes, and with which terms (all defined in BOT 0.3.2 and DiCon 0.5, except
the few ``brc:`` terms of ``vocabulary.ttl``):

* topology: ``bot:Site bot:hasBuilding bot:Building bot:hasStorey bot:Storey bot:containsElement
  bot:Element``. ``bot:hasElement`` is not stated: BOT says it is meant to be inferred from its
  sub-properties such as ``bot:containsElement``.
* connections: one ``bot:Interface`` per connection, ``bot:interfaceOf`` both elements (BOT's own
  example of an interface is "the connection in which the two elements meet"; an adjacency property
  between two elements does not exist in BOT). ``brc:realizingElement`` links the bolts, welds and
  cleats that realise it, ``brc:nodeId`` carries the thesis' node id ``<relating>:<related>``.
* precast assemblies: an outermost ``IfcElementAssembly`` (the unit a crane lifts in Tekla precast and
  steel exports) is a ``bot:Element`` of its own, contained in its storey, with ``bot:hasSubElement``
  each of its parts (which stay elements of their storey too); its weight is the sum of its parts'
  (left out when one is unknown), its position the origin of its main part (the heaviest, whose
  placement the simulated unit takes: the schedule's target) and its size the extents along the
  world axes of the union of its parts. A state set on the assembly is set on its parts too: they
  travel and are placed together. ``build_graph(..., assemblies=False)`` leaves assemblies out.
* element properties: ``brc:globalId``, ``brc:ifcClass``, ``brc:weightKg`` (kg), ``rdfs:label`` (name),
  the placement origin as ``dice:hasQuality`` a ``dice:CartesianPosition`` with ``dice:hasX/Y/Z``
  (metres, world frame, z up), and the size (thesis table 5.1: section dimensions, to match a
  gripper) as ``dice:hasQuality`` a ``dice:CartesianVolume`` with ``dice:hasX/Y/ZLength``: the
  extents of the body's bounding box in the element's local frame (metres). With ``properties=True``
  every property-set value of the element too, as ``props:<Pset>.<Name>`` (units as in the IFC file).
* activities: one ``dicp:Activity`` per schedule row with ``dice:precededBy`` its predecessors
  (FINISH_START), ``dicp:occupiesTimeInterval`` a ``dice:TimeInterval`` with ``dice:hasStart`` /
  ``dice:hasEnd`` ``dice:TimeInstant``s (``brc:atSecond``: seconds from the start of the build),
  ``dicp:hasObject`` the component (and its connection node for ``assemble`` rows), and
  ``dicp:hasOutputObject`` the component on its ``assemble`` activities (the assembled component is
  their output). The robot is a ``dice:Device`` (a robot is an object that performs a function under at
  most intermittent control) and a ``dicp:Resource``; the activity ``dicp:hasAssignedResource`` a
  ``dicp:ResourceRole`` that ``dice:isRoleOf`` the robot (the DiCon resource pattern).
* live state: ``dice:hasEntityState`` one of the ``brc:ComponentState`` individuals (OnYard ...
  Assembled) on every element (``OnYard`` at first) and on connection nodes once set, and one of the ``brc:ActivityState`` individuals
  (NotStarted, Started, Completed, Failed) on every activity.

IRIs are ``<base>element/<GlobalId>``, ``<base>activity/<id>`` etc., with the id percent-encoded
(``$`` -> ``%24``).
"""

from __future__ import annotations

import functools
import itertools
import json
import logging
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Iterator
from urllib.parse import quote, unquote

import rdflib
from pyparsing import ParseException
from rdflib import RDF, RDFS, XSD, Literal, Namespace, URIRef

from bimrobot.core import io
from bimrobot.core.errors import InputError
from bimrobot.bim import components
from bimrobot.core.progress import progress_bar
from bimrobot.schedule.csv import Activity, Schedule
from bimrobot.lbd.store import TripleStore, format_for, load_store, open_store, write_atomically
from bimrobot.core.tasks import Task

if TYPE_CHECKING:  # pragma: no cover
    from bimrobot.bim.model import BuildingModel
    from bimrobot.sco.build import SmartModel

log = logging.getLogger(__name__)


@functools.lru_cache(maxsize=None)
def _term(namespace: str, name: str) -> URIRef:
    return URIRef(namespace + name)


@functools.lru_cache(maxsize=1 << 16)
def _quoted(identifier: str) -> str:
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


def _state_name(state: Any, allowed: tuple[str, ...], what: str) -> str:
    name = getattr(state, "value", state)
    if name not in allowed:
        raise InputError(f"unknown {what} state {name!r}: use one of {', '.join(allowed)}")
    return name


@functools.lru_cache(maxsize=1 << 16, typed=True)  # typed: True and 1 are different literals
def _literal(value: Any) -> Literal:
    if isinstance(value, bool):
        return Literal(value)
    if isinstance(value, float):
        # Nanometre / nanosecond precision: drops float noise (3.8200000000000007).
        return Literal(round(value, 9), datatype=XSD.double)
    return Literal(value)


class ConstructionGraph:
    """A construction graph in a triple store, with the live-state updates and queries the system uses.

    Build one with :func:`build_graph`, or reopen a saved one with :meth:`open`.
    """

    def __init__(self, store: TripleStore, base: str = DEFAULT_BASE):
        self.store = store
        self.base = checked_base(base)
        self._parts: dict[URIRef, list[URIRef]] | None = None

    # ------------------------------------------------------------------------------------ IRIs
    def iri(self, kind: str, identifier: str) -> URIRef:
        """IRI of a thing of ``kind`` (element, storey, activity, robot, interface, ...) from its id."""
        return URIRef(f"{self.base}{kind}/{_quoted(identifier)}")

    def element_iri(self, global_id: str) -> URIRef:
        return self.iri("element", global_id)

    def activity_iri(self, activity_id: str) -> URIRef:
        return self.iri("activity", activity_id)

    def interface_iri(self, node_id: str) -> URIRef:
        return self.iri("interface", node_id)

    @staticmethod
    def id_of(iri: str) -> str:
        """The id an IRI was built from (inverse of :meth:`iri`)."""
        return unquote(str(iri).rsplit("/", 1)[-1])

    # ------------------------------------------------------------------------------ live state
    def set_component_state(self, global_id: str, state: Any) -> None:
        """Record the construction state (``OnYard`` ... ``Assembled``) of an element or connection node.

        ``global_id`` is an element GlobalId or a node id ``<relating>:<related>``; ``state`` a state
        name or a ``bimrobot.sco.states.State``. Raises :class:`InputError` for an unknown id or state.
        """
        name = _state_name(state, COMPONENT_STATES, "component")
        subject = self._stateful(global_id)
        self.store.replace(subject, DICE.hasEntityState, BRC[name])
        for part in self._sub_elements().get(subject, ()):
            self.store.replace(part, DICE.hasEntityState, BRC[name])  # an assembly's parts move with it

    def _sub_elements(self) -> dict[URIRef, list[URIRef]]:
        """Assembly IRI -> its parts' IRIs (bot:hasSubElement), read once: the topology does not change."""
        if self._parts is None:
            self._parts = {}
            for row in self.store.select(f"SELECT ?whole ?part WHERE {{ ?whole <{BOT.hasSubElement}> ?part }}"):
                self._parts.setdefault(URIRef(row["whole"]), []).append(URIRef(row["part"]))
        return self._parts

    def set_activity_state(self, activity_id: str, state: Any) -> None:
        """Record the execution state (NotStarted, Started, Completed, Failed) of an activity."""
        name = _state_name(state, ACTIVITY_STATES, "activity")
        subject = self.activity_iri(activity_id)
        if self.store.value(subject, RDF.type) is None:
            raise InputError(f"no activity {activity_id!r} in the graph")
        self.store.replace(subject, DICE.hasEntityState, BRC[name])

    def component_state(self, global_id: str) -> str | None:
        """The current state name of an element or connection node (None for a node not yet opened)."""
        value = self.store.value(self._stateful(global_id), DICE.hasEntityState)
        return None if value is None else str(value).split("#")[-1]

    def activity_state(self, activity_id: str) -> str:
        """The current state name of an activity."""
        subject = self.activity_iri(activity_id)
        value = self.store.value(subject, DICE.hasEntityState)
        if value is None:
            raise InputError(f"no activity {activity_id!r} in the graph")
        return str(value).split("#")[-1]

    def _stateful(self, global_id: str) -> URIRef:
        for subject in (self.element_iri(global_id), self.interface_iri(global_id)):
            if self.store.value(subject, RDF.type) is not None:
                return subject
        raise InputError(f"no element or connection node {global_id!r} in the graph")

    # ---------------------------------------------------------------------------------- queries
    def fleet_data(self) -> dict | None:
        """The fleet file's keys of the fleet the graph's run used (``brc:fleetDescription``), or None."""
        rows = self.store.select(f"SELECT ?d WHERE {{ ?site <{BRC.fleetDescription}> ?d }} LIMIT 1")
        return json.loads(str(rows[0]["d"])) if rows else None

    def run_site(self):
        """The site the graph's run used, with the building placed on it (:class:`bimrobot.site.site.Site`), or
        None when the graph does not hold one (``brc:siteDescription``)."""
        from bimrobot.site.site import site_from_dict

        rows = self.store.select(f"SELECT ?d WHERE {{ ?site <{BRC.siteDescription}> ?d }} LIMIT 1")
        return site_from_dict(json.loads(str(rows[0]["d"])), "the construction graph's site") if rows else None

    def query(self, query: str, **bindings: Any) -> list[dict[str, Any]]:
        """Run a SPARQL SELECT/ASK: a query name from ``lbd/queries`` (e.g. ``"ready_activities"``), a
        ``.rq`` path, or SPARQL text. ``bindings`` fix variables (``globalId="2O2Fr$t4X7Zf8NOew3FLOH"``).

        Returns one dict per solution, variable -> Python value (IRIs as str); ASK gives ``[{"ask": bool}]``.
        """
        text = bind_values(load_query(query), bindings)
        try:
            return self.store.select(text)
        except (SyntaxError, ValueError, ParseException) as exc:
            shown = query if len(query) < 80 else query[:77] + "..."
            raise InputError(f"the SPARQL query {shown} is invalid: {exc}".splitlines()[0]) from None

    # ------------------------------------------------------------------------------ in and out
    def serialize(self, path: str | os.PathLike, format: str | None = None, inputs: Iterable = (),
                  option: str = "-o") -> Path:
        """Write the graph as Turtle or JSON-LD (``format`` "turtle"/"json-ld", else from the suffix),
        under the output policy of :mod:`bimrobot.core.io`: ``inputs`` are the files it was built from,
        ``option`` how the user named ``path`` (for messages). The file is signed (a ``#`` comment in
        Turtle, a ``"generator"`` key in JSON-LD) so that a later run may replace it."""
        kinds = {kind: f"{self.base}{kind}/" for kind in ("site", "building", "storey", "element", "interface", "activity", "robot")}
        return write_atomically(self.store, path, format_for(path, format), {**PREFIXES, **kinds},
                                io.signature("construction graph"), inputs=inputs, option=option)

    @classmethod
    def open(cls, path: str | os.PathLike, base: str | None = None) -> "ConstructionGraph":
        """Reopen a graph: a Turtle/JSON-LD file (into memory), an Oxigraph store directory or a
        SPARQL endpoint URL. The base IRI is read from the graph's bot:Site unless given."""
        store = load_store(path)
        if base is None:
            sites = store.select(f"SELECT ?site WHERE {{ ?site a <{BOT.Site}> }} LIMIT 1")
            site = sites[0]["site"] if sites else ""
            base = site[: -len("site/site")] if site.endswith("site/site") else DEFAULT_BASE
        return cls(store, base)

    def __len__(self) -> int:
        return len(self.store)

    def close(self) -> None:
        self.store.close()

    def __enter__(self) -> "ConstructionGraph":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def checked_base(base: str) -> str:
    """``base`` as an absolute IRI ending in ``/`` or ``#`` (a ``/`` is added), else InputError."""
    if not re.match(r"^[A-Za-z][A-Za-z0-9+.-]*:\S+$", base) or any(c in base for c in '<>"{}|^`\\ '):
        raise InputError(f"the base IRI {base!r} is not an absolute IRI such as {DEFAULT_BASE}")
    return base if base.endswith(("/", "#")) else base + "/"


def vocabulary_triples() -> list[Triple]:
    """The ``brc:`` vocabulary (state individuals with their labels, term definitions), so that a
    saved graph describes its own terms and queries can return state names."""
    vocabulary = rdflib.Graph()
    vocabulary.parse(VOCABULARY_FILE, format="turtle")
    return list(vocabulary)


def load_query(query: str) -> str:
    """SPARQL text for a query name in ``lbd/queries``, a path to a ``.rq`` file, or the text itself."""
    named = QUERY_DIR / f"{query}.rq"
    if "\n" not in query and named.is_file():
        return named.read_text(encoding="utf-8")
    if query.endswith(".rq"):
        path = Path(query)
        if not path.is_file():
            raise InputError(f"the query file {path} does not exist")
        return path.read_text(encoding="utf-8")
    if not any(word in query.upper() for word in ("SELECT", "ASK", "CONSTRUCT", "DESCRIBE")):
        raise InputError(f"unknown query {query!r}: use one of {', '.join(query_names())}, a .rq file or SPARQL text")
    return query


def bind_values(sparql: str, bindings: dict[str, Any]) -> str:
    """``sparql`` with ``VALUES ?name { value }`` opening its first (outermost) WHERE block.

    Works the same on rdflib, Oxigraph and remote endpoints, and inside aggregates; values are
    written with rdflib's escaping (strings as literals, rdflib terms as they are).
    """
    if not bindings:
        return sparql
    match = re.search(r"WHERE\s*\{", sparql, flags=re.IGNORECASE)
    if match is None:
        raise InputError("a query with bound variables needs a WHERE { ... } block")
    values = "".join(
        f" VALUES ?{name} {{ {(value if isinstance(value, rdflib.term.Node) else _literal(value)).n3()} }}"
        for name, value in bindings.items()
    )
    return sparql[: match.end()] + values + sparql[match.end() :]


def query_names() -> list[str]:
    """Names of the queries shipped in ``lbd/queries``."""
    return sorted(p.stem for p in QUERY_DIR.glob("*.rq"))


# ------------------------------------------------------------------------------------- building


def build_graph(
    model: BuildingModel,
    schedule: Schedule | None = None,
    store: str = "memory",
    path: str | os.PathLike | None = None,
    base: str = DEFAULT_BASE,
    properties: bool = True,
    assemblies: bool = True,
    smart: SmartModel | None = None,
    pick_up: dict[str, tuple[float, float, float]] | None = None,
    site=None,
    fleet=None,
) -> ConstructionGraph:
    """The construction graph of ``model`` and, when given, its ``schedule``.

    ``store``: ``"memory"`` (rdflib, default), ``"oxigraph"`` (persistent, in the empty or new
    directory ``path``) or ``"sparql"`` (the default graph of the SPARQL 1.1 endpoint at URL ``path``,
    e.g. ``http://127.0.0.1:7878`` for ``oxigraph serve``). Every element starts ``OnYard`` and every activity ``NotStarted``. A schedule
    row whose GlobalId is not an element (or assembly) of the model raises :class:`InputError`.
    ``properties``: also write every property-set value (``props:<Pset>.<Name>``). ``assemblies``:
    write the model's assemblies with their parts as sub-elements (default).
    ``smart``: the smart construction objects the simulation uses (:func:`bimrobot.sco.build_smart_model`
    of the same model, with ``by_element=not assemblies``): its joints and connection nodes (from IFC
    relations or inferred from geometry, with provenance, assembly points and method) go into the graph,
    and its prebuilt components start in their own state (PositionFixed, Assembled) instead of OnYard.
    ``pick_up``: GlobalId -> where the component waits on the yard (m, world; see
    :func:`bimrobot.bim.components.pick_up_positions`), written as ``brc:pickUpPosition`` of the
    components that start OnYard. ``site``: the run's site with the building placed on it
    (:func:`bimrobot.site.site.site_for`), written as ``brc:modelOffsetX/Y`` (model -> site translation, m) and
    ``brc:siteDescription`` (the site file's keys as JSON) of the ``bot:Site``, so that RCAN run from the
    graph alone has the robot homes and the placement `simulate` had. ``fleet``: the run's fleet
    (:class:`bimrobot.site.fleet.Fleet`): each robot a ``dice:Device`` with its kind and the tasks
    it does (``brc:robotKind``, ``brc:performs``), the whole as ``brc:fleetDescription`` (the fleet file's
    keys as JSON), so that `rcan run --graph` needs no ``--capabilities``.

    The triples go to the store in one stream (one bulk load on Oxigraph); a progress bar on stderr
    counts the elements, joints and activities written when the work is long (see :mod:`.progress`).
    """
    from bimrobot.sco.build import gc_paused

    graph = ConstructionGraph(open_store(store, path), base)
    writer = _GraphWriter(graph, model, properties, assemblies, smart, pick_up, site, fleet)
    # The cyclic garbage collector's full passes over every live term made the time grow faster than
    # the graph (bench/graph.py); millions of short-lived terms, no cycles: pause it meanwhile.
    with progress_bar(writer.items(schedule), "graph", unit=" items") as bar, gc_paused():
        writer.bar = bar
        graph.store.add_all(itertools.chain(
            vocabulary_triples(), writer.topology(), writer.processes(schedule) if schedule is not None else ()))
    return graph


def _provenance(joint) -> str:
    return FROM_GEOMETRY if joint.inferred else FROM_IFC_RELATION


class _GraphWriter:
    """Yields the triples of one model (and schedule), in the order of fig. 5.5."""

    def __init__(self, graph: ConstructionGraph, model: BuildingModel, properties: bool = True, assemblies: bool = True,
                 smart: SmartModel | None = None, pick_up: dict[str, tuple[float, float, float]] | None = None,
                 site=None, fleet=None):
        self.graph, self.model, self.properties, self.smart = graph, model, properties, smart
        self.run_site, self.fleet = site, fleet
        self.pick_up = pick_up or {}
        self.assemblies = dict(getattr(model, "assemblies", {})) if assemblies else {}
        self.site = graph.iri("site", "site")
        self.storeys = {s.global_id for s in model.storeys}
        self.building = graph.iri("building", "building")
        self.start_states = self._start_states()
        self.interfaces = {f"{c.relating_id}:{c.related_id}" for c in model.connections}
        if smart is not None:
            self.interfaces.update(smart.nodes)
        self.bar = None  # a progress bar, advanced by one per element, assembly, connection, joint, activity

    def items(self, schedule: Schedule | None) -> int:
        """How many items (elements, assemblies, connections, joints, activities) the graph describes."""
        count = len(self.model.elements) + len(self.assemblies) + len(self.model.connections)
        if self.smart is not None:
            count += len(self.smart.joints)
        if schedule is not None:
            count += len(schedule.activities) + len(schedule.phases)
        return count

    def _tick(self) -> None:
        if self.bar is not None:
            self.bar.update(1)

    def _start_states(self) -> dict[str, str]:
        """GlobalId -> the state a prebuilt component (and each part of a prebuilt assembly) starts in."""
        states: dict[str, str] = {}
        if self.smart is None:
            return states
        for component in self.smart.components.values():
            if component.prebuilt:
                for gid in (component.id, *component.part_ids):
                    states[gid] = str(component.state)
        return states

    def topology(self) -> Iterator[Triple]:
        g, model = self.graph, self.model
        yield self.site, RDF.type, BOT.Site
        yield self.site, RDFS.label, Literal(model.site_name or "site")
        yield self.site, BOT.hasBuilding, self.building
        if self.run_site is not None and self.run_site.model_offset is not None:
            from bimrobot.site.site import site_to_dict

            yield self.site, BRC.modelOffsetX, _literal(float(self.run_site.model_offset[0]))
            yield self.site, BRC.modelOffsetY, _literal(float(self.run_site.model_offset[1]))
            yield self.site, BRC.siteDescription, Literal(json.dumps(site_to_dict(self.run_site)))
        if self.fleet is not None:
            yield from self.fleet_triples()
        yield self.building, RDF.type, BOT.Building
        yield self.building, RDFS.label, Literal(model.project_name or "building")
        for storey in model.storeys:
            iri = g.iri("storey", storey.global_id)
            yield self.building, BOT.hasStorey, iri
            yield iri, RDF.type, BOT.Storey
            yield iri, BRC.globalId, Literal(storey.global_id)
            yield iri, RDFS.label, Literal(storey.name)
            yield iri, BRC.elevation, _literal(float(storey.elevation))
        storeys = {s.global_id for s in model.storeys}
        for element in model.elements.values():
            yield from self.element(element, storeys)
            self._tick()
        for assembly in self.assemblies.values():
            yield from self.assembly(assembly, storeys)
            self._tick()
        for connection in model.connections:
            yield from self.interface(connection)
            self._tick()
        if self.smart is not None:
            for joint in self.smart.joints.values():
                yield from self.joint(joint)
                self._tick()

    def element(self, element, storeys: set[str]) -> Iterator[Triple]:
        iri = self.graph.element_iri(element.global_id)
        zone = self.graph.iri("storey", element.storey_id) if element.storey_id in storeys else self.building
        yield zone, BOT.containsElement, iri
        yield iri, RDF.type, BOT.Element
        yield iri, BRC.globalId, Literal(element.global_id)
        yield iri, BRC.ifcClass, Literal(element.ifc_class)
        if element.name:
            yield iri, RDFS.label, Literal(element.name)
        if element.weight_kg is not None:
            yield iri, BRC.weightKg, _literal(float(element.weight_kg))
            yield iri, BRC.weightSource, Literal(getattr(element.weight_source, "value", str(element.weight_source)))
        if element.material:
            yield iri, BRC.material, Literal(element.material)
        yield from _position(URIRef(f"{iri}/position"), iri, DICE.hasQuality, element.position)
        if len(element.vertices):
            lengths = element.local_bounds[1] - element.local_bounds[0]
            size = URIRef(f"{iri}/size")
            yield iri, DICE.hasQuality, size
            yield size, RDF.type, DICE.CartesianVolume
            for prop, length in zip((DICE.hasXLength, DICE.hasYLength, DICE.hasZLength), lengths):
                yield size, prop, _literal(float(length))
        if self.properties:
            yield from _property_values(iri, element.properties)
        yield from self.state(iri, element.global_id)

    def assembly(self, assembly, storeys: set[str]) -> Iterator[Triple]:
        """An assembly as a bot:Element with its parts as bot:hasSubElement (see the module docstring)."""
        g, model, gid = self.graph, self.model, assembly.global_id
        iri = g.element_iri(gid)
        storey = components.storey_id(model, gid)
        yield (g.iri("storey", storey) if storey in storeys else self.building), BOT.containsElement, iri
        yield iri, RDF.type, BOT.Element
        yield iri, BRC.globalId, Literal(gid)
        yield iri, BRC.ifcClass, Literal("IfcElementAssembly")
        if assembly.name:
            yield iri, RDFS.label, Literal(assembly.name)
        for part in assembly.part_ids:
            if part in model.elements:
                yield iri, BOT.hasSubElement, g.element_iri(part)
        weight = components.weight_kg(model, gid)
        if weight is not None:
            yield iri, BRC.weightKg, _literal(weight)
            yield iri, BRC.weightSource, Literal("sum of its parts")
        yield from _position(URIRef(f"{iri}/position"), iri, DICE.hasQuality, components.position(model, gid))
        size = components.extents(model, gid)
        if size is not None:
            volume = URIRef(f"{iri}/size")
            yield iri, DICE.hasQuality, volume
            yield volume, RDF.type, DICE.CartesianVolume
            for prop, length in zip((DICE.hasXLength, DICE.hasYLength, DICE.hasZLength), size):
                yield volume, prop, _literal(float(length))
        yield from self.state(iri, gid)

    def state(self, iri: URIRef, gid: str) -> Iterator[Triple]:
        """The component's starting state and, when it waits on the yard, its pick-up position."""
        state = self.start_states.get(gid, "OnYard")
        yield iri, DICE.hasEntityState, BRC[state]
        if state == "OnYard" and gid in self.pick_up:
            yield from _position(URIRef(f"{iri}/pick-up"), iri, BRC.pickUpPosition, self.pick_up[gid])

    def interface(self, connection) -> Iterator[Triple]:
        g = self.graph
        node_id = f"{connection.relating_id}:{connection.related_id}"
        iri = g.interface_iri(node_id)
        relating, related = g.element_iri(connection.relating_id), g.element_iri(connection.related_id)
        yield iri, RDF.type, BOT.Interface
        yield iri, BRC.nodeId, Literal(node_id)
        yield iri, BOT.interfaceOf, relating
        yield iri, BOT.interfaceOf, related
        yield iri, BRC.relatingElement, relating
        yield iri, BRC.relatedElement, related
        if connection.global_id:
            yield iri, BRC.globalId, Literal(connection.global_id)
        if connection.connection_type:
            yield iri, BRC.connectionType, Literal(connection.connection_type)
        yield iri, BRC.inferred, Literal(bool(connection.inferred))
        for realizing in connection.realizing_ids:
            yield iri, BRC.realizingElement, g.element_iri(realizing)

    def joint(self, joint) -> Iterator[Triple]:
        """A joint of the simulation (:class:`bimrobot.sco.component.Joint`) and its connection nodes.

        The joint is a ``bot:Interface`` (and ``brc:Joint``) of its components and connectors, with its
        provenance, realizing elements, total assembly points and where the robot works (m, world).
        Each node is a ``bot:Interface`` (and ``brc:ConnectionNode``) of its component and its
        connector, with its own points and method; a prebuilt component's nodes carry their state.
        """
        g, smart = self.graph, self.smart
        iri = g.iri("joint", joint.id)
        provenance = Literal(_provenance(joint))
        nodes = [smart.nodes[n] for n in joint.node_ids]
        yield iri, RDF.type, BOT.Interface
        yield iri, RDF.type, BRC.Joint
        yield iri, BRC.jointId, Literal(joint.id)
        yield iri, BRC.provenance, provenance
        for gid in (*joint.component_ids, *joint.connector_ids):
            yield iri, BOT.interfaceOf, g.element_iri(gid)
        for realizing in joint.realizing_ids:
            yield iri, BRC.realizingElement, g.element_iri(realizing)
        yield iri, BRC.assemblyPoints, Literal(sum(n.assembly_point_number for n in nodes))
        yield iri, BRC.assemblyMethod, Literal(",".join(sorted({n.assembly_method for n in nodes})))
        yield from _position(URIRef(f"{iri}/position"), iri, BRC.assemblyPosition, joint.position)
        for node in nodes:
            node_iri = g.interface_iri(node.id)
            yield iri, BRC.hasNode, node_iri
            yield node_iri, RDF.type, BOT.Interface
            yield node_iri, RDF.type, BRC.ConnectionNode
            yield node_iri, BRC.nodeId, Literal(node.id)
            yield node_iri, BRC.partOfJoint, iri
            yield node_iri, BRC.provenance, provenance
            yield node_iri, BOT.interfaceOf, g.element_iri(node.component_id)
            for connector in node.connector_ids:
                yield node_iri, BOT.interfaceOf, g.element_iri(connector)
            yield node_iri, BRC.assemblyPoints, Literal(int(node.assembly_point_number))
            yield node_iri, BRC.assemblyMethod, Literal(node.assembly_method)
            if smart.components[node.component_id].prebuilt:
                yield node_iri, DICE.hasEntityState, BRC[str(node.state)]

    def processes(self, schedule: Schedule) -> Iterator[Triple]:
        interfaces = self.interfaces
        robots: set[str] = set()
        for phase in schedule.phases:
            yield from self.activity(phase, interfaces)
            self._tick()
        for activity in schedule.activities:
            yield from self.activity(activity, interfaces)
            self._tick()
            if activity.robot and activity.robot not in robots:
                robots.add(activity.robot)
                robot = self.graph.iri("robot", activity.robot)
                yield robot, RDF.type, DICE.Device
                yield robot, RDF.type, DICP.Resource
                yield robot, RDFS.label, Literal(activity.robot)

    def fleet_triples(self) -> Iterator[Triple]:
        """The fleet's robots, what each does, and the fleet file itself (``brc:fleetDescription``)."""
        from bimrobot.site.fleet import fleet_to_dict

        yield self.site, BRC.fleetDescription, Literal(json.dumps(fleet_to_dict(self.fleet)))
        for spec in self.fleet.robots:
            robot = self.graph.iri("robot", spec.name)
            yield robot, RDF.type, DICE.Device
            yield robot, RDFS.label, Literal(spec.name)
            yield robot, BRC.robotKind, Literal(spec.kind)
            for task in spec.activities:
                yield robot, BRC.performs, Literal(str(task))

    def activity(self, activity: Activity, interfaces: set[str]) -> Iterator[Triple]:
        g = self.graph
        iri = g.activity_iri(activity.id)
        yield iri, RDF.type, DICP.Activity
        yield iri, BRC.identification, Literal(activity.id)
        yield iri, RDFS.label, Literal(activity.name)
        if activity.activity:
            yield iri, BRC.activityType, Literal(activity.activity)
        if activity.predefined_type:
            yield iri, BRC.taskType, Literal(activity.predefined_type)
        if activity.parent:
            yield g.activity_iri(activity.parent), DICP.hasSubActivity, iri
        for predecessor in activity.predecessors:
            yield iri, DICE.precededBy, g.activity_iri(predecessor)
        yield from self.interval(iri, activity)
        yield from self.objects(iri, activity, interfaces)
        if activity.robot:
            role = URIRef(f"{iri}/resource")
            robot = g.iri("robot", activity.robot)
            yield iri, DICP.hasAssignedResource, role
            yield role, RDF.type, DICP.ResourceRole
            yield role, DICE.isRoleOf, robot
            yield robot, DICE.hasRole, role
        if activity.target is not None:
            yield from _position(URIRef(f"{iri}/target"), iri, BRC.targetPosition, activity.target)
        if activity.work_from is not None:
            yield from _position(URIRef(f"{iri}/work"), iri, BRC.workPosition, activity.work_from)
        if activity.work_to is not None and activity.work_to != activity.work_from:
            yield from _position(URIRef(f"{iri}/work-end"), iri, BRC.workEndPosition, activity.work_to)
        if activity.nodes is not None:
            yield iri, BRC.nodeCount, Literal(int(activity.nodes))
        if activity.points is not None:
            yield iri, BRC.pointCount, Literal(int(activity.points))
        if activity.storey:
            if activity.storey not in self.storeys:
                raise InputError(f"schedule activity {activity.id}: Storey {activity.storey!r} is not a storey of {self.model.source or 'the model'}")
            yield iri, BRC.onStorey, g.iri("storey", activity.storey)
        yield iri, DICE.hasEntityState, BRC.NotStarted

    def interval(self, iri: URIRef, activity: Activity) -> Iterator[Triple]:
        interval, start, end = URIRef(f"{iri}/interval"), URIRef(f"{iri}/start"), URIRef(f"{iri}/end")
        yield iri, DICP.occupiesTimeInterval, interval
        yield interval, RDF.type, DICE.TimeInterval
        yield interval, DICE.hasStart, start
        yield interval, DICE.hasEnd, end
        yield start, RDF.type, DICE.TimeInstant
        yield start, BRC.atSecond, _literal(float(activity.start))
        yield end, RDF.type, DICE.TimeInstant
        yield end, BRC.atSecond, _literal(float(activity.finish))

    def objects(self, iri: URIRef, activity: Activity, interfaces: set[str]) -> Iterator[Triple]:
        gid = activity.global_id
        if not gid:
            return
        if gid in self.model.elements or gid in self.assemblies:
            element = self.graph.element_iri(gid)
        elif any(s.global_id == gid for s in self.model.storeys):
            element = self.graph.iri("storey", gid)  # an IFC summary task that outputs a storey
        else:
            where = f" of {activity.id}" if activity.id else ""
            raise InputError(f"schedule activity{where}: GlobalId {gid!r} is not an element of {self.model.source or 'the model'}")
        yield iri, DICP.hasObject, element
        if activity.activity == Task.ASSEMBLE:
            yield iri, DICP.hasOutputObject, element
        if activity.node_id and activity.node_id in interfaces:
            yield iri, DICP.hasObject, self.graph.interface_iri(activity.node_id)


def property_iri(key: str) -> URIRef:
    """``"Pset_ColumnCommon/Reference"`` -> ``props:Pset_ColumnCommon.Reference`` (other characters
    than letters, digits, ``_``, ``-`` percent-encoded)."""
    pset, _, name = key.rpartition("/")
    local = f"{pset}.{name}" if pset else name
    return PROPS[quote(local, safe="_-.")]


def _property_values(iri: URIRef, properties: dict) -> Iterator[Triple]:
    for key, value in properties.items():
        if isinstance(value, (bool, int, float, str)) and value != "":
            yield iri, property_iri(str(key)), _literal(value)


def _position(iri: URIRef, owner: URIRef, link: URIRef, xyz: Iterable[float]) -> Iterator[Triple]:
    x, y, z = (float(v) for v in xyz)
    yield owner, link, iri
    yield iri, RDF.type, DICE.CartesianPosition
    yield iri, DICE.hasX, _literal(x)
    yield iri, DICE.hasY, _literal(y)
    yield iri, DICE.hasZ, _literal(z)
