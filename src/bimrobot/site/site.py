"""The construction site, described once (thesis fig. 4.11) and read by `convert --layout yard`,
`simulate`, `rcan` and `build`.

Frames: the *site frame* is where the site file's positions are (metres, z up); the *model frame* is the
IFC model's world frame, in which packages, schedules and RCAN goals are written. A model point ``p`` is at
``p[:2] + offset`` on the site, where ``offset`` is the site file's ``model_offset`` or, by default, the
translation that centres the building in the construction area (:meth:`Site.offset_for`).

Keys of a site YAML (each optional; a missing one takes fig. 4.11's value):

``yard``              component pick-up positions [[x, y], ...], used in turn
``robot_home``        robot start positions [[x, y], ...], used in turn (a fleet robot's own ``home`` wins)
``construction_area`` [[xmin, ymin], [xmax, ymax]]: where the building stands
``model_offset``      [dx, dy]: model frame -> site frame (default: centre the building in the area)
``idle_robots``       ``stay`` (default) or ``yard``: a robot without work drives back to the nearest yard position
``assembly_points_per_joint`` bolts or welds assumed for a joint the model gives no fasteners for (default 4,
                      :data:`bimrobot.sco.build.ASSUMED_POINTS_PER_JOINT`; reported as assumed)
``work_calendar``     {days: [Monday, ...], hours: ["07:00", "16:00"]}: when the site works (default Monday-Friday
                      07:00-16:00); the IFC work schedule lays the simulated work onto these hours

Which site a run uses (:func:`site_for`): the site file given with ``--site``; ``--site thesis``, the lab
site of fig. 4.11 (7.5 x 6.5 m construction area, yard at x = 12.5 m, homes at x = 18.5 m); with no
``--site``, fig. 4.11 when the building's footprint fits its construction area (the thesis' frame, the RCAN
experiments), else a site derived from the building (:func:`derive_site`): the construction area is the
footprint plus :data:`AREA_MARGIN_M` on every side, the yard a line of positions east of it (+x), the robot
homes a line south of it (-y), so neither lies on the building. A site file whose yard positions or robot
homes lie on the building's footprint is used as given, with a warning naming them.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from bimrobot.core.config import read_yaml_file
from bimrobot.core.errors import InputError
from bimrobot.site.working_time import WorkCalendar, work_calendar_from
from bimrobot.core.schema import At, Choice, Custom, Integer, Points, Quantity, Rule, Vector, keys_of, read_keys, rule

log = logging.getLogger(__name__)

#: Site positions (yard, homes, construction area) within this many metres of the site origin; the
#: model offset may be as large as projected map coordinates (UTM northings reach 1e7 m).
SITE_COORDINATE_LIMIT_M = 1e6
OFFSET_LIMIT_M = 2e7
#: One site position: [x, y] metres, each within +-SITE_COORDINATE_LIMIT_M (the model offset: OFFSET_LIMIT_M).
POINT = Vector(Quantity(-SITE_COORDINATE_LIMIT_M, SITE_COORDINATE_LIMIT_M, "m"), "a pair of numbers [x, y] in metres")


@dataclass(frozen=True)
class _Area(Rule):
    """``construction_area``: [[xmin, ymin], [xmax, ymax]] site positions with xmin < xmax and ymin < ymax."""

    def read(self, value, at: At) -> tuple[tuple[float, float], tuple[float, float]]:
        if not isinstance(value, list) or len(value) != 2:
            raise at.fail("must be [[xmin, ymin], [xmax, ymax]] in metres")
        low, high = (POINT.read(v, at.item(i)) for i, v in enumerate(value))
        if not (low[0] < high[0] and low[1] < high[1]):
            raise at.fail(f"must have xmin < xmax and ymin < ymax, got {value!r}")
        return (low, high)


def _calendar(value, at: At) -> WorkCalendar:
    return work_calendar_from(value, at.source, at.line)


@dataclass(frozen=True)
class Site:
    """Where things are on the site (metres, site frame).

    ``yard``: component pick-up positions, used in turn; ``robot_home``: robot start positions, used in
    turn (a robot's own ``home`` wins); ``construction_area``: [[xmin, ymin], [xmax, ymax]], the building
    is centred in it unless ``model_offset`` [dx, dy] (model frame -> site frame) is given.
    ``idle_robots``: "stay" (a robot with nothing to do waits where it finished; default) or "yard" (it
    drives back to the nearest yard position, as in the thesis, and can be called away on the way).
    ``work_calendar``: working days and hours (:class:`bimrobot.site.working_time.WorkCalendar`).
    """

    yard: tuple[tuple[float, float], ...] = field(metadata=rule(Points(POINT, "[x, y] positions in metres")))
    robot_home: tuple[tuple[float, float], ...] = field(metadata=rule(Points(POINT, "[x, y] positions in metres")))
    construction_area: tuple[tuple[float, float], tuple[float, float]] = field(metadata=rule(_Area()))
    model_offset: tuple[float, float] | None = field(default=None, metadata=rule(POINT.within(OFFSET_LIMIT_M)))
    idle_robots: str = field(default="stay", metadata=rule(Choice(("stay", "yard"), "'stay' or 'yard'")))
    source: str = "default site (thesis fig. 4.11)"
    #: fastening points assumed for a joint the model gives none for (None: bimrobot.sco.build's default)
    assembly_points_per_joint: int | None = field(
        default=None, metadata=rule(Integer(1, 1000, "a whole number of bolts or welds")))
    work_calendar: WorkCalendar = field(default=WorkCalendar(), metadata=rule(Custom(_calendar)))

    def robot_start(self, index: int, own_home=None) -> tuple[float, ...]:
        """Where robot number ``index`` of a fleet starts (m, site frame): its ``own_home`` as given ((x, y)
        or (x, y, z), site frame) when it has one, else the site's robot homes (x, y) in turn."""
        return own_home or self.robot_home[index % len(self.robot_home)]

    def placed(self, elements) -> "Site":
        """This site with the building placed on it: ``model_offset`` set, once, from the footprint of
        ``elements`` (:class:`bimrobot.bim.model.Element`, their bodies' world bounding boxes) unless the
        site file gives it. Every output of a run is written with this one placement (rounded to 0.1 mm,
        so that a file read back gives the same number), and reads it back rather than computing it again."""
        if self.model_offset is not None:
            return self
        low, high = footprint(elements)
        offset = self.offset_for(low, high)
        return replace(self, model_offset=(round(float(offset[0]), 4), round(float(offset[1]), 4)))

    def offset_for_points(self, model_points_xy) -> np.ndarray:
        """Translation (x, y) model frame -> site frame for a building whose parts are at
        ``model_points_xy`` (an (n, 2) array of model-frame centres, metres)."""
        points = np.asarray(model_points_xy, dtype=float).reshape(-1, 2)
        if not len(points):
            return np.array(self.model_offset or (0.0, 0.0), dtype=float)
        return self.offset_for(points.min(axis=0), points.max(axis=0))

    def to_model(self, site_xy, offset: np.ndarray) -> np.ndarray:
        """Site-frame (x, y) -> model-frame (x, y), metres, for a model placed with ``offset``."""
        return np.asarray(site_xy, dtype=float) - np.asarray(offset, dtype=float)

    def offset_for(self, model_min_xy: np.ndarray, model_max_xy: np.ndarray) -> np.ndarray:
        """Translation (x, y) from the model frame to the site frame, metres."""
        if self.model_offset is not None:
            return np.array(self.model_offset, dtype=float)
        (x0, y0), (x1, y1) = self.construction_area
        area_centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        return area_centre - (np.asarray(model_min_xy) + np.asarray(model_max_xy)) / 2


def footprint(elements) -> tuple[np.ndarray, np.ndarray]:
    """(min_xy, max_xy) in metres, model frame: the horizontal extent of the elements' bodies (the union
    of their world bounding boxes). No elements: the origin."""
    bounds = [np.asarray(e.world_bounds, dtype=float) for e in elements]
    if not bounds:
        return np.zeros(2), np.zeros(2)
    stacked = np.stack(bounds)  # (n, 2, 3)
    return stacked[:, 0, :2].min(axis=0), stacked[:, 1, :2].max(axis=0)


#: A derived site (:func:`derive_site`): clear space around the footprint inside the construction area,
#: the gap from the area to the yard line and to the home line, and the spacing of yard positions and
#: homes along their lines (m). 3 m lets a mobile robot drive round the building; yard positions 3 m
#: apart keep neighbouring stacks of components apart.
AREA_MARGIN_M = 3.0
YARD_GAP_M = 4.0
HOME_GAP_M = 4.0
YARD_PITCH_M = 3.0
HOME_PITCH_M = 3.0
THESIS_SITE = "thesis"


def derive_site(elements) -> Site:
    """A site made for the building of ``elements`` (module docstring), already placed on it.

    The site frame's origin is the construction area's south-west corner, so site positions stay small
    even for a model in map coordinates; ``model_offset`` takes the model frame there."""
    low, high = footprint(elements)
    width, depth = (float(v) for v in high - low)
    area = ((0.0, 0.0), (round(width + 2 * AREA_MARGIN_M, 4), round(depth + 2 * AREA_MARGIN_M, 4)))
    offset = (round(AREA_MARGIN_M - float(low[0]), 4), round(AREA_MARGIN_M - float(low[1]), 4))
    yard_x = area[1][0] + YARD_GAP_M
    yard = tuple((yard_x, round(y, 4)) for y in _line(area[1][1], YARD_PITCH_M))
    homes = tuple((round(x, 4), -HOME_GAP_M) for x in _line(area[1][0], HOME_PITCH_M))
    return Site(yard=yard, robot_home=homes, construction_area=area, model_offset=offset,
                source=f"site derived from the building ({width:.1f} x {depth:.1f} m footprint; bimrobot.site.site.derive_site)")


def _line(length: float, pitch: float, least: int = 4) -> list[float]:
    """At least ``least`` positions ``pitch`` apart along a side ``length`` long, centred on it (m)."""
    count = max(least, int(length // pitch) + 1)
    start = (length - (count - 1) * pitch) / 2
    return [start + i * pitch for i in range(count)]


def fits_thesis_site(elements) -> bool:
    """Whether the footprint of ``elements`` fits fig. 4.11's 7.5 x 6.5 m construction area."""
    low, high = footprint(elements)
    (x0, y0), (x1, y1) = default_site().construction_area
    width, depth = high - low
    return bool(width <= x1 - x0 and depth <= y1 - y0)


def site_for(spec: "str | Path | Site | None", elements) -> Site:
    """The site a run uses, placed on the building of ``elements`` (module docstring): ``spec`` is a
    site file, ``"thesis"`` (fig. 4.11), a loaded :class:`Site`, or None (fig. 4.11 when the building
    fits it, else derived)."""
    elements = list(elements)
    if spec is None:
        return default_site().placed(elements) if fits_thesis_site(elements) else derive_site(elements)
    site = (spec if isinstance(spec, Site) else load_site(spec)).placed(elements)
    warning = on_the_building(site, elements)
    if warning:
        log.warning("%s", warning)
    return site


def on_the_building(site: Site, elements) -> str | None:
    """One sentence naming the yard positions and robot homes of ``site`` that lie on the footprint of
    ``elements`` (robots would start, or components wait, inside the building), or None."""
    if site.model_offset is None:
        return None
    low, high = footprint(elements)
    low, high = low + np.asarray(site.model_offset), high + np.asarray(site.model_offset)
    inside = [f"{what} ({x:g}, {y:g})" for what, points in (("yard position", site.yard), ("robot home", site.robot_home))
              for x, y in points if low[0] <= x <= high[0] and low[1] <= y <= high[1]]
    if not inside:
        return None
    shown = ", ".join(inside[:3]) + (f" and {len(inside) - 3} more" if len(inside) > 3 else "")
    return (f"{site.source}: {shown} lie on the building, whose footprint spans ({low[0]:.1f}, {low[1]:.1f}) to "
            f"({high[0]:.1f}, {high[1]:.1f}) m on the site: move them outside it (or give no --site: a site is "
            "derived from the building)")


def site_to_dict(site: Site) -> dict:
    """The site as the keys of a site file (JSON- and YAML-safe; ``model_offset`` only when placed)."""
    data = {"yard": [list(p) for p in site.yard], "robot_home": [list(p) for p in site.robot_home],
            "construction_area": [list(p) for p in site.construction_area], "idle_robots": site.idle_robots,
            "work_calendar": {"days": list(site.work_calendar.days), "hours": list(site.work_calendar.hours)}}
    if site.model_offset is not None:
        data["model_offset"] = list(site.model_offset)
    if site.assembly_points_per_joint is not None:
        data["assembly_points_per_joint"] = site.assembly_points_per_joint
    return data


def site_yaml(site: Site, what: str) -> str:
    """The site as a site file (YAML), with a header saying where it came from; ``what`` names the run."""
    import yaml

    header = (f"# The site of {what} ({site.source}), with the building placed on it: model_offset [dx, dy] m takes\n"
              "# the model frame to the site frame. Give it to any command with --site to use the same site.\n")
    return header + yaml.safe_dump(site_to_dict(site), sort_keys=False)


def site_from_dict(data, source: str) -> Site:
    """A validated Site from a parsed site file (:data:`SITE_KEYS`; a missing key takes fig. 4.11's
    value); a refusal names ``source``, the key and its line."""
    if not isinstance(data, dict):
        raise InputError(f"{source}: expected a mapping with yard, robot_home and construction_area")
    default = default_site()
    values = {key: getattr(default, key) for key in ("yard", "robot_home", "construction_area")}
    return Site(**{**values, **read_keys(data, Site, At(source))}, source=source)


#: The keys of a site file (module docstring), declared by :class:`Site`'s fields.
SITE_KEYS = keys_of(Site)


def default_site() -> Site:
    """The site of fig. 4.11: yard at x = 12.5 m, robot homes at x = 18.5 m, y = 4, 6, 8, 11 m."""
    return Site(
        yard=((12.5, 4.0), (12.5, 6.0), (12.5, 8.0), (12.5, 11.0)),
        robot_home=((18.5, 4.0), (18.5, 6.0), (18.5, 8.0), (18.5, 11.0)),
        construction_area=((3.0, 1.5), (10.5, 8.0)),
    )


def load_site(path: str | Path | None) -> Site:
    """The site YAML at ``path`` (missing keys take fig. 4.11's values), or fig. 4.11's site (``None`` or
    ``"thesis"``; a run without a site file uses :func:`site_for`, which may derive one instead)."""
    if path is None or str(path) == THESIS_SITE:
        return default_site()
    return site_from_dict(read_yaml_file(path, "site file"), str(path))
