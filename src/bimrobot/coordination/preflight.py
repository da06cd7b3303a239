"""Pre-flight of a simulated build: can the fleet do every task the building asks for?

:func:`check_capabilities` raises ONE :class:`~bimrobot.core.errors.InputError` listing everything the
fleet cannot do, grouped by IFC class with the capacity it would need (mass in kg, platform length x
width in metres, reach in metres above the floor the robot stands on), and what the fleet has. ``sim`` is
the :class:`~bimrobot.coordination.simulation.ConstructionSimulation` being set up (its ``fleet``,
``smart``, ``request_for`` and ``joints_to_build``); not imported here, which would be a circle.
"""

from __future__ import annotations

from bimrobot.coordination.market import TaskRequest, incapability
from bimrobot.core.errors import InputError
from bimrobot.core.tasks import Task
from bimrobot.site.fleet import ACTIVITIES, Fleet, RobotSpec


def distinct_robots(fleet: Fleet) -> dict[str, list[RobotSpec]]:
    """Activity -> one robot of each set of abilities (robots with the same abilities answer alike)."""
    distinct: dict[str, list[RobotSpec]] = {}
    for activity in ACTIVITIES:
        seen = {}
        for r in fleet.by_activity(activity):
            seen.setdefault((r.kind, r.carry_kg, r.platform_m, r.lift_kg, r.reach_m, r.methods), r)
        distinct[activity] = list(seen.values())
    return distinct


def _impossible(distinct: dict[str, list[RobotSpec]], request: TaskRequest) -> bool:
    return all(incapability(r, request) for r in distinct[request.activity])


def _component_needs(sim, distinct: dict[str, list[RobotSpec]], to_build: list) -> dict[str, dict]:
    """IFC class -> the components no robot can carry or position, with the worst need per activity."""
    by_class: dict[str, dict] = {}
    for component in to_build:
        for activity in (Task.TRANSPORT, Task.POSITION):
            request = sim.request_for(activity, component)
            if not _impossible(distinct, request):
                continue
            need = by_class.setdefault(component.what, {"ids": set(), Task.TRANSPORT: None, Task.POSITION: None})
            need["ids"].add(component.id)
            worst = need[activity] or {"kg": 0.0, "length": 0.0, "width": 0.0, "reach": 0.0, "example": component.id}
            if request.weight_kg > worst["kg"]:
                worst["example"] = component.id
            worst["kg"] = max(worst["kg"], request.weight_kg)
            worst["length"] = max(worst["length"], request.size[0])
            worst["width"] = max(worst["width"], request.size[1])
            worst["reach"] = max(worst["reach"], request.reach_needed)
            need[activity] = worst
    return by_class


def _joint_needs(sim, distinct: dict[str, list[RobotSpec]], joints: list) -> tuple[list[str], float, set]:
    """The joints no robot can assemble, the most reach they need (m) and their assembly methods."""
    failing_joints, joint_reach, joint_methods = [], 0.0, set()
    for joint in joints:
        owner = sim.smart.components[joint.component_ids[0]]
        request = sim.request_for(Task.ASSEMBLE, owner, joint)
        if _impossible(distinct, request):
            failing_joints.append(joint.id)
            joint_reach = max(joint_reach, request.reach_needed)
            joint_methods |= set(request.methods)
    return failing_joints, joint_reach, joint_methods


def _class_parts(by_class: dict[str, dict]) -> list[str]:
    """One phrase per IFC class: how many need what, with an example."""
    parts = []
    for ifc_class, need in sorted(by_class.items(), key=lambda item: (-len(item[1]["ids"]), item[0])):
        wants = []
        if need[Task.TRANSPORT]:
            t = need[Task.TRANSPORT]
            wants.append(f"a carrier for up to {t['kg']:,.0f} kg and {t['length']:.2f} x {t['width']:.2f} m")
        if need[Task.POSITION]:
            q = need[Task.POSITION]
            wants.append(f"a positioner for up to {q['kg']:,.0f} kg at {q['reach']:.2f} m reach")
        example = (need[Task.TRANSPORT] or need[Task.POSITION])["example"]
        count = len(need["ids"])
        parts.append(f"{count} {ifc_class} need{'s' if count == 1 else ''} {' and '.join(wants)} (e.g. {example})")
    return parts


def check_capabilities(sim) -> None:
    """Pre-flight: every component and joint of ``sim`` must be doable by some robot of its fleet.

    Raises ONE InputError listing everything the fleet cannot do, grouped by IFC class with the
    capacity it would need (mass, platform length x width, reach), and what the fleet has.
    """
    distinct = distinct_robots(sim.fleet)
    to_build = [c for c in sim.smart.components.values() if not c.prebuilt]
    by_class = _component_needs(sim, distinct, to_build)
    joints = sim.joints_to_build()
    failing_joints, joint_reach, joint_methods = _joint_needs(sim, distinct, joints)
    if not by_class and not failing_joints:
        return
    parts = _class_parts(by_class)
    if failing_joints:
        parts.append(
            f"{len(failing_joints)} joints need an assembler with {joint_reach:.2f} m reach doing "
            f"{', '.join(sorted(joint_methods))} (e.g. {failing_joints[0]})"
        )
    stronger = ", e.g. --fleet site-crane" if sim.fleet.name != "site-crane" else ""
    remedy = f"give a stronger fleet{stronger}"
    if any(sim.smart.components[i].part_ids for need in by_class.values() for i in need["ids"]):  # units
        remedy = f"build the units element by element with --by-element, give a fleet with a longer platform and payload{stronger}"
    counts = []
    if by_class:
        counts.append(f"{sum(len(n['ids']) for n in by_class.values())} of {len(to_build)} components")
    if failing_joints:
        counts.append(f"{len(failing_joints)} of {len(joints)} joints")
    raise InputError(
        f"fleet {sim.fleet.name} cannot build {' and '.join(counts)}: {'; '.join(parts)}; "
        f"the fleet {capacity_text(distinct)} ({remedy}, mark cast-in-place "
        "classes as work of others with --prebuilt, or leave elements out with --exclude)"
    )


def capacity_text(distinct: dict[str, list[RobotSpec]]) -> str:
    """What the fleet can do at most, per activity, in words."""
    words = []
    carriers, positioners, assemblers = distinct[Task.TRANSPORT], distinct[Task.POSITION], distinct[Task.ASSEMBLE]
    if carriers:
        decks = [r.platform_m for r in carriers if r.platform_m is not None]
        size = ("of any size in a gripper" if len(decks) < len(carriers) else
                f"on up to {max(d[0] for d in decks):g} x {max(d[1] for d in decks):g} m")
        words.append(f"carries at most {max(r.carry_kg for r in carriers):,.0f} kg {size}")
    else:
        words.append("has no transport robot")
    if positioners:
        words.append(
            f"positions at most {max(r.lift_kg for r in positioners):,.0f} kg with up to "
            f"{max(r.reach_m for r in positioners):g} m reach"
        )
    else:
        words.append("has no positioning robot")
    if assemblers:
        methods = sorted({m for r in assemblers for m in r.methods})
        words.append(f"assembles with up to {max(r.reach_m for r in assemblers):g} m reach ({', '.join(methods)})")
    else:
        words.append("has no assembly robot")
    return ", ".join(words[:-1]) + " and " + words[-1]
