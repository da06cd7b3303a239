"""The planning problem as data: the instance ``bimrobot plan export`` writes (docs/planning.md).

The instance is built from the simulation's own pieces, so it is the problem ``simulate --per-joint``
runs and :func:`bimrobot.planning.optimal.solve_optimal` solves: the tasks and precedences of
:func:`~bimrobot.planning.optimal.task_graph` (its floor gate written as one gate per floor,
:func:`floor_gates`), every task's request from
:meth:`~bimrobot.coordination.simulation.ConstructionSimulation.request_for` (where the work is, what it
weighs, its nodes and points), handling times from the one time model (:mod:`bimrobot.sco.timing`, via
:func:`bimrobot.coordination.market.handling_time`) and robot homes as the simulation places them.

Units: metres, seconds, kg, m/s. Positions of components are in the model frame (the IFC's world
frame, z up); positions robots drive between are in the site frame (x, y), model frame + ``model_offset``.
"""

from __future__ import annotations

import json
from pathlib import Path

from bimrobot.core.errors import InputError

#: The instance format's version; :func:`load_instance` refuses any other. Version 2: one gate per floor
#: (``gates``) instead of every lower-floor joint before every transport. Version 3: the gate also waits
#: for the positioning of the floor's robot-built parts without connection nodes, as the simulation's does.
#: Version 4: no task for a joint among prebuilt parts only where those rest on robot work (version 3 listed
#: them; the simulation never runs them).
VERSION = 4

UNITS = {"length": "m", "time": "s", "mass": "kg", "speed": "m/s"}

#: Why one task must finish before another starts (``precedences[].rule``).
RULES = {
    "support": "a component is transported once every robot-built component it rests on is positioned",
    "floor_gate": (
        "gate:<f> closes floor f once every joint of floor f is assembled, every robot-built part of floor f "
        "without connection nodes is positioned and gate:<f-1> is closed; a component of floor f+1 is transported "
        "once gate:<f> is closed (so after all of that on the floors below it)"
    ),
    "own_order": "a component is positioned after its own transport",
    "joint_members": "a joint is assembled once every component it joins is positioned",
}

RELEASE = (
    "a task is published when all its predecessors have finished; a robot leaves for a task only once it "
    "is published; each robot does one task at a time and drives straight (site frame, x and y) from where "
    "its last task ended (its home before its first) to the task's start"
)

DURATION = (
    "a task on robot r takes travel + handling_s[r]: travel = horizontal distance from the robot's position "
    "to start_site_m / speed_m_s; handling_s (bimrobot.sco.timing): transport = load_s + "
    "|end_site_m - start_site_m| / speed_m_s + unload_s, position = max(1, nodes) x per_node_s, assemble = "
    "points x per_point_s"
)

KINDS = ("transport", "position", "assemble")


def _xy(point) -> list[float]:
    return [round(float(point[0]), 4), round(float(point[1]), 4)]


def _xyz(point) -> list[float]:
    return [round(float(v), 4) for v in point[:3]]


def _rule(task_kind: str) -> str:
    """The rule that makes a task's predecessor (not a floor gate) come before a task of ``task_kind``."""
    return {"transport": "support", "position": "own_order"}.get(task_kind, "joint_members")


def floor_gates(tasks: list[dict], closers: set[str]) -> tuple[list[dict], list[dict]]:
    """One gate per floor below the top floor that has transports: (``gates``, their ``floor_gate``
    precedences). ``gate:<f>`` follows each task of ``closers`` on floor f (its assemblies and the
    positioning of its parts without nodes: :func:`~bimrobot.planning.optimal_graph.floor_closers`) and
    ``gate:<f-1>``; a transport of floor f+1 follows ``gate:<f>``. The same order as every lower-floor
    closer before every transport, in O(tasks) edges instead of O(tasks x closers)."""
    top = max((t["floor"] for t in tasks if t["kind"] == "transport"), default=0)
    gates = [{"id": f"gate:{f}", "floor": f} for f in range(top)]
    edges = [{"before": f"gate:{f - 1}", "after": f"gate:{f}", "rule": "floor_gate"} for f in range(1, top)]
    for t in tasks:
        if t["id"] in closers and t["floor"] < top:
            edges.append({"before": t["id"], "after": f"gate:{t['floor']}", "rule": "floor_gate"})
        elif t["kind"] == "transport" and t["floor"] > 0:
            edges.append({"before": f"gate:{t['floor'] - 1}", "after": t["id"], "rule": "floor_gate"})
    return gates, edges


