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

import itertools
import json
import logging
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable
from urllib.parse import unquote

import rdflib
from pyparsing import ParseException
from rdflib import RDF, URIRef

from bimrobot.core import io
from bimrobot.core.errors import InputError
from bimrobot.core.progress import progress_bar
from bimrobot.lbd.graph_writer import GraphWriter
from bimrobot.lbd.store import TripleStore, format_for, load_store, open_store, write_atomically
from bimrobot.lbd.terms import (
    ACTIVITY_STATES,
    BOT,
    BRC,
    COMPONENT_STATES,
    DEFAULT_BASE,
    DICE,
    PREFIXES,
    QUERY_DIR,
    VOCABULARY_FILE,
    Triple,
    literal,
    quoted,
    state_name,
)
from bimrobot.schedule.schedule import Schedule


if TYPE_CHECKING:  # pragma: no cover
    from bimrobot.bim.model import BuildingModel
    from bimrobot.sco.build import SmartModel

log = logging.getLogger(__name__)


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
        return URIRef(f"{self.base}{kind}/{quoted(identifier)}")

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
        name = state_name(state, COMPONENT_STATES, "component")
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
        name = state_name(state, ACTIVITY_STATES, "activity")
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
        f" VALUES ?{name} {{ {(value if isinstance(value, rdflib.term.Node) else literal(value)).n3()} }}"
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
    writer = GraphWriter(graph, model, properties, assemblies, smart, pick_up, site, fleet)
    # The cyclic garbage collector's full passes over every live term made the time grow faster than
    # the graph (bench/graph.py); millions of short-lived terms, no cycles: pause it meanwhile.
    with progress_bar(writer.items(schedule), "graph", unit=" items") as bar, gc_paused():
        writer.bar = bar
        graph.store.add_all(itertools.chain(
            vocabulary_triples(), writer.topology(), writer.processes(schedule) if schedule is not None else ()))
    return graph


