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

RCAN's older capability table is read as a fleet by the fleet format itself
(:func:`bimrobot.site.fleet.fleet_from_capability_table`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import numpy as np

from bimrobot.core.tasks import ActivityKind
from bimrobot.rcan.activities import RcanActivity
from bimrobot.site.fleet import BUILTIN_FLEETS, Fleet, RobotSpec, fleet_from_dict, load_fleet
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


__all__ = ["BUILTIN_FLEETS", "DEFAULT_FLEET", "TABLE_5_2", "activities_of", "load_rcan_fleet", "model_offset_of",
           "place_fleet", "types_for"]
