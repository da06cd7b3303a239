"""Triple stores behind the construction graph: in-memory rdflib (default) or on-disk Oxigraph.

Both offer the same small interface (add, replace one property, SPARQL SELECT/ASK with bound
variables, serialize), and both answer the project's queries identically (tested). A graph held by a
remote SPARQL 1.1 endpoint (Fuseki, GraphDB, ``oxigraph serve``) is reached through rdflib's
``SPARQLUpdateStore`` (:class:`SparqlEndpointStore`), for graphs shared beyond one machine.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Iterable, Protocol

import rdflib
from rdflib.term import Node

from bimrobot.core.errors import InputError
from bimrobot.core.io import atomic_output_file

Triple = tuple[rdflib.URIRef, rdflib.URIRef, Node]
_XSD_STRING = str(rdflib.XSD.string)

#: Serialization formats: the user's name -> (rdflib format, file suffix).
FORMATS = {"turtle": ("turtle", ".ttl"), "json-ld": ("json-ld", ".jsonld"), "ntriples": ("nt", ".nt")}
SUFFIX_FORMATS = {".ttl": "turtle", ".jsonld": "json-ld", ".json": "json-ld", ".nt": "ntriples"}


def format_for(path: str | os.PathLike, format: str | None = None) -> str:
    """The serialization format named by ``format`` or guessed from the file suffix."""
    if format is None:
        suffix = Path(path).suffix.lower()
        if suffix not in SUFFIX_FORMATS:
            raise InputError(f"cannot tell the RDF format of {path} from its suffix: use .ttl, .jsonld or .nt")
        return SUFFIX_FORMATS[suffix]
    if format not in FORMATS:
        raise InputError(f"unknown RDF format {format!r}: use one of {', '.join(FORMATS)}")
    return format


def python_value(term: Node | None) -> Any:
    """An rdflib term as a plain Python value: IRIs as str, literals as int/float/bool/str."""
    if term is None:
        return None
    if isinstance(term, rdflib.Literal):
        value = term.toPython()
        return value if isinstance(value, (int, float, bool, str)) else str(term)
    return str(term)


def _exact_turtle_serializer():
    """rdflib's Turtle serializer, except that xsd:double literals keep their full lexical form.

    rdflib writes doubles in its shorthand as ``f"{value:e}"`` (7 significant digits), which would
    turn 123.4567891 m into 1.234568e+02; ``"123.4567891"^^xsd:double`` is exact.
    """
    from rdflib.plugins.serializers.turtle import _GEN_QNAME_FOR_DT, TurtleSerializer

    class ExactTurtleSerializer(TurtleSerializer):
        def label(self, node, position):
            if isinstance(node, rdflib.Literal) and node.datatype == rdflib.XSD.double:
                return node._literal_n3(use_plain=False, qname_callback=lambda dt: self.get_pname(dt, _GEN_QNAME_FOR_DT))
            return super().label(node, position)

    return ExactTurtleSerializer


class TripleStore(Protocol):
    """What the construction graph needs from a store."""

    def add_all(self, triples: Iterable[Triple]) -> None: ...

    def replace(self, subject: rdflib.URIRef, predicate: rdflib.URIRef, value: Node) -> None: ...

    def value(self, subject: rdflib.URIRef, predicate: rdflib.URIRef) -> Node | None: ...

    def select(self, sparql: str) -> list[dict[str, Any]]: ...

    def serialize(self, path: Path, format: str, prefixes: dict[str, str], signature: str | None = None) -> None: ...

    def __len__(self) -> int: ...

    def close(self) -> None: ...


class RdflibStore:
    """An ``rdflib.Graph`` (in memory by default; any rdflib store plugin works)."""

    def __init__(self, graph: rdflib.Graph | None = None):
        self.graph = graph if graph is not None else rdflib.Graph()

    def add_all(self, triples: Iterable[Triple]) -> None:
        self.graph.addN((s, p, o, self.graph) for s, p, o in triples)

    def replace(self, subject, predicate, value) -> None:
        self.graph.set((subject, predicate, value))

    def value(self, subject, predicate):
        return self.graph.value(subject, predicate)

    def select(self, sparql: str) -> list[dict[str, Any]]:
        result = self.graph.query(sparql)
        if result.type == "ASK":
            return [{"ask": bool(result.askAnswer)}]
        names = [str(v) for v in result.vars]
        return [{name: python_value(row[i]) for i, name in enumerate(names)} for row in result]

    def serialize(self, path: Path, format: str, prefixes: dict[str, str], signature: str | None = None) -> None:
        """Write the graph to ``path``; ``signature`` (e.g. ``io.signature(...)``) goes in as a first
        ``#`` comment line (Turtle, N-Triples) or a top-level ``"generator"`` key that the JSON-LD
        context maps to null, so it is no triple and every JSON-LD processor ignores it."""
        for prefix, namespace in prefixes.items():
            self.graph.bind(prefix, namespace, override=True)
        if format == "json-ld":
            text = self.graph.serialize(format="json-ld", context=dict(prefixes), auto_compact=True)
            with open(path, "w", encoding="utf-8") as handle:
                json.dump(_signed_json_ld(json.loads(text), prefixes, signature), handle, indent=2, ensure_ascii=False)
            return
        if len(self.graph) > FAST_WRITE_TRIPLES and _fast_writer_available():
            fast = OxigraphStore(None)
            fast.add_all(self.graph)
            fast.serialize(path, format, prefixes, signature)
            return
        with open(path, "wb") as handle:
            if signature:
                handle.write(f"# {signature}\n".encode("utf-8"))
            if format == "turtle":
                _exact_turtle_serializer()(self.graph).serialize(handle, encoding="utf-8")
            else:
                self.graph.serialize(destination=handle, format=FORMATS[format][0], encoding="utf-8")

    def __len__(self) -> int:
        return len(self.graph)

    def close(self) -> None:
        self.graph.close()


def _signed_json_ld(document: Any, prefixes: dict[str, str], signature: str | None) -> dict:
    """``{"@context": ..., "generator": signature, "@graph": [...]}`` from rdflib's compacted output."""
    if isinstance(document, list):
        document = {"@context": dict(prefixes), "@graph": document}
    elif "@graph" not in document:  # a single node, compacted to the top level
        context = document.pop("@context", dict(prefixes))
        document = {"@context": context, "@graph": [document] if document else []}
    if not signature:
        return document
    context = document.get("@context")
    context = {**context, "generator": None} if isinstance(context, dict) else [context, {"generator": None}]
    return {"@context": context, "generator": signature, "@graph": document["@graph"]}


