"""The CP-SAT schedule's tasks (:mod:`bimrobot.planning.optimal`): the build's tasks with their
precedences as the simulation publishes them, the solver's time unit, and the order facts the model and
its bounds read (ancestors; whether a floor's work is held by the floor gate or feeds its joints)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from bimrobot.coordination.simulation import ConstructionSimulation
from bimrobot.core.errors import InputError
from bimrobot.core.tasks import Task
from bimrobot.sco.build import SmartModel

SCALE = 100  # solver time unit: 0.01 s


@dataclass
class _Task:
    key: str
    activity: Task
    request: object
    predecessors: list[str]
    #: the floor gate: everything that closes a floor below this one comes first (None: no gate), see
    #: :func:`floor_closers`; those tasks are also listed in ``predecessors``
    gate_floor: int | None = None
    floor: int = 0
    #: whether it closes its floor (:func:`floor_closers`): the floor gate waits for it
    closes: bool = False


def floor_closers(smart: SmartModel) -> dict[int, list[str]]:
    """floor -> the tasks that close it in the simulation (its count of open work, per joint): the
    assembly of each joint with a robot-built part (a joint of prebuilt parts only is no task) and the
    positioning of each robot-built part without connection nodes (nothing else finishes it). The next
    floor's transports wait for all of them (the floor gate)."""
    components = smart.components
    closers: dict[int, list[str]] = {}
    for joint in smart.joints.values():
        if any(not components[g].prebuilt for g in joint.component_ids):
            closers.setdefault(joint.floor, []).append(f"assemble:{joint.id}")
    for component in components.values():
        if not component.prebuilt and not component.connection_nodes:
            closers.setdefault(component.floor, []).append(f"position:{component.id}")
    return closers


def task_graph(smart: SmartModel, sim: ConstructionSimulation) -> list[_Task]:
    """The build's tasks with their precedences, as the simulation publishes them."""
    tasks: list[_Task] = []
    components = smart.components
    closers = floor_closers(smart)
    closing = {key for keys in closers.values() for key in keys}
    for component in components.values():
        if component.prebuilt:
            continue
        # a prebuilt supporter made later stands once its own robot-built supporters do
        preds = [f"position:{s}" for s in smart.robot_supporters(component.id)]
        gate = [key for floor, keys in closers.items() if floor < component.floor for key in keys if key not in preds]
        tasks.append(_Task(f"transport:{component.id}", Task.TRANSPORT, sim.request_for(Task.TRANSPORT, component),
                           preds + gate, component.floor if gate else None, component.floor))
        key = f"position:{component.id}"
        tasks.append(_Task(key, Task.POSITION, sim.request_for(Task.POSITION, component),
                           [f"transport:{component.id}"], None, component.floor, key in closing))
    for joint in smart.joints.values():
        members = [components[g] for g in joint.component_ids]
        if all(m.prebuilt for m in members):
            continue  # made with the prebuilt parts it joins (the simulation's rule): no robot's work
        preds = [f"position:{m.id}" for m in members if not m.prebuilt]
        preds += [f"position:{s}" for m in members if m.prebuilt for s in smart.robot_supporters(m.id)]
        preds = list(dict.fromkeys(preds))
        key = f"assemble:{joint.id}"
        tasks.append(_Task(key, Task.ASSEMBLE, sim.request_for(Task.ASSEMBLE, members[0], joint),
                           preds, None, joint.floor, key in closing))
    return tasks


def _ticks(seconds: float) -> int:
    return int(math.ceil(seconds * SCALE - 1e-9))



def _closure(tasks: list[_Task]) -> dict[str, int]:
    """Each task's ancestors (within ``tasks``) as a bit set over ``tasks``' order (Python ints)."""
    import networkx as nx

    index = {t.key: i for i, t in enumerate(tasks)}
    preds = {t.key: [p for p in t.predecessors if p in index] for t in tasks}
    graph = nx.DiGraph()
    graph.add_nodes_from(preds)
    graph.add_edges_from((p, key) for key, ps in preds.items() for p in ps)
    ancestors: dict[str, int] = {}
    try:
        for key in nx.topological_sort(graph):  # every task after its predecessors
            bits = 0
            for p in preds[key]:
                bits |= (1 << index[p]) | ancestors[p]
            ancestors[key] = bits
    except nx.NetworkXUnfeasible:
        raise InputError("the task graph has a cycle: no schedule can satisfy its precedences") from None
    return ancestors



def _all_after_the_gate(tasks: list[_Task]) -> bool:
    """Whether every task of a floor waits, through the floor's own precedences, for a transport held
    by the floor gate (then nothing of this floor can start before the floors below are done)."""
    keys = {t.key for t in tasks}
    gated = {t.key for t in tasks if t.gate_floor is not None}
    changed = True
    while changed:
        changed = False
        for t in tasks:
            if t.key not in gated and any(p in gated for p in t.predecessors if p in keys):
                gated.add(t.key)
                changed = True
    return len(gated) == len(tasks)


def _all_feed_a_closer(tasks: list[_Task]) -> bool:
    """Whether every task of a floor closes it or comes before a task that does (then nothing of this
    floor can run on after its gate, and floors follow each other without overlap)."""
    feeds = {p for t in tasks if t.closes for p in t.predecessors}
    changed = True
    while changed:
        changed = False
        for t in tasks:
            if t.key in feeds:
                for p in t.predecessors:
                    if p not in feeds:
                        feeds.add(p)
                        changed = True
    return all(t.closes or t.key in feeds for t in tasks)


def within(tasks: list[_Task], **changes) -> list[_Task]:
    """``tasks`` as a problem of their own: each keeps only its predecessors among them (``changes``: other
    fields replaced as well, e.g. ``gate_floor=None`` for a floor solved alone)."""
    keys = {t.key for t in tasks}
    return [dataclasses.replace(t, predecessors=[p for p in t.predecessors if p in keys], **changes) for t in tasks]


def merge_overlapping_floors(tasks: list[_Task]) -> list[_Task]:
    """The tasks with each run of floors whose work may overlap relabelled as one floor, the top one of
    the run: a floor ends a run where every task of the run closes a floor of it or comes before one
    that does, and every task of the next floor waits for the floor gate. Then no run's work continues
    after the next one starts, and the solver's floor-by-floor reasoning (gates, floors alone, the
    chain) holds per run; a transport's gate becomes its run's. E.g. ROOT-staal's ground floor: four
    of its nine columns carry joints of floor 1 only and close nothing of their own floor, so floors 0
    and 1 are one run. The precedences are unchanged, so the schedules are the same."""
    floors = sorted({t.floor for t in tasks})
    top_of: dict[int, int] = {}
    first = 0
    for i, floor in enumerate(floors):
        run = set(floors[first:i + 1])
        local = within([t for t in tasks if t.floor in run])
        after = [t for t in tasks if i + 1 < len(floors) and t.floor == floors[i + 1]]
        if not after or (_all_feed_a_closer(local) and _all_after_the_gate(after)):
            top_of.update((f, floor) for f in run)
            first = i + 1
    return [dataclasses.replace(t, floor=top_of[t.floor], gate_floor=None if t.gate_floor is None else top_of[t.gate_floor])
            for t in tasks]
