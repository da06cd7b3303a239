"""The thesis' step-synchronous build loop (Listing 4.1, l.4862-4932), to reproduce its Table 4.2.

``bimrobot simulate --mode thesis``. Where the event-driven simulation (:mod:`.simulation`) asks how
fast a fleet can build, this loop runs the build the way the thesis did, in lock-step *construction
steps* (``../shared/specs/thesis-table-4.2.md``):

- Inside a step the kinds run in Listing 4.2's order: transport, positioning, assembly. For each kind:
  publish the requirements visible now, award each to the *idle* capable robot with the lowest bid
  (bid = travel / speed + handling, seconds), then every busy robot of that kind advances one phase.
  A transport task has 3 phases (come, carry, unload), a positioning or an assembly task 2 (come, work).
  A task finished in a step makes its successor visible to the later kinds of the same step.
- Transport is per component; positioning and assembly are per *connection node* (l.4214-4218), one
  node charge (``time_per_node``) or the node's points x ``time_per_point`` each.
- ACC / RCC (l.4240-4262): a component not on site is a *required connection component* and is
  requested for transport once the components that carry it stand; a node asks to be positioned once
  every component of its joint has arrived (they are *arrived connection components*); a node asks to
  be assembled once its position is fixed. Each request records the rule that released it.
- Floors (Listing 4.1): a node belongs to the floor of its joint (a column's top node to the floor of
  the beams it carries). The floor check runs at the end of a step; the next floor is published from
  the next step.
- After each task a robot returns to the yard point nearest to where it worked, in no time (as in the
  thesis). Nodes of prebuilt components (footings) are work of others and carry no robot work.
- Robot time = the sum of its task times. Construction time = the sum over steps of one *step time*,
  which the thesis does not define: :data:`STEP_TIME_RULES` are offered, ``awarded`` is the default.

Positions are site-frame x, y in metres; times in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bimrobot.site.fleet import Fleet, RobotSpec
from bimrobot.site.site import Site
from bimrobot.coordination.market import TaskRequest, incapability
from bimrobot.coordination.simulation import ConstructionSimulation
from bimrobot.core.errors import BimrobotError, InputError
from bimrobot.sco import timing
from bimrobot.sco.build import SmartModel
from bimrobot.sco.states import Event, State, at_least
from bimrobot.core.tasks import TASKS, Task

KINDS = TASKS
KIND_WORDS = {task: task.word for task in TASKS}  # "Node: ... requests positioning"

#: How one step's time is formed (the thesis does not say): the longest task awarded in the step
#: (Listing 4.2's "total work time"; default), the longest task finished in it, the longest phase
#: worked in it, or the longest task awarded per kind, summed over the kinds.
STEP_TIME_RULES = ("awarded", "finished", "phase", "per-kind")
DEFAULT_STEP_TIME = "awarded"

#: Table 4.2 of the thesis (l.4960-5015): robot -> (steps, time s); "total" is the overview row.
THESIS_TABLE_4_2 = {
    "fleet1": {
        "TransportRobot11": (26, 200.0), "PositioningRobot21": (40, 2543.0), "AssemblyRobot31": (42, 7343.0),
        "total": (49, 9868.0),
    },
    "fleet2": {
        "TransportRobot11": (12, 52.0), "TransportRobot12": (12, 102.0),
        "PositioningRobot21": (20, 1270.0), "PositioningRobot22": (20, 668.0),
        "AssemblyRobot31": (20, 3700.0), "AssemblyRobot32": (20, 1850.0),
        "total": (27, 5072.0),
    },
}


@dataclass
class ThesisTask:
    """One request: transport of a component, or positioning / assembly of one connection node.

    ``release``: the rule that released it: "RCC" (a component that is not on site is required by the
    components it connects to, listed in ``released_by``), "ACC" (the node's connection components have
    arrived) or "PositionFixed" (assembly after the node's positioning). Steps are 1-based.
    """

    id: str
    kind: Task
    component_id: str
    node_id: str | None
    floor: int
    published_step: int
    release: str
    released_by: tuple[str, ...]
    request: TaskRequest
    awarded_step: int | None = None
    finished_step: int | None = None
    robot: str | None = None
    time_s: float = 0.0


@dataclass
class ThesisRobot:
    """A robot in the loop: ``steps`` = steps in which it worked, ``time_s`` = sum of its task times (s)."""

    spec: RobotSpec
    position: np.ndarray
    steps: int = 0
    tasks: int = 0
    time_s: float = 0.0
    travel_s: float = 0.0
    handling_s: float = 0.0
    task: ThesisTask | None = None
    phases: list = field(default_factory=list)  # [(phase name, seconds)] of the current task
    phase: int = 0


@dataclass
class ThesisResult:
    """What a thesis-mode run produced (times s). ``totals``: construction time under each rule."""

    model: str
    fleet: str
    step_time_rule: str
    steps: int
    robots: list[ThesisRobot]
    tasks: list[ThesisTask]
    step_times: dict[str, list[float]]
    floor_steps: list[int]
    log_lines: list[str]
    thesis_table: dict | None = None
    built: SmartModel | None = None  # the run's copy of the model, in its final states

    @property
    def totals(self) -> dict[str, float]:
        return {rule: float(sum(times)) for rule, times in self.step_times.items()}

    @property
    def construction_time(self) -> float:
        """Construction time (s) under the chosen step-time rule."""
        return self.totals[self.step_time_rule]


def is_chapter4_frame(smart: SmartModel) -> bool:
    """True for the thesis' chapter-4 frame: 4 columns of 289.81 kg and 4 beams of 105.49 / 134.39 kg to build."""
    built = [c for c in smart.components.values() if not c.prebuilt]
    columns = sorted(round(c.weight_kg or 0, 2) for c in built if c.ifc_class == "IfcColumn")
    beams = sorted(round(c.weight_kg or 0, 2) for c in built if c.ifc_class == "IfcBeam")
    return len(built) == 8 and columns == [289.81] * 4 and beams == [105.49, 105.49, 134.39, 134.39]


class ThesisSimulation:
    """The step loop on ``smart`` with ``fleet`` on ``site``; call :meth:`run`.

    ``step_time``: one of :data:`STEP_TIME_RULES`. ``storey_elevations``: metres, for the reach a node
    needs. The same pre-flight check as the event mode refuses what the fleet cannot build (InputError).
    """

    def __init__(self, smart: SmartModel, fleet: Fleet, site: Site | None = None, step_time: str = DEFAULT_STEP_TIME,
                 storey_elevations: list[float] | None = None, max_steps: int = 1_000_000):
        if step_time not in STEP_TIME_RULES:
            raise InputError(f"step time rule must be one of {', '.join(STEP_TIME_RULES)}, got {step_time!r}")
        # Placement on the site (model -> site offset, yard slots) and the pre-flight check are shared.
        self.base = ConstructionSimulation(smart, fleet, site, storey_elevations=storey_elevations)
        # The run's own copy of the model (ConstructionSimulation made it): the caller's stays as built.
        self.smart, self.fleet, self.site = self.base.smart, fleet, self.base.site
        self.step_time = step_time
        self.max_steps = max_steps

    # ---------------------------------------------------------------- helpers
    def _work_nodes(self):
        """Nodes the robots must position and assemble (those of robot-built components)."""
        return [n for n in self.smart.nodes.values() if not self.smart.components[n.component_id].prebuilt]

    def _arrived(self, component_id: str) -> bool:
        component = self.smart.components[component_id]
        return component.prebuilt or at_least(component.state, State.ARRIVED)

    def _stands(self, component_id: str) -> bool:
        """On site with the position of at least one node fixed (or prebuilt): it can carry others."""
        component = self.smart.components[component_id]
        if component.prebuilt:
            return True
        if not component.connection_nodes:
            return at_least(component.state, State.POSITION_FIXED)
        return any(at_least(n.state, State.POSITION_FIXED) for n in component.connection_nodes if n.id in self.positioned)

    def _nearest_yard(self, point: np.ndarray) -> np.ndarray:
        yard = np.asarray(self.site.yard, dtype=float)
        return yard[int(np.argmin(np.hypot(*(yard - point).T)))].copy()

    def _publish(self, kind: Task, component, node, release: str, released_by, step: int) -> None:
        """Add a request to the pending list of its kind and log it (with its ACC / RCC rule)."""
        base = self.base
        if kind == Task.TRANSPORT:
            request = base.request_for(Task.TRANSPORT, component)
            floor = component.floor
        elif node is None:  # a component without nodes is positioned as a whole
            request = base.request_for(Task.POSITION, component)
            request.nodes = 1
            floor = component.floor
        else:
            joint = self.smart.joints[node.joint_id]
            request = base.request_for(Task.ASSEMBLE, component, joint)
            request.activity = kind
            request.start = request.end = base.site_xy(node.position)
            request.node_ids = (node.id,)
            request.points = node.assembly_point_number
            request.methods = frozenset({node.assembly_method})
            request.nodes = 1
            request.weight_kg = component.weight_kg or 0.0
            floor = node.level
        self.counter += 1
        task = ThesisTask(f"R{self.counter:04d}", kind, component.id, node.id if node else None, floor, step,
                          release, tuple(released_by), request)
        self.pending[kind].append(task)
        self.tasks.append(task)
        what = f"Node: {node.id}" if node else f"Component: {component.id}"
        if release == "RCC":
            why = (f"a required connection component (RCC) of {', '.join(released_by)}, which stand" if released_by
                   else f"a required connection component (RCC) of floor {floor + 1}, resting on nothing still to build")
        elif release == "ACC":
            why = (f"its connection components have arrived (ACC): {', '.join(released_by)}" if released_by
                   else "it joins nothing still to come (ACC)")
        else:
            why = "its position is fixed"
        self.lines.append(f"{what} requests {KIND_WORDS[kind]} ({task.id}): {why}")

    def _phases(self, robot: ThesisRobot, task: ThesisTask) -> list[tuple[str, float]]:
        """The task's phases for this robot: [(name, seconds)]; their sum is its bid."""
        times, request = robot.spec.times, task.request
        come = timing.travel_s(times, float(np.hypot(*(request.start - robot.position))))
        if task.kind == Task.TRANSPORT:
            carry = timing.travel_s(times, float(np.hypot(*(request.end - request.start))))
            return [("coming", come), ("carrying", times.load_s + carry), ("unloading", times.unload_s)]
        if task.kind == Task.POSITION:
            return [("coming", come), ("positioning", timing.position_s(times, request.nodes))]
        return [("coming", come), ("assembling", timing.assemble_s(times, request.points))]

    # ---------------------------------------------------------------- run
    def run(self) -> ThesisResult:
        smart = self.smart
        self._start()
        to_build = [c for c in smart.components.values() if not c.prebuilt]
        floor_units = self._floor_units(to_build)
        self.done_on_floor: dict[int, int] = {f: 0 for f in floor_units}
        floors = sorted(floor_units)
        self.floor = floors[0]
        floor_steps: list[int] = []
        published: tuple[set[str], set[str], set[str]] = (set(), set(), set())  # transports, nodes, bodies
        step = 0
        while floors:
            step += 1
            if step > self.max_steps:
                raise BimrobotError(f"the thesis loop did not finish within {self.max_steps} steps")
            phases = self._step(step, to_build, *published)
            self._close_floors(step, floors, floor_units, floor_steps)
            if floors and not phases:  # no robot worked: nothing can change any more
                waiting = [t.id for k in KINDS for t in self.pending[k]]
                raise BimrobotError(
                    f"the thesis loop stalled in step {step} on floor {self.floor + 1}: no robot can take "
                    f"the {len(waiting)} waiting requests{' (e.g. ' + waiting[0] + ')' if waiting else ''}"
                )
        table = None
        if self.fleet.name in THESIS_TABLE_4_2 and is_chapter4_frame(smart):
            table = THESIS_TABLE_4_2[self.fleet.name]
        return ThesisResult(smart.source, self.fleet.name, self.step_time, step, list(self.robots.values()),
                            self.tasks, self.step_times, floor_steps, self.lines, table, built=smart)

    def _start(self) -> None:
        """The run's state before step 1: robots at their starts on the site, no request, an empty log."""
        self.robots = {}
        for index, spec in enumerate(self.fleet.robots):
            home = self.site.robot_start(index, self.fleet.home_on_site(spec, self.base.offset))
            self.robots[spec.name] = ThesisRobot(spec, np.array(home, dtype=float))
        self.pending = {k: [] for k in KINDS}
        self.tasks: list[ThesisTask] = []
        self.lines: list[str] = []
        self.counter = 0
        self.positioned: set[str] = set()
        self.step_times = {rule: [] for rule in STEP_TIME_RULES}

    def _floor_units(self, to_build) -> dict[int, int]:
        """Units of floor work per floor: every work node, and every component without nodes (positioned as a whole)."""
        floor_units: dict[int, int] = {}
        for node in self._work_nodes():
            floor_units[node.level] = floor_units.get(node.level, 0) + 1
        for c in to_build:
            if not c.connection_nodes:
                floor_units[c.floor] = floor_units.get(c.floor, 0) + 1
        return floor_units

    def _step(self, step: int, to_build, transport_published: set, node_published: set, body_published: set) -> list[float]:
        """One construction step: transport requests of components whose carriers stand (RCC), positioning
        requests (ACC), then per kind the awards and one phase of every robot's work; records the step's
        times under every rule and returns the phases worked (s; none: no robot worked)."""
        self.lines += ["-" * 48, f"Start a new construction step, NO.{step}, in {self.floor + 1} floor", "-" * 48,
                       "Get components requirement from site", ""]
        for c in sorted(to_build, key=lambda c: (c.floor, c.bottom_z, c.id)):
            if c.id in transport_published or c.floor > self.floor:
                continue
            supporters = self.smart.robot_supporters(c.id)
            if all(self._stands(s) for s in supporters):
                transport_published.add(c.id)
                self._publish(Task.TRANSPORT, c, None, "RCC", self.smart.supporters[c.id], step)
        awarded = {k: [] for k in KINDS}
        finished: list[float] = []
        phases: list[float] = []
        for kind in KINDS:
            if kind == Task.POSITION:
                self._release_positioning(to_build, node_published, body_published, step)
            self.lines.append(f"Publish {KIND_WORDS[kind]} requirements to robot")
            self._award(kind, step, awarded)
            for robot in self.robots.values():
                if robot.task is not None and robot.task.kind == kind:
                    phases.append(self._advance(robot, step, finished))
            self.lines.append("")
        self.step_times["awarded"].append(max((t for k in KINDS for t in awarded[k]), default=0.0))
        self.step_times["finished"].append(max(finished, default=0.0))
        self.step_times["phase"].append(max(phases, default=0.0))
        self.step_times["per-kind"].append(sum(max(awarded[k], default=0.0) for k in KINDS))
        return phases

    def _close_floors(self, step: int, floors: list[int], floor_units: dict[int, int], floor_steps: list[int]) -> None:
        """Floor check (Listing 4.1) at the end of the step: every floor whose work is all done is closed
        (``floors`` loses it, ``floor_steps`` records the step) and work moves to the next one."""
        while floors and self.done_on_floor[self.floor] == floor_units[self.floor]:
            floor_steps.append(step)
            self.lines.append(f"Floor {self.floor + 1} is complete after step {step}")
            floors.pop(0)
            if floors:
                self.floor = floors[0]

    def _release_positioning(self, to_build, node_published: set, body_published: set, step: int) -> None:
        """Nodes whose component and joint partners have arrived ask to be positioned (ACC)."""
        for c in to_build:
            if not self._arrived(c.id) or c.state == State.ON_YARD:
                continue
            if not c.connection_nodes and c.id not in body_published and c.floor <= self.floor:
                body_published.add(c.id)
                self._publish(Task.POSITION, c, None, "ACC", [], step)
            for node in c.connection_nodes:
                if node.id in node_published or node.level > self.floor:
                    continue
                partners = [p for p in self.smart.joints[node.joint_id].component_ids if p != c.id]
                if all(self._arrived(p) for p in partners):
                    node_published.add(node.id)
                    self._publish(Task.POSITION, c, node, "ACC", partners, step)

    def _award(self, kind: Task, step: int, awarded: dict) -> None:
        """Award the visible requests of ``kind`` in publication order to idle robots, lowest bid first."""
        for task in [t for t in self.pending[kind] if t.floor <= self.floor]:
            idle = [r for r in self.robots.values()
                    if r.task is None and r.spec.can(kind) and incapability(r.spec, task.request) is None]
            if not idle:
                continue
            bids = sorted((sum(s for _, s in self._phases(r, task)), r.spec.name, r) for r in idle)
            cost, name, robot = bids[0]
            robot.task, robot.phases, robot.phase = task, self._phases(robot, task), 0
            task.awarded_step, task.robot, task.time_s = step, name, cost
            self.pending[kind].remove(task)
            awarded[kind].append(cost)
            component = self.smart.components[task.component_id]
            if kind == Task.TRANSPORT:
                component.update_state(Event.START_TRANSPORT)
            elif kind == Task.POSITION:
                if task.node_id:
                    self.smart.nodes[task.node_id].update_state(Event.START_POSITIONING)
            else:
                self.smart.nodes[task.node_id].update_state(Event.START_ASSEMBLY)
            self._sync(component)

    def _advance(self, robot: ThesisRobot, step: int, finished: list) -> float:
        """The robot does one phase of its task; returns the phase's seconds."""
        task = robot.task
        name, seconds = robot.phases[robot.phase]
        robot.steps += 1
        who, cost = robot.spec.name, task.time_s
        if task.kind == Task.TRANSPORT:  # Listing 4.2's words, every step the robot works
            self.lines.append(f"{who} is working for component: {task.component_id}, total work time is {cost:.2f}s")
        elif task.kind == Task.POSITION:
            self.lines.append(f"{who} is positioning for nodes: {task.node_id or task.component_id}, total work time is {cost:.2f}s")
        else:
            self.lines.append(f"{who} is finding nodes: {task.node_id}, total work time is {cost:.2f}s")
        self.lines.append(f"Current progress: {who} is {name}")
        robot.phase += 1
        if robot.phase < len(robot.phases):
            return seconds
        # The task is done.
        robot.tasks += 1
        robot.time_s += task.time_s
        travel = robot.phases[0][1] + (robot.phases[1][1] - robot.spec.load_s if task.kind == Task.TRANSPORT else 0.0)
        robot.travel_s += travel
        robot.handling_s += task.time_s - travel
        robot.task, robot.phases, robot.phase = None, [], 0
        task.finished_step = step
        finished.append(task.time_s)
        robot.position = self._nearest_yard(task.request.end)  # back to the nearest yard point, untimed
        component = self.smart.components[task.component_id]
        if task.kind == Task.TRANSPORT:
            component.update_state(Event.FINISH_TRANSPORT)
            component.update_state(Event.PUBLISH_POSITIONING)
            for node in component.connection_nodes:
                node.state = State.IN_LOCATION
            self.lines.append(f"Component: {component.id} is arrived, {robot.spec.name} is free for next work")
        elif task.kind == Task.POSITION:
            if task.node_id is None:
                component.update_state(Event.START_POSITIONING)
                component.update_state(Event.FINISH_POSITIONING)
                component.state = State.ASSEMBLED
                self.done_on_floor[component.floor] += 1
            else:
                node = self.smart.nodes[task.node_id]
                node.update_state(Event.FINISH_POSITIONING)
                self.positioned.add(node.id)
            self.lines.append(f"Node: {task.node_id or component.id} position is fixed, {robot.spec.name} is free for next work")
            if task.node_id is not None:
                node.update_state(Event.PUBLISH_ASSEMBLY)
                self._publish(Task.ASSEMBLE, component, node, "PositionFixed", [], step)
        else:
            node = self.smart.nodes[task.node_id]
            node.update_state(Event.FINISH_ASSEMBLY)
            self.done_on_floor[node.level] += 1
            self.lines.append(f"Node: {node.id} is assembled, {robot.spec.name} is free for next work")
        self._sync(component)
        return seconds

    @staticmethod
    def _sync(component) -> None:
        """The component's state follows its nodes (see :meth:`Component.sync_from_nodes`)."""
        component.sync_from_nodes()


def simulate_thesis(smart: SmartModel, fleet: Fleet, site: Site | None = None, step_time: str = DEFAULT_STEP_TIME,
                    storey_elevations: list[float] | None = None) -> ThesisResult:
    """Run the thesis' step loop; see :class:`ThesisSimulation`."""
    return ThesisSimulation(smart, fleet, site, step_time, storey_elevations).run()


# ---------------------------------------------------------------- reports
def robot_rows(result: ThesisResult) -> list[dict]:
    """One row per robot as in Table 4.2: steps worked and time (s), and the thesis' figures when known."""
    rows = []
    table = result.thesis_table or {}
    for robot in result.robots:
        thesis = table.get(robot.spec.name)
        rows.append({
            "robot": robot.spec.name,
            "kind": robot.spec.kind,
            "steps": robot.steps,
            "tasks": robot.tasks,
            "time_s": round(robot.time_s, 2),
            "travel_s": round(robot.travel_s, 2),
            "handling_s": round(robot.handling_s, 2),
            "thesis_steps": "" if thesis is None else thesis[0],
            "thesis_time_s": "" if thesis is None else thesis[1],
        })
    return rows


def _difference(ours: float, theirs: float) -> str:
    return f"{(ours - theirs) / theirs:+.1%}" if theirs else ""


def format_thesis_table(result: ThesisResult) -> str:
    """Table 4.2's layout: per robot steps and time, then the overview (steps, construction time)."""
    table = result.thesis_table
    head = f"{'robot':<20} {'steps':>5} {'time s':>9}"
    if table:
        head += f"   {'thesis steps':>12} {'thesis time s':>13} {'time diff.':>10}"
    lines = [head]
    for row in robot_rows(result):
        line = f"{row['robot']:<20} {row['steps']:>5} {row['time_s']:>9.1f}"
        if table and row["thesis_steps"] != "":
            line += f"   {row['thesis_steps']:>12} {row['thesis_time_s']:>13.0f} {_difference(row['time_s'], row['thesis_time_s']):>10}"
        lines.append(line)
    total = f"{'overview':<20} {result.steps:>5} {result.construction_time:>9.1f}"
    if table:
        steps, seconds = table["total"]
        total += f"   {steps:>12} {seconds:>13.0f} {_difference(result.construction_time, seconds):>10}"
    lines.append(total)
    rules = ", ".join(
        f"{rule}{' (used)' if rule == result.step_time_rule else ''} {seconds:.1f} s" for rule, seconds in result.totals.items()
    )
    lines.append(f"construction time = sum over steps of the step time; by rule: {rules}")
    if table:
        lines.append("thesis figures: Table 4.2 (thesis l.4960-5015), shown because this is the chapter-4 frame and a built-in fleet")
    return "\n".join(lines)


def request_rows(result: ThesisResult) -> list[dict]:
    """Every request: kind, component, node, floor, the rule that released it (ACC / RCC / PositionFixed), steps."""
    return [{
        "request": t.id,
        "kind": t.kind,
        "component": t.component_id,
        "node": t.node_id or "",
        "floor": t.floor + 1,
        "release": t.release,
        "released_by": " ".join(t.released_by),
        "published_step": t.published_step,
        "awarded_step": t.awarded_step,
        "finished_step": t.finished_step,
        "robot": t.robot or "",
        "time_s": round(t.time_s, 2),
    } for t in result.tasks]


def thesis_summary(result: ThesisResult, unknown_weight: dict | None = None, smart_summary: dict | None = None) -> dict:
    """Steps, construction time under every rule, per-robot rows and provenance (JSON-serialisable)."""
    from collections import Counter

    from bimrobot.core.io import signature

    return {
        "generator": signature("simulate summary"),
        "mode": "thesis",
        "model": result.model,
        "fleet": result.fleet,
        "steps": result.steps,
        "step_time_rule": result.step_time_rule,
        "construction_time_s": round(result.construction_time, 3),
        "construction_time_by_rule_s": {k: round(v, 3) for k, v in result.totals.items()},
        "floor_complete_after_step": result.floor_steps,
        "requests_by_release": dict(Counter(t.release for t in result.tasks)),
        "robots": robot_rows(result),
        "thesis_table_4_2": result.thesis_table,
        "step_times_s": {k: [round(v, 3) for v in times] for k, times in result.step_times.items()},
        "unknown_weight": unknown_weight,
        "smart_components": smart_summary,
    }


def write_thesis_outputs(result: ThesisResult, out_dir, unknown_weight: dict | None = None, smart_summary: dict | None = None) -> list:
    """Write events.log (Listing 4.2), robots.txt / robots.csv (Table 4.2), requests.csv, summary.json."""
    import csv
    import json
    from pathlib import Path

    out_dir = Path(out_dir)
    (out_dir / "events.log").write_text("\n".join(result.log_lines) + "\n", encoding="utf-8")
    (out_dir / "robots.txt").write_text(format_thesis_table(result) + "\n", encoding="utf-8")
    for name, rows in (("robots.csv", robot_rows(result)), ("requests.csv", request_rows(result))):
        with open(out_dir / name, "w", newline="", encoding="utf-8") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    summary = thesis_summary(result, unknown_weight, smart_summary)
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return [out_dir / n for n in ("events.log", "robots.txt", "robots.csv", "requests.csv", "summary.json")]