def build_instance(smart, fleet, site, storey_elevations=None) -> dict:
    """The planning instance (a JSON-ready dict) of ``smart`` (a SmartModel) built by ``fleet`` on ``site``
    (placed on the building, :func:`bimrobot.site.site.site_for`); ``storey_elevations`` in metres."""
    from bimrobot.planning.optimal_graph import floor_closers, task_graph
    from bimrobot.coordination.simulation import ConstructionSimulation

    sim = ConstructionSimulation(smart, fleet, site, storey_elevations=storey_elevations)
    graph = task_graph(sim.smart, sim)
    tasks = [_task_row(t, sim, fleet) for t in graph]
    closers = {key for keys in floor_closers(sim.smart).values() for key in keys}
    precedences = _precedences(graph, sim.smart)
    gates, gate_edges = floor_gates(tasks, closers)
    precedences += gate_edges
    return {
        "bimrobot": _signature(),
        "version": VERSION,
        "units": {**UNITS, "model_frame": "the IFC's world frame, z up", "site_frame": "model frame + model_offset (x, y), z up"},
        "model": str(smart.source),
        "fleet": fleet.name,
        "mode": "per-joint",
        "release": RELEASE,
        "duration": DURATION,
        "rules": RULES,
        "site": _site_row(sim),
        "robots": _robot_rows(fleet, sim),
        "tasks": tasks,
        "gates": gates,
        "precedences": precedences,
    }


def _task_row(t, sim, fleet) -> dict:
    """One task of the graph as the instance writes it: what it moves or joins, where (site frame, m),
    and its handling time (s) on each robot that can do it."""
    from bimrobot.coordination.market import handling_time, incapability

    kind = str(t.activity)
    request = t.request
    component = sim.smart.components[request.component_id]
    joint = sim.smart.joints[request.joint_id] if request.joint_id else None
    capable = [r for r in fleet.robots if not incapability(r, request)]
    return {
        "id": t.key,
        "kind": kind,
        "component": component.id,
        "joint": joint.id if joint else None,
        "joint_components": list(joint.component_ids) if joint else None,
        "floor": int(request.floor),
        "mass_kg": None if component.weight_kg is None else round(float(component.weight_kg), 3),
        "position_m": _xyz(joint.position if joint else component.target_position),
        "nodes": int(request.nodes) if kind == "position" else None,
        "points": int(request.points) if kind == "assemble" else None,
        "reach_m": round(float(request.reach_needed), 4),
        "start_site_m": _xy(request.start),
        "end_site_m": _xy(request.end),
        "handling_s": {r.name: round(handling_time(r, request), 6) for r in capable},
    }


def _precedences(graph, smart) -> list[dict]:
    """The graph's precedences between its tasks with the rule that makes each; the floor gate is left
    out (:func:`floor_gates` says it once per floor)."""
    known = {t.key for t in graph}
    precedences = []
    for t in graph:
        kind = str(t.activity)
        support = {f"position:{s}" for s in smart.robot_supporters(t.request.component_id)} if kind == "transport" else set()
        for p in t.predecessors:
            if kind == "transport" and p not in support:
                continue  # a floor gate: said once per floor below
            if p in known:
                precedences.append({"before": p, "after": t.key, "rule": _rule(kind)})
    return precedences


