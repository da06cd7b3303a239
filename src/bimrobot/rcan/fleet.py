"""The fleet RCAN runs with: THE fleet (:mod:`bimrobot.coordination.fleet`) placed in the model frame.

RCAN's robot is the fleet's :class:`~bimrobot.coordination.fleet.RobotSpec`; its RCAN views (the activities
it performs, its payload, handling times and arm speed) are that class's properties. This module adds
what only RCAN needs:

- :data:`TABLE_5_2`: robot type -> the activities it performs (thesis Table 5.2);
- :func:`place_fleet`: every robot's home as [x, y, z] in the model frame (the IFC's world frame, where
  RCAN's goals are). A fleet's homes are site positions (:mod:`bimrobot.site`) unless the fleet says
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

import math
from collections.abc import Iterable
from dataclasses import replace
from pathlib import Path

import numpy as np

from bimrobot.config import check_keys, line_of
from bimrobot.config import number as config_number
from bimrobot.coordination.fleet import (BUILTIN_FLEETS, Fleet, RobotSpec, fleet_from_dict, load_fleet,
                                         warn_old_format)
from bimrobot.errors import InputError
from bimrobot.rcan.activities import ActivityKind, RcanActivity
from bimrobot.site import Site, default_site

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
#: Physical ranges of a robot's numbers in a capability table: key -> (low, high, low inclusive, unit).
#: The largest land cranes lift about 5,000 t and reach about 250 m; nothing on a site drives faster
#: than a road vehicle (20 m/s); a gripper takes less than a day per pick-up or install.
ROBOT_RANGES = {
    "payload_kg": (0.0, 5.0e6, True, "kg"),
    "reach_m": (0.0, 250.0, True, "m"),
    "speed_m_s": (0.0, 20.0, False, "m/s"),
    "arm_speed_m_s": (0.0, 10.0, False, "m/s"),
}
#: The keys of a robot entry of a capability table.
ROBOT_KEYS = ("types", *ROBOT_RANGES, "handling_s", "gripper_opening_m", "home", "footprint_m")
HANDLING_RANGE_S = (0.0, 86400.0)
GRIPPER_RANGE_M = (0.0, 20.0)
FOOTPRINT_RANGE_M = (0.05, 100.0)
HOME_RANGE_M = 1.0e7


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


def _coordinates(entry: dict, key: str, source: str, robot: str, line: str, count: int, low: float, high: float,
                 default: list | None = None) -> tuple[float, ...] | None:
    """``entry[key]`` as ``count`` numbers in metres, each in ``[low, high]``; None when absent and no
    default. ``line``: the robot's line, used when the key's own is unknown."""
    value = entry.get(key, default)
    if value is None:
        value = default  # 'home:' with nothing after it: as if absent
    if value is None:
        return None
    label = f"{source}{line_of(entry, key) or line}: robot '{robot}': key '{key}'"
    if not (isinstance(value, list) and len(value) == count
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        raise InputError(f"{label} must be a list of {count} numbers in metres, got {value!r}")
    if not all(low <= v <= high and math.isfinite(v) for v in value):
        raise InputError(f"{label} must hold numbers between {low:g} and {high:g} m, got {value!r}")
    return tuple(float(v) for v in value)


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
    robot = f"robot '{name}'"
    check_keys(entry, ROBOT_KEYS, source, robot)

    def number(key: str, default: float) -> float:
        low, high, inclusive, unit = ROBOT_RANGES[key]
        return config_number(entry, key, source, low=low, high=high, low_inclusive=inclusive, unit=unit,
                             default=default, where=robot)

    home = _coordinates(entry, "home", source, name, line, 3, -HOME_RANGE_M, HOME_RANGE_M, [0.0, 0.0, 0.0])
    handling = entry.get("handling_s", {}) or {}
    if not isinstance(handling, dict):
        raise InputError(f"{source}{line_of(entry, 'handling_s') or line}: {robot}: key 'handling_s' must map "
                         "activity names (pick_up, install, ...) to seconds")
    handling_s = {}
    for key in handling:
        try:
            kind = ActivityKind.parse(str(key))
        except ValueError as exc:
            raise InputError(f"{source}{line_of(handling, key) or line}: {robot}: handling_s: {exc}") from None
        handling_s[kind] = config_number(handling, key, source, low=HANDLING_RANGE_S[0], high=HANDLING_RANGE_S[1],
                                         unit="s", where=f"{robot} handling_s")
    opening = _coordinates(entry, "gripper_opening_m", source, name, line, 2, *GRIPPER_RANGE_M)
    if opening is not None and opening[0] > opening[1]:
        raise InputError(f"{source}{line_of(entry, 'gripper_opening_m') or line}: {robot}: key 'gripper_opening_m' "
                         f"must be [min, max] with min <= max, got {list(opening)}")
    activities = frozenset().union(*(robot_types[t] for t in types))
    payload = number("payload_kg", 0.0)
    install = handling_s.get(ActivityKind.INSTALL, 0.0)
    footprint = _coordinates(entry, "footprint_m", source, name, line, 2, *FOOTPRINT_RANGE_M)
    return RobotSpec(
        name=name, kind="mobile_manipulator", speed_m_s=number("speed_m_s", 1.0), carry_kg=payload, lift_kg=payload,
        reach_m=number("reach_m", 0.0), time_per_node_s=install,
        time_per_point_s=install, load_s=handling_s.get(ActivityKind.PICK_UP, 0.0),
        arm_speed_m_s=number("arm_speed_m_s", 0.5), gripper_opening_m=opening, footprint_m=footprint, home_m=home,
        rcan_activities=None if activities == frozenset(ActivityKind) else frozenset(k.value for k in activities),
    )


__all__ = ["BUILTIN_FLEETS", "DEFAULT_FLEET", "TABLE_5_2", "activities_of", "fleet_from_capability_table",
           "load_rcan_fleet", "model_offset_of", "place_fleet", "types_for"]