#: Above this many triples Turtle and N-Triples are written by Oxigraph (when installed): rdflib's
#: Turtle writer groups and sorts in Python (measured: 380 s for 700k triples, Oxigraph 12 s), but
#: its output, grouped by subject, is easier to read, so smaller graphs keep it.
FAST_WRITE_TRIPLES = 50_000


def _fast_writer_available() -> bool:
    """Whether pyoxigraph (the ``oxigraph`` extra) is installed, to write Turtle and N-Triples fast."""
    import importlib.util

    return importlib.util.find_spec("pyoxigraph") is not None


class OxigraphStore:
    """A pyoxigraph ``Store`` (default graph only): persistent in a directory, or in memory when
    ``path`` is None (used to build and write large graphs fast)."""

    def __init__(self, path: str | os.PathLike | None):
        from bimrobot.core.errors import require_extra

        self.ox = require_extra("pyoxigraph", "oxigraph")
        self.path = Path(path) if path is not None else None
        self._named: dict[str, Any] = {}  # IRI -> pyoxigraph NamedNode, made once (predicates, classes, states repeat)
        try:
            self.store = self.ox.Store(str(self.path)) if self.path is not None else self.ox.Store()
        except OSError as exc:
            raise InputError(f"cannot open the Oxigraph store {self.path}: {exc}") from None

    # rdflib terms <-> pyoxigraph terms
    def _named_node(self, iri: str):
        node = self._named.get(iri)
        if node is None:
            node = self._named[iri] = self.ox.NamedNode(iri)
        return node

    def _term(self, term: Node):
        if type(term) is rdflib.URIRef:  # the common case first: most terms are IRIs, many repeated
            node = self._named.get(term)
            if node is None:
                node = self._named[term] = self.ox.NamedNode(term)
            return node
        if isinstance(term, rdflib.URIRef):
            return self._named_node(str(term))
        if isinstance(term, rdflib.Literal):
            if term.language:
                return self.ox.Literal(str(term), language=term.language)
            return self.ox.Literal(str(term), datatype=self._named_node(str(term.datatype or rdflib.XSD.string)))
        if isinstance(term, rdflib.BNode):
            return self.ox.BlankNode(str(term))
        raise TypeError(f"cannot store {term!r}")

    def _rdflib(self, term) -> Node | None:
        if term is None:
            return None
        if isinstance(term, self.ox.NamedNode):
            return rdflib.URIRef(term.value)
        if isinstance(term, self.ox.Literal):
            if term.language:
                return rdflib.Literal(term.value, lang=term.language)
            if term.datatype.value == _XSD_STRING:  # RDF 1.1: the same as a plain literal, which rdflib keeps apart
                return rdflib.Literal(term.value)
            return rdflib.Literal(term.value, datatype=rdflib.URIRef(term.datatype.value))
        return rdflib.BNode(term.value)

    def add_all(self, triples: Iterable[Triple]) -> None:
        """Add many triples in one bulk load (Oxigraph writes them straight to new files, without a
        transaction: meant for building a graph, not for updates others read at the same time)."""
        quad, term = self.ox.Quad, self._term
        self.store.bulk_extend(quad(term(s), term(p), term(o)) for s, p, o in triples)
        self._named.clear()

    def replace(self, subject, predicate, value) -> None:
        s, p = self._term(subject), self._term(predicate)
        for old in list(self.store.quads_for_pattern(s, p, None, self.ox.DefaultGraph())):
            self.store.remove(old)
        self.store.add(self.ox.Quad(s, p, self._term(value)))

    def value(self, subject, predicate):
        for quad in self.store.quads_for_pattern(self._term(subject), self._term(predicate), None, self.ox.DefaultGraph()):
            return self._rdflib(quad.object)
        return None

    def select(self, sparql: str) -> list[dict[str, Any]]:
        result = self.store.query(sparql)
        if isinstance(result, self.ox.QueryBoolean):
            return [{"ask": bool(result)}]
        names = [v.value for v in result.variables]
        return [{name: python_value(self._rdflib(solution[name])) for name in names} for solution in result]

    def serialize(self, path: Path, format: str, prefixes: dict[str, str], signature: str | None = None) -> None:
        """Turtle and N-Triples with Oxigraph's own writer (fast; doubles keep their exact lexical form),
        JSON-LD through rdflib so that both stores write the same compacted, signed document."""
        if format in ("turtle", "ntriples") and len(self) > FAST_WRITE_TRIPLES:
            kind = self.ox.RdfFormat.TURTLE if format == "turtle" else self.ox.RdfFormat.N_TRIPLES
            with open(path, "wb") as handle:
                if signature:
                    handle.write(f"# {signature}\n".encode("utf-8"))
                # Generated property names (props:) carry escapes rdflib's Turtle parser rejects: in full.
                short = {k: v for k, v in prefixes.items() if k != "props"} if format == "turtle" else None
                self.store.dump(handle, kind, from_graph=self.ox.DefaultGraph(), prefixes=short)
            return
        graph = rdflib.Graph()
        graph.addN(
            (self._rdflib(q.subject), self._rdflib(q.predicate), self._rdflib(q.object), graph)
            for q in self.store.quads_for_pattern(None, None, None, self.ox.DefaultGraph())
        )
        RdflibStore(graph).serialize(path, format, prefixes, signature)

    def __len__(self) -> int:
        return len(self.store)

    def close(self) -> None:
        if self.path is not None:
            self.store.flush()
        del self.store


