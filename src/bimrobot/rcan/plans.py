"""Plans of RCAN activities: from a schedule CSV (+ BuildingModel) and the thesis' three experiments.

A schedule row is broken down into RCAN activities (see :mod:`bimrobot.rcan.activities`) with goal
poses: components wait on the yard (one slot per component, ``yard_spacing_m`` apart along x from
``yard``), the robot's base stops ``standoff_m`` short (in -y) of the pick-up slot and of the installed
position, and the gripper goes to the slot and to the installed position (``Target*`` of the row).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import Callable

from bimrobot.bim.examples import RCAN_EXPERIMENTS
from bimrobot.core.errors import InputError
from bimrobot.bim import components
from bimrobot.rcan.activities import SCHEDULE_DECOMPOSITION, ActivityKind, Pose, RcanActivity
from bimrobot.core.tasks import Task

K = ActivityKind

#: How far apart (m, horizontally) a component's pick-up and installed positions may be for a robot to do
#: both from one stand midway: the reach of the thesis' UR5 (0.85 m), so each is at most 0.43 m away.
WITHIN_REACH_M = 0.85


@dataclass(frozen=True)
class ComponentFacts:
    """What a plan needs to know of one component, from a model or from the construction graph.

    ``weight_kg`` (None: unknown, no payload is checked); ``section_m`` (the two smaller extents, m);
    ``position`` its installed position (m, world) when the schedule row gives none; ``pick_up`` where
    it waits on the yard (m, world; None: the next of RCAN's own yard slots); ``start_state`` the state
    it starts in (``OnYard`` for a component robots fetch; None: not known, as with a schedule CSV);
    ``size_m`` its three extents, smallest first (m).
    """

    weight_kg: float | None = None
    section_m: tuple[float, float] | None = None
    position: tuple[float, float, float] | None = None
    pick_up: tuple[float, float, float] | None = None
    start_state: str | None = None
    size_m: tuple[float, float, float] | None = None


def model_facts(model) -> Callable[[str], ComponentFacts]:
    """Facts of a model's components (GlobalId of an element or an assembly); without a model,
    nothing is known. A GlobalId that is not a component of the model raises InputError."""
    if model is None:
        return lambda gid: ComponentFacts()

    def facts(gid: str) -> ComponentFacts:
        if not components.is_component(model, gid):
            raise InputError(f"schedule names component {gid}, which is not in {model.source or 'the model'}")
        extents = components.extents(model, gid)
        return ComponentFacts(components.weight_kg(model, gid), components.section_m(model, gid),
                              tuple(float(v) for v in components.position(model, gid)),
                              size_m=None if extents is None else tuple(round(float(v), 4) for v in sorted(extents)))

    return facts


def plan_from_schedule(schedule, model=None, yard: tuple[float, float, float] = (-10.0, -10.0, 0.0),
                       yard_spacing_m: float = 2.0, standoff_m: float = 0.6,
                       facts: Callable[[str], ComponentFacts] | None = None,
                       reach_m: float = WITHIN_REACH_M) -> list[RcanActivity]:
    """RCAN activities for every row of ``schedule`` (a :class:`bimrobot.schedule.csv.Schedule`).

    A row without a target position (an IFC work schedule's task) goes to its component's position
    in ``model`` (an element's placement origin; see :mod:`bimrobot.bim.components` for an assembly).

    ``model`` (a BuildingModel, with :func:`bimrobot.bim.unknown_weight.apply_unknown_weight_rule`
    already applied) supplies component weights (kg; the allocator only gives a component to robots
    whose payload carries it) and sections; a component whose weight stays unknown, and every
    component without ``model``, has ``weight_kg`` None: no payload is checked for it, and the run
    reports it. A GlobalId may name an element or an assembly (lifted as one unit: the sum of its
    parts' weights). ``facts`` replaces ``model`` as the source of these (e.g. the construction graph:
    :func:`plan_from_graph`). Ids are ``<Identification>.<n>``; the first activity of a row
    waits for the last one of each predecessor row.

    Components wait at their pick-up position (``facts``), else in RCAN's own yard slots,
    ``yard_spacing_m`` apart along x from ``yard``. A ``transport`` row ends with the component set
    down at its drop-off point (the transport's stand pose) and the robot free: the component's
    positioning may have to wait for other components, and the robot may be needed to bring them. The
    ``position`` (or ``assemble``) row that follows picks it up again there (move to component,
    position for picking up, pick up, position for installing), possibly with another robot. A
    ``position`` or ``assemble`` row of a component still on the yard (its start state is ``OnYard``
    and no row transported it) picks it up there: when the pick-up and installed positions are at most
    ``reach_m`` apart (horizontally) the robot stands midway and does both from there (the thesis'
    experiment 1), else it transports the component itself and keeps holding it (experiments 2, 3). A ``position`` or ``assemble`` row of a component in place already (a
    footing, a further connection node after the first install; a CSV does not say where a
    component starts, so one no row transported is taken to be in place) starts by moving a robot to
    it: move to component, position for installing, install. A ``position`` row leaves the component
    PositionFixed and frees its robot (chapter 4: assembly robots fix the connection nodes afterwards);
    a component that no ``assemble`` row fixes is installed by its ``position`` row (nothing is left
    to fix: the simulation counts it Assembled once positioned).
    """
    facts = facts or model_facts(model)
    rows = schedule.topological_order()
    planner = _RowPlanner(facts, yard, yard_spacing_m, standoff_m, reach_m,
                          assembled_later={row.global_id for row in rows if row.activity == Task.ASSEMBLE})
    for row in rows:
        planner.add(row)
    return _robot_order(planner.activities, rows, planner.last_of_row)


@dataclass
class _RowPlanner:
    """:func:`plan_from_schedule`'s pass over the schedule rows, in precedence order: what it knows of each
    component (where it waits, whether it was set down or put in place) and the activities so far."""

    facts: Callable[[str], ComponentFacts]
    yard: tuple[float, float, float]
    yard_spacing_m: float
    standoff_m: float
    reach_m: float
    assembled_later: set[str]  # components an ``assemble`` row fixes
    known: dict[str, ComponentFacts] = dataclasses.field(default_factory=dict)
    activities: list[RcanActivity] = dataclasses.field(default_factory=list)
    last_of_row: dict[str, str] = dataclasses.field(default_factory=dict)
    slots: dict[str, Pose] = dataclasses.field(default_factory=dict)
    dropped: set[str] = dataclasses.field(default_factory=set)  # transported and set down at their drop-off, not yet positioned
    on_yard: set[str] = dataclasses.field(default_factory=set)  # known to wait on the yard, untouched by any row yet
    placed_by: dict[str, str] = dataclasses.field(default_factory=dict)  # component -> last activity of the row that put it in place

    def add(self, row) -> None:
        """The RCAN activities of one schedule row (InputError for an activity RCAN does not know, or a row
        without a GlobalId or target position)."""
        if row.activity not in SCHEDULE_DECOMPOSITION:
            raise InputError(f"schedule activity {row.id} has activity {row.activity!r}; RCAN knows "
                             f"{', '.join(SCHEDULE_DECOMPOSITION)}")
        gid = row.global_id
        fact = self._fact(gid)
        target = row.target if row.target is not None else fact.position
        if not gid or target is None:
            raise InputError(f"schedule activity {row.id} needs a GlobalId and a target position "
                             f"(TargetX/Y/Z, or the element's placement in --model) for RCAN")
        if gid not in self.slots:
            self.slots[gid] = Pose(*fact.pick_up) if fact.pick_up is not None else \
                Pose(self.yard[0] + self.yard_spacing_m * len(self.slots), self.yard[1], self.yard[2])
        where = "drop-off" if gid in self.dropped else "yard" if gid in self.on_yard else "in place"
        installs = row.activity == Task.ASSEMBLE or (row.activity == Task.POSITION and gid not in self.assembled_later)
        kinds, goals, lifts = _row_activities(row.activity, self.slots[gid], Pose(*target), self.standoff_m, where,
                                              installs, self.reach_m)
        self.on_yard.discard(gid)
        if row.activity == Task.TRANSPORT:
            self.dropped.add(gid)
        else:
            self.dropped.discard(gid)  # positioned (PositionFixed) or installed
        previous = tuple(self.last_of_row[p] for p in row.predecessors)
        if where == "in place" and gid in self.placed_by and self.placed_by[gid] not in previous:
            # Work on a component in place waits for the row that put it there: a beam's two per-node
            # position rows both wait for its transport, not for each other, yet the second works on
            # the beam where the first installs it.
            previous += (self.placed_by[gid],)
        work_points = _work_points(row, self.slots[gid], Pose(*target), where)
        for n, kind in enumerate(kinds, start=1):
            activity_id = f"{row.id}.{n}"
            frees = (kind is K.TRANSPORT and row.activity == Task.TRANSPORT) or \
                (row.activity == Task.POSITION and kind is K.POSITION_FOR_INSTALLING)
            self.activities.append(RcanActivity(
                activity_id=activity_id, component_id=gid, kind=kind, target=goals[kind],
                weight_kg=fact.weight_kg, section_m=fact.section_m, size_m=fact.size_m, robot=row.robot,
                predecessors=previous,
                start=row.start, finish=row.finish, name=f"{kind.label} {gid}",
                frees_robot=True if frees and not installs else None, lifts=lifts,
                task=Task(row.activity), nodes=row.nodes, points=row.points, work_point=work_points.get(kind),
                loads=where != "drop-off",
            ))
            previous = (activity_id,)
        self.last_of_row[row.id] = previous[0]
        if where != "in place" and row.activity != Task.TRANSPORT:
            self.placed_by[gid] = previous[0]

    def _fact(self, gid: str | None) -> ComponentFacts:
        """What is known of component ``gid`` (looked up once; one that starts OnYard waits on the yard)."""
        if gid and gid not in self.known:
            self.known[gid] = self.facts(gid)
            if self.known[gid].start_state == "OnYard":
                self.on_yard.add(gid)
        return self.known.get(gid, ComponentFacts())


def _work_points(row, slot: Pose, installed: Pose, where: str) -> dict[ActivityKind, Pose]:
    """Where each drive of a row ends in the one time model (:mod:`bimrobot.sco.timing`): the points the
    robot works at, as `simulate` drives between them. A transport goes from the pick-up on the yard to
    the installed position; a positioning or an assembly goes to the row's work point (its node or joint;
    the schedule's From columns). A row without them (a schedule of another tool) leaves the drives to
    the stand poses (an empty mapping)."""
    if row.activity == Task.TRANSPORT:
        if row.work_from is None:
            return {}
        # the time model's pick-up is the schedule's (the site's yard position); the component itself
        # lies at ``slot`` (the world package's yard pose, where a physical robot grips it)
        return {K.MOVE_TO_COMPONENT: Pose(*row.work_from), K.TRANSPORT: Pose(*row.work_to) if row.work_to else installed}
    if row.work_from is None or where == "yard":
        return {}
    return {K.MOVE_TO_COMPONENT: Pose(*row.work_from)}


def _robot_order(activities: list[RcanActivity], rows, last_of_row: dict[str, str]) -> list[RcanActivity]:
    """Each row's first activity follows (``after``) the last activity of the previous row the schedule
    gives the same robot, so a robot does its work in the schedule's order whatever order the results of
    other robots come in (the times do not depend on threads). A soft order: a failed row does not
    block the robot's later ones."""
    previous_row: dict[str, str] = {}
    robot_rows: dict[str, list] = {}
    for row in rows:
        if row.robot:
            robot_rows.setdefault(row.robot, []).append(row)
    for ordered in robot_rows.values():
        ordered.sort(key=lambda r: (r.start, r.finish, r.id))
        for before, row in zip(ordered, ordered[1:]):
            previous_row[row.id] = before.id
    out = []
    for activity in activities:
        row_id, _, number = activity.activity_id.rpartition(".")
        before = previous_row.get(row_id)
        if number == "1" and before is not None and last_of_row[before] not in activity.predecessors:
            activity = dataclasses.replace(activity, after=(last_of_row[before],))
        out.append(activity)
    return out


def _row_activities(activity: str, slot: Pose, installed: Pose, standoff_m: float, where: str,
                    installs: bool, reach_m: float = WITHIN_REACH_M) -> tuple[tuple[ActivityKind, ...], dict[ActivityKind, Pose], bool]:
    """(RCAN activity kinds, goal pose of each kind, whether a robot lifts the component) of one row.

    ``slot`` is the component's pick-up position on the yard, ``installed`` its installed position
    (world frame, m); ``where`` the component is: ``yard``, ``drop-off`` (it was transported and rests
    at its drop-off point: the transport's stand pose, ``standoff_m`` short in -y of the installed
    position, on the ground) or ``in place``; ``installs``: the row ends with an install; ``reach_m``:
    how far apart (horizontally) a yard pick-up and its installed position may be for one stand midway.
    """
    stand = Pose(installed.x, installed.y - standoff_m, 0.0)
    goals = {
        K.MOVE_TO_COMPONENT: Pose(slot.x, slot.y - standoff_m, 0.0),
        K.POSITION_FOR_PICKING_UP: slot,
        K.PICK_UP: slot,
        K.TRANSPORT: stand,  # the robot sets the component down here and is free again
        K.POSITION_FOR_INSTALLING: installed,
        K.INSTALL: installed,
    }
    if activity == Task.TRANSPORT:
        return SCHEDULE_DECOMPOSITION[Task.TRANSPORT], goals, True
    install = (K.INSTALL,) if installs else ()
    pick = (K.MOVE_TO_COMPONENT, K.POSITION_FOR_PICKING_UP, K.PICK_UP, K.POSITION_FOR_INSTALLING)
    if where == "yard" and slot.distance_xy(installed) <= reach_m:  # one stand midway reaches both
        goals[K.MOVE_TO_COMPONENT] = Pose((slot.x + installed.x) / 2, (slot.y + installed.y) / 2, 0.0)
        return pick + install, goals, True
    if where == "yard":  # the robot fetches it, carries it over and installs it without letting go
        return pick[:3] + (K.TRANSPORT, K.POSITION_FOR_INSTALLING) + install, goals, True
    goals[K.MOVE_TO_COMPONENT] = stand
    if where == "drop-off":  # a robot picks it up again at the drop-off point and positions it
        goals[K.POSITION_FOR_PICKING_UP] = goals[K.PICK_UP] = stand
        return pick + install, goals, True
    # in place already (a footing, a prebuilt slab, a further connection node): a robot works on it there
    return (K.MOVE_TO_COMPONENT, K.POSITION_FOR_INSTALLING) + install, goals, False


def plan_from_graph(graph, yard: tuple[float, float, float] = (-10.0, -10.0, 0.0), yard_spacing_m: float = 2.0,
                    standoff_m: float = 0.6) -> list[RcanActivity]:
    """RCAN activities generated from the construction graph alone (thesis l.5779-5790): the schedule's
    activities and every property the plan needs (the robot assigned, the component, its starting
    state, weight, size, goal and pick-up position) are selected with SPARQL (``lbd/queries/rcan_plan.rq``)
    and broken down as :func:`plan_from_schedule` does. ``graph``: a
    :class:`bimrobot.lbd.graph.ConstructionGraph` with a schedule (``bimrobot graph --schedule``)."""
    from bimrobot.core.tasks import Activity
    from bimrobot.schedule.schedule import Schedule

    rows = graph.query("rcan_plan")
    if not rows:
        raise InputError("the construction graph has no scheduled activities (brc:activityType): build it with "
                         "`bimrobot graph model.ifc --schedule schedule.csv`")
    activities, facts = [], {}
    for row in rows:
        gid = row["globalId"]
        if gid and gid not in facts:
            facts[gid] = _graph_facts(row)
        target = _xyz(row, "target")
        activities.append(Activity(
            id=str(row["activityId"]), name=str(row["name"] or ""), activity=str(row["activityType"]), global_id=gid,
            robot=row["robot"], start=float(row["start"]), finish=float(row["finish"]),
            predecessors=tuple(sorted(str(row["predecessors"] or "").split())), target=target, node_id=row["nodeId"],
            work_from=_xyz(row, "work"), work_to=_xyz(row, "workEnd") or _xyz(row, "work"),
            nodes=_count(row, "nodes"), points=_count(row, "points")))
    missing = sorted({p for a in activities for p in a.predecessors} - {a.id for a in activities})
    if missing:
        raise InputError(f"the construction graph's activities name predecessor(s) it does not schedule: {', '.join(missing[:5])}")
    return plan_from_schedule(Schedule(activities), None, yard, yard_spacing_m, standoff_m,
                              facts=lambda gid: facts.get(gid, ComponentFacts()))


def _xyz(row: dict, prefix: str) -> tuple[float, float, float] | None:
    values = [row.get(f"{prefix}{axis}") for axis in "XYZ"]
    return None if any(v is None for v in values) else tuple(float(v) for v in values)


def _count(row: dict, key: str) -> int | None:
    return None if row.get(key) is None else int(row[key])


def _graph_facts(row: dict) -> ComponentFacts:
    """A component's facts from one ``rcan_plan`` row (its weight, size, pick-up position, state)."""
    size = _xyz(row, "size")
    section = None if size is None else tuple(round(v, 4) for v in sorted(size)[:2])
    weight = row.get("weightKg")
    return ComponentFacts(None if weight is None else float(weight), section, None, _xyz(row, "pickUp"),
                          row.get("componentState"), None if size is None else tuple(round(v, 4) for v in sorted(size)))


def unknown_weight_components(activities: list[RcanActivity]) -> list[str]:
    """The components a robot lifts in the plan whose weight is unknown (no payload can be checked)."""
    return list(dict.fromkeys(a.component_id for a in activities if a.weight_kg is None and a.lifts))


@dataclass(frozen=True)
class Experiment:
    """One of the thesis' three RCAN experiments (section 5.3.3)."""

    number: int
    title: str
    activities: tuple[RcanActivity, ...]


#: The experiments' components (the column's GlobalId is the one the thesis prints).
COLUMN_ID, FOOTING_ID = RCAN_EXPERIMENTS[1][1], RCAN_EXPERIMENTS[3][1]


@functools.lru_cache(maxsize=3)
def experiment(number: int) -> Experiment:
    """Experiment 1 (column within the manipulator's reach), 2 (column that needs transport) or 3
    (footing that needs transport), generated as any build is: the experiment's IFC model
    (:func:`bimrobot.bim.examples.rcan_experiment`) and a one-row schedule (assemble the component, by the
    thesis' Husky + UR5, ``husky_ur5``) make a construction graph with the component's pick-up position
    on the yard, and RCAN's activities are selected from the graph (:func:`plan_from_graph`). Whether the
    robot has to transport the component follows from the positions, not from the experiment's number.
    Poses in metres, world frame; the robot's home is (-3, 0, 0) (the built-in rcan-robots fleet)."""
    import tempfile
    from pathlib import Path

    from bimrobot.bim import load_model
    from bimrobot.bim.examples import rcan_experiment
    from bimrobot.lbd.graph import build_graph
    from bimrobot.core.tasks import Activity
    from bimrobot.schedule.schedule import Schedule

    if number not in RCAN_EXPERIMENTS:
        raise InputError(f"there is no experiment {number}: the thesis has experiments 1, 2 and 3")
    title, global_id, _, _, _, _, pick_up, installed = RCAN_EXPERIMENTS[number]
    with tempfile.TemporaryDirectory(prefix="bimrobot-experiment-") as folder:
        model = load_model(rcan_experiment(number, Path(folder) / f"experiment{number}.ifc"))
    row = Activity(f"E{number}", f"{Task.ASSEMBLE.title} {global_id}", Task.ASSEMBLE, global_id, "husky_ur5", 0.0, 0.0, (), installed)
    graph = build_graph(model, Schedule([row]), pick_up={global_id: pick_up})
    return Experiment(number, title, tuple(plan_from_graph(graph)))
