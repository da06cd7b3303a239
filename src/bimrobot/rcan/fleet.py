"""The fleet RCAN runs with: THE fleet (:mod:`bimrobot.site.fleet`) placed in the model frame.

RCAN's robot is the fleet's :class:`~bimrobot.site.fleet.RobotSpec`; its RCAN views (the activities
it performs, its payload, handling times and arm speed) are that class's properties. This module adds
what only RCAN needs:

- :data:`TABLE_5_2`: robot type -> the activities it performs (thesis Table 5.2);
- :func:`place_fleet`: every robot's home as [x, y, z] in the model frame (the IFC's world frame, where
  RCAN's goals are). A fleet's homes are site positions (:mod:`bimrobot.site.site`) unless the fleet says
  ``home_frame: model``; a home ``h`` on the site is at ``h - offset`` in the model frame, with ``offset``
  the model -> site translation `simulate` uses (:func:`model_offset_of`). A robot without a home starts
  at the site's robot homes in turn. Without the offset a georeferenced model (thousands of kilometres
  from the IFC origin) would have its robots start on the far side of the planet;
- :func:`fleet_from_capability_table`: RCAN's older capability table (``robot_types`` and ``robots`` with
  ``payload_kg``, ``reach_m``, ``speed_m_s``, ``arm_speed_m_s``, ``handling_s``, ``gripper_opening_m``,
  ``home``, ``footprint_m``) read as a fleet, with one warning: each robot becomes a mobile manipulator
  that carries (in its gripper, no platform) and lifts its ``payload_kg``, loads in ``handling_s.pick_up`` and installs a node or point
  in ``handling_s.install``, performing the activities of its types; its home stays in the model frame.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from bimrobot.core.config import check_keys, line_of
from bimrobot.site.fleet import (BUILTIN_FLEETS, Fleet, RobotSpec, fleet_from_dict, load_fleet,
                                         warn_old_format)
from bimrobot.core.errors import InputError
from bimrobot.rcan.activities import ActivityKind, RcanActivity
from bimrobot.core.schema import At, Coordinates, Custom, Ordered, Quantity, keys_of, quantities_of, read_keys, rule
from bimrobot.site.site import Site, default_site

#: The built-in fleet RCAN runs with when it is given none (husky_ur5, heavy_mobile_manipulator, site_crane).
DEFAULT_FLEET = "rcan-robots"

#: Thesis Table 5.2: which robot type performs which construction activity.
TABLE_5_2: dict[str, frozenset[ActivityKind]] = {
    "mobile_base": frozenset({ActivityKind.MOVE_TO_COMPONENT, ActivityKind.TRANSPORT}),
    "manipulator": frozenset({ActivityKind.POSITION_FOR_PICKING_UP, ActivityKind.POSITION_FOR_INSTALLING}),
    "gripper": frozenset({ActivityKind.PICK_UP, ActivityKind.INSTALL}),
}


def types_for(kind: ActivityKind) -> list[str]:
    """The Table 5.2 robot types able to perform ``kind``."""
    return sorted(name for name, kinds in TABLE_5_2.items() if kind in kinds)


def activities_of(robot: RobotSpec) -> frozenset[ActivityKind]:
    """The RCAN activities ``robot`` performs."""
    return frozenset(ActivityKind) if robot.rcan_activities is None else frozenset(map(ActivityKind, robot.rcan_activities))


def place_fleet(fleet: Fleet, site: Site | None = None, model_offset=(0.0, 0.0)) -> Fleet:
    """``fleet`` with every robot's home as (x, y, z) in the model frame (module docstring): a site-frame
    home (the robot's own, else ``site``'s robot homes in turn, default fig. 4.11) moved by
    ``-model_offset`` (model -> site, metres); a model-frame home kept (none: the origin)."""
    if fleet.home_frame == "model":
        robots = tuple(replace(r, home_m=tuple(float(v) for v in (*(r.home_m or (0.0, 0.0)), 0.0)[:3]))
                       for r in fleet.robots)
        return replace(fleet, robots=robots)
    site = site or default_site()
    offset = np.asarray(model_offset, dtype=float)
    robots = []
    for index, robot in enumerate(fleet.robots):
        home = site.robot_start(index, robot.home_m)
        x, y = site.to_model(np.asarray(home[:2], dtype=float), offset)
        z = float(home[2]) if len(home) > 2 else 0.0
        robots.append(replace(robot, home_m=(float(x), float(y), z)))
    return replace(fleet, robots=tuple(robots), home_frame="model")


def model_offset_of(activities: Iterable[RcanActivity], site: Site) -> tuple[float, float]:
    """Model -> site translation (x, y), metres, for a plan: the site's ``model_offset``, or the one that
    centres the plan's installs (where the building's components go) in the construction area, as
    `simulate` centres the components' target positions."""
    installs = [(a.target.x, a.target.y) for a in activities if a.kind is ActivityKind.INSTALL]
    dx, dy = site.offset_for_points(installs)
    return float(dx), float(dy)


