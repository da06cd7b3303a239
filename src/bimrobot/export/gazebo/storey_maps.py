"""The per-storey occupancy maps of a package (Nav2 map_server): which storeys get a map, their names and
bands (m above each storey), and one map drawn and written (metres, z up, the world frame)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bimrobot.bim.model import BuildingModel
from bimrobot.core.names import safe_name
from bimrobot.export.gazebo import navmap
from bimrobot.export.gazebo.naming import map_name
from bimrobot.export.gazebo.options import ConvertOptions


@dataclass
class MapPlan:
    """The maps to draw: one level per storey (name, storey id and name, elevation, band) in one grid frame."""

    levels: list[tuple[str, str | None, str, float, tuple[float, float]]]
    origin: tuple[float, float]
    shape: tuple[int, int]


def plan_maps(model: BuildingModel, extent: np.ndarray, options: ConvertOptions, ground_z: float) -> MapPlan:
    """One map per storey (the site's ground when the model has none), named by :func:`map_name`, over the
    grid that covers the world's ``extent`` (m) with the margin."""
    origin, shape = navmap.grid_frame(extent[:, :2], options.map_margin, options.map_resolution)
    storeys = sorted(model.storeys, key=lambda s: s.elevation)
    levels = [(s.global_id, s.name, s.elevation) for s in storeys] or [(None, "site", ground_z)]
    used: set[str] = set()
    planned = []
    for index, (storey_id, storey_name, elevation) in enumerate(levels, start=1):
        name = map_name(storey_name, index) if storey_id else "site"
        if name in used:
            name = f"{name}_{safe_name(storey_id) if storey_id else len(used)}"
        used.add(name)
        band = (elevation + options.map_band[0], elevation + options.map_band[1])
        planned.append((name, storey_id, storey_name, elevation, band))
    return MapPlan(planned, origin, shape)


def write_map(maps_dir: Path, converted: list, plan: MapPlan, level: int, options: ConvertOptions) -> dict:
    """Draw and write one storey's map; return its report entry."""
    name, storey_id, storey_name, elevation, band = plan.levels[level]
    bodies = [(item.world_vertices, item.body.faces) for item in converted]
    occupied = navmap.occupancy(bodies, band, plan.origin, plan.shape, options.map_resolution)
    grid = navmap.OccupancyGrid(name, storey_id, storey_name, elevation, band, options.map_resolution, plan.origin, occupied)
    pgm, yaml_file = navmap.write_map(grid, maps_dir)
    return {
        "image": f"maps/{pgm.name}",
        "yaml": f"maps/{yaml_file.name}",
        "storey_id": storey_id,
        "storey_name": storey_name,
        "elevation_m": elevation,
        "band_z_m": list(band),
        "resolution_m": options.map_resolution,
        "origin_m": list(plan.origin),
        "size_px": [plan.shape[1], plan.shape[0]],
        "occupied_cells": int(occupied.sum()),
    }
