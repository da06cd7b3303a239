"""The CP-SAT schedule's tasks (:mod:`bimrobot.planning.optimal`): the build's tasks with their
precedences as the simulation publishes them, the solver's time unit, and the order facts the model and
its bounds read (ancestors; whether a floor's work is held by the floor gate or feeds its joints)."""

from __future__ import annotations

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
    for component in components.values():
        if component.prebuilt:
            continue
        # a prebuilt supporter made later stands once its own robot-built supporters do
        preds = [f"position:{s}" for s in smart.robot_supporters(component.id)]
        gate = [key for floor, keys in closers.items() if floor < component.floor for key in keys if key not in preds]
        tasks.append(_Task(f"transport:{component.id}", Task.TRANSPORT, sim.request_for(Task.TRANSPORT, component),
                           preds + gate, component.floor if gate else None, component.floor))
        tasks.append(_Task(f"position:{component.id}", Task.POSITION, sim.request_for(Task.POSITION, component),
                           [f"transport:{component.id}"], None, component.floor))
    for joint in smart.joints.values():
        members = [components[g] for g in joint.component_ids]
        preds = [f"position:{m.id}" for m in members if not m.prebuilt]
        preds += [f"position:{s}" for m in members if m.prebuilt for s in smart.robot_supporters(m.id)]
        preds = list(dict.fromkeys(preds))
        if not preds:
            continue  # foundations only: nothing for robots to wait for, but still assembled
        tasks.append(_Task(f"assemble:{joint.id}", Task.ASSEMBLE, sim.request_for(Task.ASSEMBLE, members[0], joint),
                           preds, None, joint.floor))
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


def _all_feed_a_joint(tasks: list[_Task]) -> bool:
    """Whether every task of a floor is a joint or comes before one of the floor's joints (then nothing
    of this floor can run on after its gate, and floors follow each other without overlap)."""
    feeds = {p for t in tasks if t.activity == Task.ASSEMBLE for p in t.predecessors}
    changed = True
    while changed:
        changed = False
        for t in tasks:
            if t.key in feeds:
                for p in t.predecessors:
                    if p not in feeds:
                        feeds.add(p)
                        changed = True
    return all(t.activity == Task.ASSEMBLE or t.key in feeds for t in tasks)