class SparqlEndpointStore:
    """The default graph of a remote SPARQL 1.1 endpoint, spoken to with the SPARQL 1.1 protocol
    (rdflib's ``SPARQLConnector``): for graphs shared by several machines (Fuseki, GraphDB,
    ``oxigraph serve``). Every read and write is a query or update request, so other clients see
    state changes at once.

    ``url`` is the endpoint's base: queries go to ``<url>/query`` and updates to ``<url>/update``
    (Oxigraph's and Fuseki's layout); pass ``query_url``/``update_url`` for other servers.
    """

    BATCH = 5000  # triples per INSERT DATA request

    def __init__(self, url: str, query_url: str | None = None, update_url: str | None = None):
        from rdflib.plugins.stores.sparqlconnector import SPARQLConnector

        self.url = url.rstrip("/")
        self.connector = SPARQLConnector(
            query_endpoint=query_url or f"{self.url}/query",
            update_endpoint=update_url or f"{self.url}/update",
            returnFormat="json",
            method="POST_FORM",
        )

    def _query(self, sparql: str):
        try:
            return self.connector.query(sparql)
        except (OSError, ValueError) as exc:  # rdflib turns connection errors into ValueError
            raise InputError(f"the SPARQL endpoint {self.url} did not answer the query: {exc}") from None

    def _update(self, sparql: str) -> None:
        try:
            self.connector.update(sparql)
        except (OSError, ValueError) as exc:
            raise InputError(f"the SPARQL endpoint {self.url} did not take the update: {exc}") from None

    def add_all(self, triples: Iterable[Triple]) -> None:
        batch: list[str] = []
        for s, p, o in triples:
            batch.append(f"{s.n3()} {p.n3()} {o.n3()} .")
            if len(batch) == self.BATCH:
                self._update("INSERT DATA {\n" + "\n".join(batch) + "\n}")
                batch = []
        if batch:
            self._update("INSERT DATA {\n" + "\n".join(batch) + "\n}")

    def replace(self, subject, predicate, value) -> None:
        s, p = subject.n3(), predicate.n3()
        self._update(f"DELETE WHERE {{ {s} {p} ?old }} ;\nINSERT DATA {{ {s} {p} {value.n3()} . }}")

    def value(self, subject, predicate):
        for row in self._query(f"SELECT ?o WHERE {{ {subject.n3()} {predicate.n3()} ?o }} LIMIT 1"):
            return row[0]
        return None

    def select(self, sparql: str) -> list[dict[str, Any]]:
        result = self._query(sparql)
        if result.type == "ASK":
            return [{"ask": bool(result.askAnswer)}]
        names = [str(v) for v in result.vars]
        return [{name: python_value(row.get(rdflib.Variable(name))) for name in names} for row in result]

    def __len__(self) -> int:
        return int(self.select("SELECT (COUNT(*) AS ?n) WHERE { ?s ?p ?o }")[0]["n"])

    def serialize(self, path: Path, format: str, prefixes: dict[str, str], signature: str | None = None) -> None:
        local = rdflib.Graph()
        for row in self._query("SELECT ?s ?p ?o WHERE { ?s ?p ?o }"):
            local.add((row[0], row[1], row[2]))
        RdflibStore(local).serialize(path, format, prefixes, signature)

    def close(self) -> None:
        """Nothing to release: every request is its own HTTP exchange."""


