"""Plans of RCAN activities: from a schedule CSV (+ BuildingModel) and the thesis' three experiments.

A schedule row is broken down into RCAN activities (see :mod:`bimrobot.rcan.activities`) with goal
poses: components wait on the yard (one slot per component, ``yard_spacing_m`` apart along x from
``yard``), the robot's base stops ``standoff_m`` short (in -y) of the pick-up slot and of the installed
position, and the gripper goes to the slot and to the installed position (``Target*`` of the row).
"""

from __future__ import annotations

from dataclasses import dataclass

from bimrobot.errors import InputError
from bimrobot.lbd import components
from bimrobot.rcan.activities import SCHEDULE_DECOMPOSITION, ActivityKind, Pose, RcanActivity

K = ActivityKind


def plan_from_schedule(schedule, model=None, yard: tuple[float, float, float] = (-10.0, -10.0, 0.0),
                       yard_spacing_m: float = 2.0, standoff_m: float = 0.6) -> list[RcanActivity]:
    """RCAN activities for every row of ``schedule`` (a :class:`bimrobot.lbd.schedule.Schedule`).

    A row without a target position (an IFC work schedule's task) goes to its component's position
    in ``model`` (an element's placement origin; see :mod:`bimrobot.lbd.components` for an assembly).

    ``model`` (a BuildingModel, with :func:`bimrobot.bim.unknown_weight.apply_unknown_weight_rule`
    already applied) supplies component weights (kg; the allocator only gives a component to robots
    whose payload carries it) and sections; a component whose weight stays unknown, and every
    component without ``model``, has ``weight_kg`` None: no payload is checked for it, and the run
    reports it. A GlobalId may name an element or an assembly (lifted as one unit: the sum of its
    parts' weights). Ids are ``<Identification>.<n>``; the first activity of a row
    waits for the last one of each predecessor row. A ``position`` or ``assemble`` row of a component no
    robot holds (in place already, e.g. a footing, or a further connection node after the first
    install) starts by moving a robot to it: move to component, position for installing, install. A
    ``transport`` row ends with the component set down at its drop-off point (the transport's stand
    pose) and the robot free: the component's positioning may have to wait for other components, and
    the robot may be needed to bring them. The ``position`` (or ``assemble``) row that follows picks it
    up again there (move to component, position for picking up, pick up, position for installing),
    possibly with another robot. A ``position`` row leaves the component PositionFixed and frees its
    robot (chapter 4: assembly robots fix the connection nodes afterwards).
    """
    activities: list[RcanActivity] = []
    last_of_row: dict[str, str] = {}
    slots: dict[str, Pose] = {}
    dropped: set[str] = set()  # components transported and set down at their drop-off, not yet positioned
    for row in schedule.topological_order():
        if row.activity not in SCHEDULE_DECOMPOSITION:
            raise InputError(f"schedule activity {row.id} has activity {row.activity!r}; RCAN knows "
                             f"{', '.join(SCHEDULE_DECOMPOSITION)}")
        gid = row.global_id
        target = row.target
        if target is None and model is not None and gid and components.is_component(model, gid):
            target = tuple(float(v) for v in components.position(model, gid))  # e.g. an IfcTask's output element
        if not gid or target is None:
            raise InputError(f"schedule activity {row.id} needs a GlobalId and a target position "
                             f"(TargetX/Y/Z, or the element's placement in --model) for RCAN")
        if gid not in slots:
            slots[gid] = Pose(yard[0] + yard_spacing_m * len(slots), yard[1], yard[2])
        kinds, goals, lifts = _row_activities(row.activity, slots[gid], Pose(*target), standoff_m, gid in dropped)
        if row.activity == "transport":
            dropped.add(gid)
        else:
            dropped.discard(gid)  # positioned (PositionFixed) or installed
        weight, section = _weight(model, gid), _section(model, gid)
        previous = tuple(last_of_row[p] for p in row.predecessors)
        for n, kind in enumerate(kinds, start=1):
            activity_id = f"{row.id}.{n}"
            frees = kind is K.TRANSPORT or (row.activity == "position" and kind is K.POSITION_FOR_INSTALLING)
            activities.append(RcanActivity(
                activity_id=activity_id, component_id=gid, kind=kind, target=goals[kind],
                weight_kg=weight, section_m=section, robot=row.robot, predecessors=previous,
                start=row.start, finish=row.finish, name=f"{kind.label} {gid}",
                frees_robot=True if frees else None, lifts=lifts,
            ))
            previous = (activity_id,)
        last_of_row[row.id] = previous[0]
    return activities