def load_rcan_fleet(spec=None, data: object | None = None, source: str | None = None, site: Site | None = None,
                    model_offset=(0.0, 0.0)) -> Fleet:
    """The placed fleet (:func:`place_fleet`) of a built-in fleet name or fleet file of any version
    (``spec``; None: :data:`DEFAULT_FLEET`), or of already parsed fleet data (``data``, named ``source``)."""
    if data is not None:
        fleet = fleet_from_dict(data, source or str(spec))
    else:
        fleet = load_fleet(DEFAULT_FLEET if spec is None else spec)
    return place_fleet(fleet, site, model_offset)


# ---------------------------------------------------------------- RCAN's older capability table
#: Physical ranges of a robot's numbers in a capability table, declared on :class:`CapabilityRobot`.
#: The largest land cranes lift about 5,000 t and reach about 250 m; nothing on a site drives faster
#: than a road vehicle (20 m/s); a gripper takes less than a day per pick-up or install.
HANDLING_S = Quantity(0.0, 86400.0, "s")


def _handling(value, at: At) -> dict:
    """``handling_s``: RCAN activity name -> seconds (empty or null: none)."""
    if not value:
        return {}
    if not isinstance(value, dict):
        raise at.fail("must map activity names (pick_up, install, ...) to seconds")
    seconds = {}
    for key in value:
        try:
            kind = ActivityKind.parse(str(key))
        except ValueError as exc:
            raise InputError(f"{at.source}{line_of(value, key) or at.line}: {at.where}: handling_s: {exc}") from None
        seconds[kind] = HANDLING_S.read(value[key], replace(at, line=line_of(value, key), where=f"{at.where} handling_s", key=str(key)))
    return seconds


@dataclass(frozen=True)
class CapabilityRobot:
    """The keys of one robot of a capability table (metres, seconds, kg, m/s; ``home`` [x, y, z] in the
    model frame); ``types`` is checked against the table's ``robot_types`` before (its messages name them)."""

    types: tuple = field(metadata=rule(Custom(lambda value, at: value)))
    home: tuple = field(default=(0.0, 0.0, 0.0), metadata=rule(Coordinates(3, -1.0e7, 1.0e7)))
    handling_s: dict = field(default_factory=dict, metadata=rule(Custom(_handling)))
    gripper_opening_m: tuple | None = field(default=None, metadata=rule(Ordered(Coordinates(2, 0.0, 20.0))))
    payload_kg: float = field(default=0.0, metadata=rule(Quantity(0.0, 5.0e6, "kg")))
    footprint_m: tuple | None = field(default=None, metadata=rule(Coordinates(2, 0.05, 100.0)))
    speed_m_s: float = field(default=1.0, metadata=rule(Quantity(0.0, 20.0, "m/s", low_open=True)))
    reach_m: float = field(default=0.0, metadata=rule(Quantity(0.0, 250.0, "m")))
    arm_speed_m_s: float = field(default=0.5, metadata=rule(Quantity(0.0, 10.0, "m/s", low_open=True)))