def is_endpoint(location: str | os.PathLike) -> bool:
    """Whether ``location`` names a SPARQL endpoint (an http(s) URL) rather than a file or directory."""
    return str(location).startswith(("http://", "https://"))


def open_store(kind: str = "memory", path: str | os.PathLike | None = None) -> TripleStore:
    """A store to build a graph in: ``"memory"`` (rdflib), ``"oxigraph"`` (persistent, in the new or
    empty directory ``path``) or ``"sparql"`` (the remote endpoint at URL ``path``)."""
    if kind == "memory":
        return RdflibStore()
    if kind == "oxigraph-memory":  # an in-memory Oxigraph store: builds and writes large graphs fast
        return OxigraphStore(None)
    if kind == "sparql":
        if path is None or not is_endpoint(path):
            raise InputError(f"the sparql store needs the endpoint's http(s) URL, not {path!r}")
        return SparqlEndpointStore(str(path))
    if kind == "oxigraph":
        if path is None:
            raise InputError("the oxigraph store needs a directory: give --store-path (or path=)")
        if Path(path).exists() and (not Path(path).is_dir() or any(Path(path).iterdir())):
            raise InputError(f"the Oxigraph store directory {path} is not empty: give a new or empty folder")
        return OxigraphStore(path)
    raise InputError(f"unknown store {kind!r}: use 'memory', 'oxigraph' or 'sparql'")


def load_store(path: str | os.PathLike) -> TripleStore:
    """An existing graph: a SPARQL endpoint URL, an Oxigraph store directory, or a Turtle / JSON-LD /
    N-Triples file read into memory."""
    if is_endpoint(path):
        return SparqlEndpointStore(str(path))
    path = Path(path)
    if path.is_dir():
        if not (path / "CURRENT").is_file():  # RocksDB's marker: don't create a store in a random folder
            raise InputError(f"{path} is a directory but not an Oxigraph store")
        return OxigraphStore(path)
    if not path.is_file():
        raise InputError(f"the graph {path} does not exist")
    kind = format_for(path)
    if kind in ("turtle", "ntriples") and _fast_writer_available():
        # Oxigraph parses and queries large graphs many times faster than rdflib (same answers: tested).
        store = OxigraphStore(None)
        try:
            store.store.bulk_load(path=str(path), format=store.ox.RdfFormat.TURTLE if kind == "turtle" else store.ox.RdfFormat.N_TRIPLES)
        except (SyntaxError, ValueError, OSError) as exc:
            raise InputError(f"cannot parse the graph {path}: {exc}".splitlines()[0]) from None
        return store
    graph = rdflib.Graph()
    try:
        graph.parse(str(path), format=FORMATS[format_for(path)][0])
    except InputError:
        raise
    except Exception as exc:  # rdflib raises parser-specific exceptions
        raise InputError(f"cannot parse the graph {path}: {exc}".splitlines()[0]) from None
    return RdflibStore(graph)


def write_atomically(
    store: TripleStore,
    path: str | os.PathLike,
    format: str,
    prefixes: dict[str, str],
    signature: str,
    inputs: Iterable = (),
    option: str = "-o",
) -> Path:
    """Serialize ``store`` to ``path`` under the output policy (:mod:`bimrobot.core.io`): via a temporary
    file, so a failure leaves nothing half-written, and signed, so a later run may replace it.
    ``inputs``: the files the graph was built from (never overwritten)."""
    with atomic_output_file(path, inputs=inputs, option=option) as tmp:
        store.serialize(tmp, format, prefixes, signature)
    return Path(path)
