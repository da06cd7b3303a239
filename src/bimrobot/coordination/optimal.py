"""An optimal schedule with OR-Tools CP-SAT, to measure how far the market is from the best possible.

Same problem as the simulation: the same tasks (transport, position, assemble), handling times, robot
speeds, capabilities, start positions and precedences (supporters positioned before a component is
brought in, floor by floor, position after transport, assemble after all members are positioned), and
a robot leaves for a task only once the task is published (its predecessors are done). Travel between
two tasks of one robot is sequence-dependent, modelled with one circuit per robot. The market's schedule
is a feasible solution of this model, so the optimum is never worse than the market.

Times in seconds (solved in units of 0.01 s). Only for small instances (tens of tasks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bimrobot.coordination.fleet import Fleet, Site
from bimrobot.coordination.market import handling_time, incapability
from bimrobot.coordination.simulation import ConstructionSimulation
from bimrobot.tasks import Task
from bimrobot.errors import InputError, require_extra
from bimrobot.sco.build import SmartModel

SCALE = 100  # solver time unit: 0.01 s


@dataclass
class _Task:
    key: str
    activity: Task
    request: object
    predecessors: list[str]


@dataclass
class OptimalSchedule:
    makespan: float
    lower_bound: float
    status: str
    assignment: dict[str, str]  # task key -> robot
    start: dict[str, float]  # task key -> work start (s)
    tasks: int


def task_graph(smart: SmartModel, sim: ConstructionSimulation) -> list[_Task]:
    """The build's tasks with their precedences, as the simulation publishes them."""
    tasks: list[_Task] = []
    components = smart.components
    joints_by_floor: dict[int, list[str]] = {}
    for joint in smart.joints.values():
        joints_by_floor.setdefault(joint.floor, []).append(f"assemble:{joint.id}")
    for component in components.values():
        if component.prebuilt:
            continue
        # a prebuilt supporter made later stands once its own robot-built supporters do
        preds = [f"position:{s}" for s in smart.robot_supporters(component.id)]
        preds += [key for floor, keys in joints_by_floor.items() if floor < component.floor for key in keys]
        tasks.append(_Task(f"transport:{component.id}", Task.TRANSPORT, sim.request_for(Task.TRANSPORT, component), preds))
        tasks.append(_Task(f"position:{component.id}", Task.POSITION, sim.request_for(Task.POSITION, component), [f"transport:{component.id}"]))
    for joint in smart.joints.values():
        members = [components[g] for g in joint.component_ids]
        preds = [f"position:{m.id}" for m in members if not m.prebuilt]
        preds += [f"position:{s}" for m in members if m.prebuilt for s in smart.robot_supporters(m.id)]
        preds = list(dict.fromkeys(preds))
        if not preds:
            continue  # foundations only: nothing for robots to wait for, but still assembled
        tasks.append(_Task(f"assemble:{joint.id}", Task.ASSEMBLE, sim.request_for(Task.ASSEMBLE, members[0], joint), preds))
    return tasks