def _robot_rows(fleet, sim) -> list[dict]:
    """The fleet's robots as the instance writes them: capabilities, speeds, times, limits and home
    (site frame, m)."""
    robots = []
    for index, spec in enumerate(fleet.robots):
        home = sim.site.robot_start(index, fleet.home_on_site(spec, sim.offset))
        robots.append({
            "name": spec.name,
            "kind": spec.kind,
            "capabilities": [str(a) for a in spec.activities],
            "speed_m_s": spec.speed_m_s,
            "load_s": spec.load_s,
            "unload_s": spec.unload_s,
            "per_node_s": spec.time_per_node_s,
            "per_point_s": spec.time_per_point_s,
            "carry_kg": spec.carry_kg,
            "lift_kg": spec.lift_kg,
            "reach_m": spec.reach_m,
            "methods": list(spec.methods),
            "home_site_m": _xy(home),
        })
    return robots


def _site_row(sim) -> dict:
    """The site as the instance writes it: the model offset, the yard and the robots' homes (site frame, m)."""
    return {
        "source": sim.site.source,
        "model_offset": _xy(sim.offset),
        "yard_site_m": [_xy(p) for p in sim.site.yard],
        "robot_home_site_m": [_xy(p) for p in sim.site.robot_home],
        "idle_robots": sim.site.idle_robots,
    }


def _signature() -> str:
    from bimrobot.core.io import signature

    return signature("planning instance")


def dumps(instance: dict) -> str:
    """The instance as JSON text: sorted keys, so the same problem gives the same bytes."""
    return json.dumps(instance, sort_keys=True, indent=1, ensure_ascii=False) + "\n"


def load_instance(path: str | Path) -> dict:
    """Read and check an instance file; InputError (one sentence) when it is not one this version reads."""
    try:
        instance = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"{path}: cannot read the planning instance ({exc.strerror})") from None
    except ValueError as exc:
        raise InputError(f"{path}: not a JSON planning instance ({exc})") from None
    problem = check_instance(instance)
    if problem:
        raise InputError(f"{path}: {problem}")
    return instance


def check_instance(instance) -> str | None:
    """What is wrong with ``instance`` (one sentence), or None when it is a valid instance of :data:`VERSION`."""
    if not isinstance(instance, dict):
        return "a planning instance is a JSON object"
    if instance.get("version") != VERSION:
        return f"planning instance version {instance.get('version')!r}, this bimrobot reads version {VERSION}"
    for key in ("robots", "tasks", "gates", "precedences"):
        if not isinstance(instance.get(key), list):
            return f"the instance has no list {key!r}"
    robots = {r.get("name") for r in instance["robots"] if isinstance(r, dict)}
    ids = set()
    for task in instance["tasks"]:
        if not isinstance(task, dict) or task.get("kind") not in KINDS:
            return f"task {task.get('id') if isinstance(task, dict) else task!r} has no kind among {', '.join(KINDS)}"
        if task.get("id") in ids:
            return f"task {task['id']!r} is listed twice"
        ids.add(task.get("id"))
        handling = task.get("handling_s")
        if not isinstance(handling, dict) or not handling:
            return f"task {task['id']!r} has no capable robot (handling_s)"
        for name, seconds in handling.items():
            if name not in robots:
                return f"task {task['id']!r} names robot {name!r}, which is not in robots"
            if not isinstance(seconds, (int, float)) or seconds < 0:
                return f"task {task['id']!r}: handling time of {name} must be a number >= 0 s, got {seconds!r}"
    for gate in instance["gates"]:
        if not isinstance(gate, dict) or not str(gate.get("id", "")).startswith("gate:") or gate["id"] in ids:
            return f"gate {gate!r} is not a new id gate:<floor>"
        ids.add(gate["id"])
    for edge in instance["precedences"]:
        for end in ("before", "after"):
            if not isinstance(edge, dict) or edge.get(end) not in ids:
                return f"precedence {edge!r} names a task or gate that is not in tasks or gates ({end})"
        if edge.get("rule") not in RULES:
            return f"precedence {edge['before']} -> {edge['after']} has an unknown rule {edge.get('rule')!r}"
    return None