#: The keys of a robot entry of a capability table, and the ranges of its numbers (low, high, unit).
ROBOT_KEYS = keys_of(CapabilityRobot)
ROBOT_RANGES = quantities_of(CapabilityRobot)


def fleet_from_capability_table(data: object, source: str = "capability table") -> Fleet:
    """A fleet (homes in the model frame) from RCAN's older capability table, validated; one warning."""
    if not isinstance(data, dict) or not isinstance(data.get("robot_types"), dict):
        raise InputError(f"{source}: expected a mapping with 'robot_types' and 'robots'")
    if not isinstance(data.get("robots"), dict) or not data["robots"]:
        raise InputError(f"{source}{line_of(data, 'robots')}: 'robots' must map at least one robot name to its specification")
    check_keys(data, ("robot_types", "robots"), source)
    robot_types: dict[str, frozenset[ActivityKind]] = {}
    for type_name, entry in data["robot_types"].items():
        activities = (entry or {}).get("activities") if isinstance(entry, dict) else None
        where = f"{source}{line_of(data['robot_types'], type_name)}: robot_types.{type_name}"
        if isinstance(entry, dict):
            check_keys(entry, ("activities",), source, f"robot_types.{type_name}")
        if not isinstance(activities, list):
            raise InputError(f"{where}.activities must be a list of activity names")
        try:
            robot_types[str(type_name)] = frozenset(ActivityKind.parse(str(a)) for a in activities)
        except ValueError as exc:
            raise InputError(f"{where}: {exc}") from None
    robots = tuple(_table_robot(str(name), entry, robot_types, source, line_of(data["robots"], name))
                   for name, entry in data["robots"].items())
    warn_old_format(source, "an RCAN capability table", "robot_types -> rcan_activities, payload_kg -> carry_kg "
                    "and lift_kg, handling_s pick_up -> load_s, install -> time_per_node_s and time_per_point_s, "
                    "home -> home_m (home_frame: model)")
    return Fleet(name=Path(source).stem, robots=robots, source=source, home_frame="model")


def _table_robot(name: str, entry: object, robot_types: dict, source: str, line: str = "") -> RobotSpec:
    where = f"{source}{line}: robots.{name}"
    if not isinstance(entry, dict):
        raise InputError(f"{where} must be a mapping")
    types = entry.get("types")
    if not isinstance(types, list) or not types:
        raise InputError(f"{where}.types must list the robot types it integrates")
    unknown = [t for t in types if not isinstance(t, str) or t not in robot_types]
    if unknown:
        raise InputError(f"{where}.types names unknown robot type {unknown[0]!r} (known: {', '.join(robot_types)})")
    read = read_keys(entry, CapabilityRobot, At(source, line, f"robot '{name}'"))
    spec = CapabilityRobot(**{key: value for key, value in read.items() if value is not None})
    activities = frozenset().union(*(robot_types[t] for t in types))
    install = spec.handling_s.get(ActivityKind.INSTALL, 0.0)
    return RobotSpec(
        name=name, kind="mobile_manipulator", speed_m_s=spec.speed_m_s, carry_kg=spec.payload_kg,
        lift_kg=spec.payload_kg, reach_m=spec.reach_m, time_per_node_s=install, time_per_point_s=install,
        load_s=spec.handling_s.get(ActivityKind.PICK_UP, 0.0), arm_speed_m_s=spec.arm_speed_m_s,
        gripper_opening_m=spec.gripper_opening_m, footprint_m=spec.footprint_m, home_m=spec.home,
        rcan_activities=None if activities == frozenset(ActivityKind) else frozenset(k.value for k in activities),
    )


__all__ = ["BUILTIN_FLEETS", "DEFAULT_FLEET", "TABLE_5_2", "activities_of", "fleet_from_capability_table",
           "load_rcan_fleet", "model_offset_of", "place_fleet", "types_for"]
