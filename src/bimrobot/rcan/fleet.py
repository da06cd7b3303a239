"""One fleet file for `simulate` and RCAN: a chapter-4 fleet read as RCAN's capability table (Table 5.2).

`bimrobot rcan run --capabilities fleet2` (or a fleet YAML file) runs RCAN with the robots the
simulation used, so a schedule written by `simulate` names robots RCAN has. Each robot of the fleet
(:class:`bimrobot.coordination.fleet.RobotSpec`) becomes one RCAN robot:

======================== ==================================================================================
RCAN key                 from the fleet entry
======================== ==================================================================================
types                    ``rcan_types`` if given, else all three Table 5.2 types (mobile base, manipulator,
                         gripper): every chapter-4 robot drives to its work and handles the component or tool
payload_kg               ``carry_load`` (transport), ``payload`` (positioning), the larger of both
                         (mobile manipulator); 0 for an assembly robot, which lifts nothing
reach_m                  ``reach``; a transport robot loads over its platform: half its length
speed_m_s                ``speed``
arm_speed_m_s            0.5 m/s, the built-in RCAN robots' end-effector speed
handling_s               pick up: ``load_time``; install: ``time_per_point`` (assembly) or ``time_per_node``
times                    the robot's speed, load, unload, per-node and per-point times: the one time model
                         (:mod:`bimrobot.sco.timing`) by which the ``sim`` backend takes as long as `simulate`
home                     the robot's ``home``, else the site's robot homes in turn (site frame, z = 0),
                         taken into the model frame (:func:`model_offset_of`)
======================== ==================================================================================

Frames: a fleet's homes are site positions (:mod:`bimrobot.site`), while RCAN's goals are in the model
frame (the IFC's world frame). A home ``h`` is at ``h - offset`` in the model frame, with ``offset`` the
model -> site translation that `simulate` and `convert --layout yard` use: the site's ``model_offset``, or
the one that centres the building in the construction area. Without it a georeferenced model (thousands
of kilometres from the IFC origin) would have its robots start on the far side of the planet.
"""

from __future__ import annotations

from collections.abc import Iterable
from importlib import resources

import numpy as np

from bimrobot.config import parse_yaml
from bimrobot.coordination.fleet import Fleet, RobotSpec as FleetRobot, fleet_from_dict, load_fleet, BUILTIN_FLEETS
from bimrobot.rcan.activities import ActivityKind, Pose, RcanActivity
from bimrobot.rcan.generation import DEFAULT_CAPABILITIES, CapabilityTable, RobotSpec, parse_capabilities
from bimrobot.sco.timing import RobotTimes
from bimrobot.site import Site, default_site
from bimrobot.tasks import Task

#: RCAN's default end-effector speed for fleet robots, m/s (as the built-in capability table's robots).
ARM_SPEED_M_S = 0.5


def is_fleet(data: object) -> bool:
    """Whether parsed YAML is a fleet file (``robots`` is a list of entries with a ``kind``)."""
    return isinstance(data, dict) and isinstance(data.get("robots"), list)


def table_5_2() -> dict[str, frozenset[ActivityKind]]:
    """Robot type -> the activities it performs (thesis Table 5.2), from the built-in capability table."""
    source = f"built-in {DEFAULT_CAPABILITIES}"
    text = resources.files("bimrobot.rcan").joinpath(DEFAULT_CAPABILITIES).read_text()
    return parse_capabilities(parse_yaml(text, source), source).robot_types


def capabilities_from_fleet(fleet: Fleet, site: Site | None = None, model_offset=(0.0, 0.0)) -> CapabilityTable:
    """RCAN's capability table with one robot per fleet robot (mapping in the module docstring).
    ``model_offset``: model -> site translation (x, y) in metres (:func:`model_offset_of`); the fleet's
    site-frame homes are placed at ``home - model_offset`` in the model frame."""
    site = site or default_site()
    types = table_5_2()
    robots = {}
    for index, robot in enumerate(fleet.robots):
        home_on_site = robot.home or site.robot_home[index % len(site.robot_home)]
        home = site.to_model(np.asarray(home_on_site, dtype=float), np.asarray(model_offset, dtype=float))
        robots[robot.name] = _rcan_robot(robot, types, Pose(float(home[0]), float(home[1]), 0.0))
    return CapabilityTable(types, robots, f"fleet {fleet.name} ({fleet.source})")


def model_offset_of(activities: Iterable[RcanActivity], site: Site) -> tuple[float, float]:
    """Model -> site translation (x, y), metres, for a plan: the site's ``model_offset``, or the one that
    centres the plan's installs (where the building's components go) in the construction area, as
    `simulate` centres the components' target positions."""
    installs = [(a.target.x, a.target.y) for a in activities if a.kind is ActivityKind.INSTALL]
    dx, dy = site.offset_for_points(installs)
    return float(dx), float(dy)


def _rcan_robot(robot: FleetRobot, types: dict[str, frozenset[ActivityKind]], home: Pose) -> RobotSpec:
    names = tuple(types)
    payload = {Task.TRANSPORT.robot_kind: robot.carry_load, Task.POSITION.robot_kind: robot.payload,
               Task.ASSEMBLE.robot_kind: 0.0, "mobile_manipulator": max(robot.carry_load, robot.payload)}[robot.kind]
    reach = robot.reach if robot.kind != Task.TRANSPORT.robot_kind else robot.platform_size[0] / 2
    install = robot.time_per_point if robot.kind == Task.ASSEMBLE.robot_kind else robot.time_per_node
    return RobotSpec(
        name=robot.name, types=names, activities=frozenset().union(*types.values()),
        payload_kg=payload, reach_m=reach, speed_m_s=robot.speed, arm_speed_m_s=ARM_SPEED_M_S,
        handling_s={ActivityKind.PICK_UP.value: robot.load_time, ActivityKind.INSTALL.value: install},
        home=home, times=RobotTimes.of_fleet_robot(robot),
    )


def load_fleet_capabilities(spec: str, data: object | None = None, source: str | None = None,
                            site: Site | None = None, model_offset=(0.0, 0.0)) -> CapabilityTable:
    """The capability table of a built-in fleet name or of an already parsed fleet file, its robots'
    homes taken from ``site`` (default fig. 4.11) into the model frame with ``model_offset`` (m)."""
    fleet = load_fleet(spec) if data is None else fleet_from_dict(data, source or str(spec))
    return capabilities_from_fleet(fleet, site, model_offset)


__all__ = ["BUILTIN_FLEETS", "capabilities_from_fleet", "is_fleet", "load_fleet_capabilities", "model_offset_of",
           "table_5_2"]
