"""The :class:`Schedule`: activities (:class:`~bimrobot.core.tasks.Activity`, times in seconds from the
start of the build) with their phases, and the precedence graph of their FINISH_START links, whatever file
they were read from (:mod:`bimrobot.schedule.csv`, :mod:`~bimrobot.schedule.msproject`, :mod:`~bimrobot.schedule.task_rows`).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Iterator

from bimrobot.core.errors import InputError
from bimrobot.core.tasks import Activity

if TYPE_CHECKING:  # pragma: no cover
    import networkx as nx


@dataclass
class Schedule:
    """Activities in file order, plus the summary tasks (phases) they are nested in, if any.

    ``activities`` are the leaves that robots execute; ``phases`` are IFC summary tasks (empty for a
    CSV schedule), each with its own ``parent``. ``source`` is the file it was read from.
    """

    activities: list[Activity]
    phases: list[Activity] = field(default_factory=list)
    source: Path | None = None
    epoch: str | None = None  # ISO date-time of t = 0 s, when the source had calendar times
    #: ids of activities read from a schedule that did not name a model element (Microsoft Project
    #: tasks no rule matched to the model): kept as activities without a component.
    unmatched: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._by_id = {a.id: a for a in [*self.phases, *self.activities]}
        self._successors: dict[str, list[Activity]] | None = None

    def __iter__(self) -> Iterator[Activity]:
        return iter(self.activities)

    def __len__(self) -> int:
        return len(self.activities)

    def __getitem__(self, activity_id: str) -> Activity:
        try:
            return self._by_id[activity_id]
        except KeyError:
            raise KeyError(f"no activity {activity_id!r} in {self.source or 'the schedule'}") from None

    def __contains__(self, activity_id: object) -> bool:
        return activity_id in self._by_id

    @property
    def makespan(self) -> float:
        """Finish of the last activity, seconds (0 for an empty schedule)."""
        return max((a.finish for a in self.activities), default=0.0)

    def of_component(self, global_id: str) -> list[Activity]:
        """The component's activities, by start time."""
        return sorted((a for a in self.activities if a.global_id == global_id), key=lambda a: (a.start, a.id))

    def successors(self, activity_id: str) -> list[Activity]:
        """Activities that list ``activity_id`` as a predecessor (lists made once for all activities)."""
        if self._successors is None:
            self._successors = {}
            for a in self.activities:
                for p in dict.fromkeys(a.predecessors):
                    self._successors.setdefault(p, []).append(a)
        return list(self._successors.get(activity_id, ()))

    def ready(self, done: Iterable[str]) -> list[Activity]:
        """Activities not in ``done`` whose predecessors are all in ``done``, by start time."""
        done = set(done)
        return sorted(
            (a for a in self.activities if a.id not in done and all(p in done for p in a.predecessors)),
            key=lambda a: (a.start, a.id),
        )

    def topological_order(self) -> list[Activity]:
        """Activities so that each comes after its predecessors: at every step the earliest-starting
        ready one (ties by id); networkx's lexicographical topological sort with the key (start, id),
        O(n log n + links). InputError naming the activities of a cycle, or an activity whose
        predecessor is not one of the activities (only possible for a Schedule built by hand).
        Python's cyclic garbage collector is paused meanwhile: its full passes over every live object
        made the time grow faster than the schedule (as in :func:`bimrobot.sco.build.gc_paused`)."""
        from bimrobot.sco.build import gc_paused

        with gc_paused():
            return self._topological_order()

    def _topological_order(self) -> list[Activity]:
        import networkx as nx  # imported when needed: it adds 0.2 s to every command that reads a schedule

        by_id = {a.id: a for a in self.activities}
        if len(by_id) < len(self.activities):
            twice = next(i for i, n in Counter(a.id for a in self.activities).items() if n > 1)
            raise InputError(f"{self.source or 'the schedule'} has two activities with the id {twice!r}")
        for a in self.activities:
            missing = next((p for p in a.predecessors if p not in by_id), None)
            if missing is not None:
                raise InputError(f"activity {a.id} of {self.source or 'the schedule'} has the predecessor "
                                 f"{missing!r}, which is not one of its activities")
        graph = precedence_graph({a.id: a.predecessors for a in self.activities})
        try:
            ids = list(nx.lexicographical_topological_sort(graph, key=lambda i: (by_id[i].start, i)))
        except nx.NetworkXUnfeasible:
            cycle = find_cycle({a.id: a.predecessors for a in self.activities}) or []
            raise InputError(f"the activities of {self.source or 'the schedule'} form a cycle {' -> '.join(cycle)}") from None
        return [by_id[i] for i in ids]

    def global_ids(self) -> set[str]:
        """GlobalIds of every component the schedule acts on."""
        return {a.global_id for a in self.activities if a.global_id}


def precedence_graph(predecessors: dict[str, tuple[str, ...]]) -> nx.DiGraph:
    """The directed graph predecessor -> activity of ``predecessors`` (activity id -> the ids that must
    finish first), nodes in the dict's order; a predecessor that is not a key is left out."""
    import networkx as nx

    graph = nx.DiGraph()
    graph.add_nodes_from(predecessors)
    graph.add_edges_from((p, a) for a, before in predecessors.items() for p in before if p in predecessors)
    return graph


def find_cycle(predecessors: dict[str, tuple[str, ...]]) -> list[str] | None:
    """A cycle ``[a, b, ..., a]`` in the predecessor relation, in execution order (each id a predecessor
    of the next), or None (networkx's depth-first search from the first activity)."""
    import networkx as nx

    try:
        edges = nx.find_cycle(precedence_graph(predecessors))
    except nx.NetworkXNoCycle:
        return None
    return [u for u, _ in edges] + [edges[0][0]]