def solve_optimal(
    smart: SmartModel,
    fleet: Fleet,
    site: Site | None = None,
    storey_elevations: list[float] | None = None,
    time_limit_s: float = 60.0,
    workers: int = 2,
    max_tasks: int = 60,
) -> OptimalSchedule:
    """Minimum-makespan schedule of the build (CP-SAT). Raises InputError above ``max_tasks`` tasks."""
    cp_model = require_extra("ortools.sat.python.cp_model", "optimize")
    sim = ConstructionSimulation(smart, fleet, site, storey_elevations=storey_elevations)
    tasks = task_graph(smart, sim)
    if len(tasks) > max_tasks:
        raise InputError(f"the build has {len(tasks)} tasks; the CP-SAT comparison is limited to {max_tasks}")
    homes = {}
    for index, spec in enumerate(fleet.robots):
        homes[spec.name] = np.array(sim.site.robot_start(index, fleet.home_on_site(spec, sim.offset)), dtype=float)

    def ticks(seconds: float) -> int:
        return int(math.ceil(seconds * SCALE - 1e-9))

    model = cp_model.CpModel()
    horizon = 0
    capable = {t.key: [r for r in fleet.robots if not incapability(r, t.request)] for t in tasks}
    for t in tasks:
        worst = max(handling_time(r, t.request) for r in capable[t.key])
        horizon += ticks(worst) + ticks(200.0 / min(r.speed_m_s for r in fleet.robots))
    horizon += ticks(3600)
    depart = {t.key: model.NewIntVar(0, horizon, f"depart[{t.key}]") for t in tasks}
    start = {t.key: model.NewIntVar(0, horizon, f"start[{t.key}]") for t in tasks}
    end = {t.key: model.NewIntVar(0, horizon, f"end[{t.key}]") for t in tasks}
    assigned = {}
    intervals: dict[str, list] = {r.name: [] for r in fleet.robots}
    for t in tasks:
        literals = []
        for r in capable[t.key]:
            lit = model.NewBoolVar(f"x[{t.key},{r.name}]")
            assigned[t.key, r.name] = lit
            literals.append(lit)
            duration = ticks(handling_time(r, t.request))
            model.Add(end[t.key] == start[t.key] + duration).OnlyEnforceIf(lit)
            # redundant with the circuits below, but it makes the solver propagate much better
            intervals[r.name].append(model.NewOptionalIntervalVar(start[t.key], duration, end[t.key], lit, f"work[{t.key},{r.name}]"))
        model.AddExactlyOne(literals)
        model.Add(depart[t.key] <= start[t.key])
        for p in t.predecessors:
            model.Add(depart[t.key] >= end[p])
    for r in fleet.robots:
        mine = [t for t in tasks if (t.key, r.name) in assigned]
        if not mine:
            continue
        arcs = []
        index = {t.key: i + 1 for i, t in enumerate(mine)}
        empty = model.NewBoolVar(f"idle[{r.name}]")
        arcs.append((0, 0, empty))
        for t in mine:
            lit = assigned[t.key, r.name]
            arcs.append((index[t.key], index[t.key], lit.Not()))
            first = model.NewBoolVar(f"first[{r.name},{t.key}]")
            arcs.append((0, index[t.key], first))
            travel = ticks(float(np.hypot(*(t.request.start - homes[r.name]))) / r.speed_m_s)
            model.Add(start[t.key] >= depart[t.key] + travel).OnlyEnforceIf(first)
            last = model.NewBoolVar(f"last[{r.name},{t.key}]")
            arcs.append((index[t.key], 0, last))
            for u in mine:
                if u.key == t.key:
                    continue
                follow = model.NewBoolVar(f"next[{r.name},{t.key},{u.key}]")
                arcs.append((index[t.key], index[u.key], follow))
                travel = ticks(float(np.hypot(*(u.request.start - t.request.end))) / r.speed_m_s)
                model.Add(depart[u.key] >= end[t.key]).OnlyEnforceIf(follow)
                model.Add(start[u.key] >= depart[u.key] + travel).OnlyEnforceIf(follow)
        model.AddCircuit(arcs)
        model.AddNoOverlap(intervals[r.name])
    makespan = model.NewIntVar(0, horizon, "makespan")
    model.AddMaxEquality(makespan, list(end.values()))
    model.Minimize(makespan)
    solver = cp_model.CpSolver()
    solver.parameters.max_time_in_seconds = time_limit_s
    solver.parameters.num_workers = workers
    status = solver.Solve(model)
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        raise InputError(f"CP-SAT found no schedule within {time_limit_s} s (status {solver.StatusName(status)})")
    assignment = {
        t.key: next(r.name for r in capable[t.key] if solver.Value(assigned[t.key, r.name]))
        for t in tasks
    }
    return OptimalSchedule(
        makespan=solver.Value(makespan) / SCALE,
        lower_bound=solver.BestObjectiveBound() / SCALE,
        status=solver.StatusName(status),
        assignment=assignment,
        start={t.key: solver.Value(start[t.key]) / SCALE for t in tasks},
        tasks=len(tasks),
    )
