"""Occupancy grids: what a robot's map must show at robot height."""

from __future__ import annotations

import numpy as np
import pytest

from bimrobot.export.gazebo.navmap import grid_frame, occupancy


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """trimesh (about 1 s of imports with SciPy and networkx), imported when these tests run, not at collection."""
    global trimesh
    import trimesh


RESOLUTION = 0.05


def _grid(*meshes: trimesh.Trimesh, band=(0.1, 1.5)):
    bounds = np.array([[-1.0, -1.0], [5.0, 5.0]])
    origin, shape = grid_frame(bounds, 0.0, RESOLUTION)
    bodies = [(np.asarray(m.vertices), np.asarray(m.faces)) for m in meshes]
    return occupancy(bodies, band, origin, shape, RESOLUTION), origin


def _cell(origin, rows, x, y):
    return rows - 1 - int(np.floor((y - origin[1]) / RESOLUTION)), int(np.floor((x - origin[0]) / RESOLUTION))


def test_a_sheet_thinner_than_a_cell_still_blocks_its_cells():
    sheet = trimesh.creation.box(extents=(2.0, 0.009, 3.0))  # 9 mm thick, 2 m long, standing
    sheet.apply_translation((1.0 + 0.01, 0.32, 1.5))
    grid, origin = _grid(sheet)
    row, _ = _cell(origin, grid.shape[0], 1.0, 0.32)
    assert grid[row].sum() >= 40  # 2 m / 0.05 m
    assert grid.sum() <= 2 * 42  # one row of cells, two where the sheet straddles a cell edge


def test_a_table_top_inside_the_band_is_occupied_and_the_floor_slab_below_is_not():
    table = trimesh.creation.box(extents=(1.0, 0.6, 0.05))
    table.apply_translation((2.0, 2.0, 0.8))
    slab = trimesh.creation.box(extents=(6.0, 6.0, 0.2))
    slab.apply_translation((2.0, 2.0, -0.1))
    grid, origin = _grid(table, slab)
    assert grid[_cell(origin, grid.shape[0], 2.0, 2.0)]
    assert not grid[_cell(origin, grid.shape[0], 0.5, 0.5)]
    # 1.0 m x 0.6 m = 20 x 12 cells; edges on cell boundaries may add one conservative cell per side.
    assert 20 * 12 <= grid.sum() <= 22 * 14


def test_a_ring_shaped_element_leaves_its_inside_free():
    outer = trimesh.creation.box(extents=(4.0, 4.0, 3.0))
    inner = trimesh.creation.box(extents=(3.6, 3.6, 3.2))
    # A closed ring of walls as one body: outer box with the inner box's faces reversed.
    inner.invert()
    ring = trimesh.util.concatenate([outer, inner])
    ring.apply_translation((2.0, 2.0, 1.5))
    grid, origin = _grid(ring)
    assert not grid[_cell(origin, grid.shape[0], 2.0, 2.0)]  # inside the room
    assert grid[_cell(origin, grid.shape[0], 0.1, 2.0)]  # in the wall
    assert not grid[_cell(origin, grid.shape[0], -0.5, 2.0)]  # outside
