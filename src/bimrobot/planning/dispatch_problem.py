"""The problem the dispatching environment plans (issue 38) and its task graph: one build (smart model,
fleet, site) as :class:`DispatchProblem`, and the tasks the event simulation will publish with what waits
for what (:func:`task_graph`), keyed as the simulation's requests are (:func:`task_key`, :func:`request_key`).

Units: metres, seconds, kg; positions (x, y) in the site frame, heights z in the model frame (z up).
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bimrobot.site.fleet import Fleet, load_fleet
from bimrobot.site.site import Site
from bimrobot.coordination.simulation import ConstructionSimulation
from bimrobot.core.errors import BimrobotError, InputError
from bimrobot.sco.build import SmartModel
from bimrobot.sco.states import State
from bimrobot.core.tasks import Task

KINDS = ("transport", "position", "assemble", "gate")


@dataclass(frozen=True)
class DispatchProblem:
    """One build to plan: the smart model, the fleet, the site (placed on the building), the storey
    elevations (m), the task granularity (``per_node`` as ``simulate``'s default, else per joint) and
    breakdowns ((robot, time s[, repair s]) as ``simulate --breakdown``)."""

    smart: SmartModel
    fleet: Fleet
    site: Site | None = None
    storey_elevations: list[float] | None = None
    per_node: bool = True
    breakdowns: tuple = ()
    #: what the environments derive from the problem alone, once (:func:`problem_graph`: the task graph)
    derived: dict = field(default_factory=dict, init=False, repr=False, compare=False)


class PublishingSimulation(ConstructionSimulation):
    """The event simulation, keeping each published request by id (``published``): the dispatching
    environment finds a ready task's request without searching the request pools."""

    def start(self) -> None:
        self.published: dict = {}
        super().start()

    def request_for(self, *args, **kwargs):
        self._made = super().request_for(*args, **kwargs)
        return self._made

    def _publish(self, *args, **kwargs) -> None:
        super()._publish(*args, **kwargs)
        self.published[self._made.id] = self._made


def frame_problem(fleet: str = "fleet2", per_node: bool = True, size: tuple[int, int, int] = (2, 2, 1)) -> DispatchProblem:
    """A generated steel frame (no IFC file) of ``size`` = (columns along x, along y, storeys), built by
    ``fleet`` on its site; the default is the thesis' chapter-4 frame."""
    from bimrobot.coordination.generate import generated_frame
    from bimrobot.sco.build import build_smart_model
    from bimrobot.site.site import site_for

    model = generated_frame(*size)
    return DispatchProblem(build_smart_model(model), load_fleet(fleet), site_for(None, model.elements.values()),
                           [s.elevation for s in model.storeys], per_node)


def simulate_problem(argv: list[str]) -> DispatchProblem:
    """The problem that ``bimrobot simulate ARGV`` runs, read by simulate's own parser and readers
    (model, ``--fleet``, ``--site``, ``--prebuilt``, selection, ``--per-joint``, ``--breakdown``, ...).
    Give no ``-o``: nothing is written."""
    from bimrobot.coordination.inputs import prepare
    from bimrobot.coordination.options import simulate_parser

    with tempfile.TemporaryDirectory() as folder:
        args = simulate_parser().parse_args([*argv, "-o", str(Path(folder) / "unused")])
        if args.mode != "event":
            raise InputError("the dispatching environment runs the event simulation, not --mode thesis")
        _, elevations, fleet, site, _, smart_model = prepare(args, "simulate")
    return DispatchProblem(smart_model(), fleet, site, elevations, not args.per_joint, tuple(args.breakdown))


def task_key(activity: str, component: str, joint: str | None, node: str | None) -> str:
    """The graph node of a published request: ``transport:<component>``, ``position:<node or component>``,
    ``assemble:<node or joint>`` (per node or per joint)."""
    if activity == Task.ASSEMBLE:
        return f"assemble:{node or joint}"
    if activity == Task.POSITION:
        return f"position:{node or component}"
    return f"transport:{component}"


def request_key(sim, request) -> str:
    """The task graph's node (:func:`task_key`) of a request published in ``sim``, a running
    :class:`~bimrobot.coordination.simulation.ConstructionSimulation` (per node when ``sim.per_node``)."""
    node = request.node_ids[0] if request.node_ids and sim.per_node else None
    return task_key(request.activity, request.component_id, request.joint_id, node)


@dataclass
class TaskGraph:
    """The build's tasks and floor gates as a graph: ``keys[i]`` names node i, ``requests[i]`` is its
    task request (None for a gate), ``edges`` (E, 2) are precedences (before, after). ``groups`` (E,):
    the edges of one group release their ``after`` node once the first of them is done (per node: a
    component stands once its first node is positioned); a node waits for all its groups."""

    keys: list[str]
    kinds: np.ndarray
    requests: list
    edges: np.ndarray
    groups: np.ndarray
    #: :meth:`depths`, computed once per graph (2 CPU s at 10,000 components)
    _depth: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def any_of(self) -> np.ndarray:
        """(E,) True for an edge that is one of several alternatives of its group."""
        return np.bincount(self.groups, minlength=len(self.groups))[self.groups] > 1 if len(self.groups) else np.zeros(0, bool)

    def successors(self) -> list[list[int]]:
        """``successors()[i]``: the nodes that node i directly precedes (edge order)."""
        after: list[list[int]] = [[] for _ in self.keys]
        for a, b in self.edges.tolist():
            after[a].append(b)
        return after

    def topological_order(self) -> list[int]:
        """The nodes in an order where each comes before every node it precedes (networkx)."""
        import networkx as nx

        return list(nx.topological_sort(self._digraph()))

    def depths(self) -> np.ndarray:
        """(n,) each node's depth: the longest path from a source, in edges (its topological generation,
        networkx). A cycle is refused (BimrobotError)."""
        import networkx as nx

        if self._depth is not None:
            return self._depth.copy()
        depth = np.zeros(len(self.keys), np.int64)
        try:
            for d, generation in enumerate(nx.topological_generations(self._digraph())):
                depth[generation] = d
        except nx.NetworkXUnfeasible:
            raise BimrobotError("the task graph has a cycle") from None
        self._depth = depth
        return depth.copy()

    def _digraph(self):
        """The precedences as a networkx DiGraph over the node indices."""
        import networkx as nx

        graph = nx.DiGraph()
        graph.add_nodes_from(range(len(self.keys)))
        graph.add_edges_from(self.edges.tolist())
        return graph


@dataclass
class _Builder:
    """The task graph while it is built: its nodes in order (key, kind, request), the precedences
    (before, after[, group]) and per floor the tasks that close it."""

    keys: list = field(default_factory=list)
    kinds: list = field(default_factory=list)
    requests: list = field(default_factory=list)
    index: dict = field(default_factory=dict)
    edges: list = field(default_factory=list)
    closes: dict = field(default_factory=dict)

    def add(self, key: str, kind: str, request) -> None:
        self.index[key] = len(self.keys)
        self.keys.append(key)
        self.kinds.append(KINDS.index(kind))
        self.requests.append(request)

    def close(self, floor: int, key: str) -> None:
        self.closes.setdefault(floor, []).append(key)

    def finish(self) -> TaskGraph:
        """The graph: duplicate precedences dropped, a group for each edge without one."""
        unique = list(dict.fromkeys(e if len(e) == 3 else (*e, None) for e in self.edges))
        pairs = np.array([(self.index[a], self.index[b]) for a, b, _ in unique], dtype=np.int64).reshape(-1, 2)
        group_ids: dict = {}
        groups = [group_ids.setdefault(g if g is not None else ("edge", i), len(group_ids)) for i, (_, _, g) in enumerate(unique)]
        return TaskGraph(self.keys, np.array(self.kinds, dtype=np.int64), self.requests, pairs, np.array(groups, dtype=np.int64))


def problem_graph(problem: DispatchProblem, sim: ConstructionSimulation) -> TaskGraph:
    """:func:`task_graph` of ``sim``, a simulation of ``problem`` just started, built once per problem and
    kept in ``problem.derived``: the graph depends on the problem alone (its requests describe the tasks;
    the simulation's own requests are published with their ids), so the environments of one problem (the
    padding's, the policy's, the search's sandbox) share it instead of building it again (about 4 CPU s
    at 10,000 components). Read, never written."""
    if "task_graph" not in problem.derived:
        problem.derived["task_graph"] = task_graph(sim)
    return problem.derived["task_graph"]


def task_graph(sim: ConstructionSimulation) -> TaskGraph:
    """The tasks ``sim`` will publish, with what waits for what: transport after the positioning of what a
    component rests on and after the gate of the floor below; positioning after the transport (per node:
    after the transports of the joint's partners too, ACC); assembly after the positioning of its members
    (per node: of its node). One gate per floor closes it: after every assembly (and every positioning of
    a part without nodes) of the floor, and after the gate below. Call after ``sim.start()``."""
    graph = _Builder()
    built = [c for c in sim.smart.components.values() if not c.prebuilt]
    position_of = _add_handling(sim, graph, built)
    if sim.per_node:
        _add_node_assembly(sim, graph, built)
    else:
        _add_joint_assembly(sim, graph, position_of)
    _add_gates(sim, graph, built, position_of)
    _add_handling_order(sim, graph, built, position_of)
    return graph.finish()


def _add_handling(sim: ConstructionSimulation, graph: _Builder, built: list) -> dict[str, list[str]]:
    """A transport node and its positioning nodes (per node: one per connection node) for each component
    built; returns component -> the keys of its positioning tasks."""
    position_of: dict[str, list[str]] = {}
    for c in built:
        graph.add(f"transport:{c.id}", "transport", sim.request_for(Task.TRANSPORT, c))
        if sim.per_node and c.connection_nodes:
            position_of[c.id] = [f"position:{n.id}" for n in c.connection_nodes]
            for n in c.connection_nodes:
                graph.add(f"position:{n.id}", "position", sim.request_for(Task.POSITION, c, node=n))
        else:
            position_of[c.id] = [f"position:{c.id}"]
            graph.add(f"position:{c.id}", "position", sim.request_for(Task.POSITION, c))
    return position_of


def _add_node_assembly(sim: ConstructionSimulation, graph: _Builder, built: list) -> None:
    """Per node: an assembly of each node not yet assembled, after its positioning, before its floor's
    gate; the node's positioning after the transports of the joint's partners (unless they rest on it)."""
    smart = sim.smart
    for c in built:
        for n in c.connection_nodes:
            if n.state != State.ASSEMBLED:
                graph.add(f"assemble:{n.id}", "assemble", sim.request_for(Task.ASSEMBLE, c, node=n))
                graph.edges.append((f"position:{n.id}", f"assemble:{n.id}"))
                graph.close(n.level, f"assemble:{n.id}")
                joint = smart.joints[n.joint_id]
                for partner in joint.component_ids:
                    if partner != c.id and not smart.components[partner].prebuilt and not sim.rests_on(partner, c.id):
                        graph.edges.append((f"transport:{partner}", f"position:{n.id}"))


def _add_joint_assembly(sim: ConstructionSimulation, graph: _Builder, position_of: dict[str, list[str]]) -> None:
    """Per joint: an assembly of each joint to build, after the positioning of its members built here
    (for a prebuilt member: of what it rests on), before its floor's gate."""
    smart = sim.smart
    for joint in sim.joints_to_build():
        members = [smart.components[g] for g in joint.component_ids]
        graph.add(f"assemble:{joint.id}", "assemble", sim.request_for(Task.ASSEMBLE, members[0], joint))
        graph.close(joint.floor, f"assemble:{joint.id}")
        before = [p for m in members if not m.prebuilt for p in position_of[m.id]]
        before += [p for m in members if m.prebuilt for s in smart.robot_supporters(m.id) for p in position_of[s]]
        graph.edges += [(p, f"assemble:{joint.id}") for p in dict.fromkeys(before)]


def _add_gates(sim: ConstructionSimulation, graph: _Builder, built: list, position_of: dict[str, list[str]]) -> None:
    """One gate per floor but the top: after the tasks that close the floor (its assemblies, the
    positioning of its parts without nodes) and after the gate below."""
    for c in built:
        if not c.connection_nodes:
            graph.close(c.floor, position_of[c.id][0])
    for f in range(len(sim.smart.floors) - 1):
        graph.add(f"gate:{f}", "gate", None)
        graph.edges += [(k, f"gate:{f}") for k in graph.closes.get(f, ())]
        if f:
            graph.edges.append((f"gate:{f - 1}", f"gate:{f}"))


def _add_handling_order(sim: ConstructionSimulation, graph: _Builder, built: list, position_of: dict[str, list[str]]) -> None:
    """Positioning after the component's transport; transport after the positioning of each component it
    rests on (one group per supporter: its first node positioned is enough) and after the gate below."""
    for c in built:
        graph.edges += [(f"transport:{c.id}", p) for p in position_of[c.id]]
        graph.edges += [(p, f"transport:{c.id}", f"{s}>{c.id}") for s in sim.smart.robot_supporters(c.id) for p in position_of.get(s, ())]
        if c.floor:
            graph.edges.append((f"gate:{c.floor - 1}", f"transport:{c.id}"))