def _row_activities(activity: str, slot: Pose, installed: Pose, standoff_m: float,
                    at_drop_off: bool) -> tuple[tuple[ActivityKind, ...], dict[ActivityKind, Pose], bool]:
    """(RCAN activity kinds, goal pose of each kind, whether a robot lifts the component) of one row.

    ``slot`` is the component's yard slot, ``installed`` its installed position (world frame, m);
    ``at_drop_off``: the component was transported and rests at its drop-off point (the transport's
    stand pose, ``standoff_m`` short in -y of the installed position, on the ground).
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
    if activity == "transport":
        return SCHEDULE_DECOMPOSITION["transport"], goals, True
    install = (K.INSTALL,) if activity == "assemble" else ()
    goals[K.MOVE_TO_COMPONENT] = stand
    if at_drop_off:  # a robot picks it up again at the drop-off point and positions it
        goals[K.POSITION_FOR_PICKING_UP] = goals[K.PICK_UP] = stand
        return (K.MOVE_TO_COMPONENT, K.POSITION_FOR_PICKING_UP, K.PICK_UP, K.POSITION_FOR_INSTALLING) + install, goals, True
    # in place already (a footing, a prebuilt slab, a further connection node): a robot works on it there
    return (K.MOVE_TO_COMPONENT, K.POSITION_FOR_INSTALLING) + install, goals, False


def _weight(model, gid: str) -> float | None:
    """The component's weight in kg, or None when unknown (no model, or the model does not give it)."""
    if model is None:
        return None
    if not components.is_component(model, gid):
        raise InputError(f"schedule names component {gid}, which is not in {model.source or 'the model'}")
    return components.weight_kg(model, gid)


def _section(model, gid: str) -> tuple[float, float] | None:
    """The two smaller extents of the component (m): what a gripper closes on; None without a model."""
    if model is None:
        return None
    return components.section_m(model, gid)


def unknown_weight_components(activities: list[RcanActivity]) -> list[str]:
    """The components a robot lifts in the plan whose weight is unknown (no payload can be checked)."""
    return list(dict.fromkeys(a.component_id for a in activities if a.weight_kg is None and a.lifts))


@dataclass(frozen=True)
class Experiment:
    """One of the thesis' three RCAN experiments (section 5.3.3)."""

    number: int
    title: str
    activities: tuple[RcanActivity, ...]


#: The thesis' column (its GlobalId is the one printed in section 5.3.3) and an illustrative footing.
COLUMN_ID = "267VPu8ab9991QBA3MI3UN"
FOOTING_ID = "1kTvXnbbzCWw8lcMd1dR4o"
COLUMN_KG = 2.0  # light-weight scale column, within the UR5's 5 kg payload
FOOTING_KG = 3.5
COLUMN_SECTION_M = (0.04, 0.04)  # the thesis' prototype gripper is sized to the components' sections
FOOTING_SECTION_M = (0.10, 0.10)


def _chain(prefix: str, component: str, weight: float, section: tuple[float, float],
           steps: list[tuple[ActivityKind, Pose]]) -> tuple[RcanActivity, ...]:
    out, previous = [], ()
    for n, (kind, pose) in enumerate(steps, start=1):
        activity_id = f"{prefix}.{n}"
        out.append(RcanActivity(activity_id, component, kind, pose, weight, section_m=section, robot="husky_ur5",
                                predecessors=previous, name=f"{kind.label} {component}"))
        previous = (activity_id,)
    return tuple(out)


def experiment(number: int) -> Experiment:
    """Experiment 1 (column within the manipulator's reach), 2 (column that needs transport) or 3
    (footing that needs transport). The robot is the thesis' Husky + UR5 (``husky_ur5``), home at
    (-3, 0, 0); poses in metres, world frame.
    """
    pick_column = Pose(0.0, -0.75, 0.45)  # the pick-up target printed in the thesis
    stand = Pose(0.0, 0.0, 0.0)
    if number == 1:
        install = Pose(0.55, -0.35, 0.30)  # 0.65 m from the base: within the UR5's reach
        steps = [(K.MOVE_TO_COMPONENT, stand), (K.POSITION_FOR_PICKING_UP, pick_column), (K.PICK_UP, pick_column),
                 (K.POSITION_FOR_INSTALLING, install), (K.INSTALL, install)]
        return Experiment(1, "column within the manipulator's reach", _chain("E1", COLUMN_ID, COLUMN_KG, COLUMN_SECTION_M, steps))
    if number == 2:
        install = Pose(4.0, 2.0, 0.30)  # 4.5 m away: the base has to transport the column
        steps = [(K.MOVE_TO_COMPONENT, stand), (K.POSITION_FOR_PICKING_UP, pick_column), (K.PICK_UP, pick_column),
                 (K.TRANSPORT, Pose(4.0, 2.6, 0.0)), (K.POSITION_FOR_INSTALLING, install), (K.INSTALL, install)]
        return Experiment(2, "column that needs transport", _chain("E2", COLUMN_ID, COLUMN_KG, COLUMN_SECTION_M, steps))
    if number == 3:
        pick_footing = Pose(0.0, -0.75, 0.10)
        install = Pose(4.0, -2.0, 0.0)
        steps = [(K.MOVE_TO_COMPONENT, stand), (K.POSITION_FOR_PICKING_UP, pick_footing), (K.PICK_UP, pick_footing),
                 (K.TRANSPORT, Pose(4.0, -1.4, 0.0)), (K.POSITION_FOR_INSTALLING, install), (K.INSTALL, install)]
        return Experiment(3, "footing that needs transport", _chain("E3", FOOTING_ID, FOOTING_KG, FOOTING_SECTION_M, steps))
    raise InputError(f"there is no experiment {number}: the thesis has experiments 1, 2 and 3")
