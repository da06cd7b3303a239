"""Occupancy grids per storey from a horizontal section band at robot height (Nav2 map_server format).

For a storey at elevation ``e`` and a band ``(low, high)`` (metres above the storey), a cell is
occupied when any element's solid reaches into the slab ``e + low <= z <= e + high`` above that
cell. Each element is cut in two ways that together cover its footprint in the band exactly:

* its triangles clipped to the band and projected onto the floor (catches every part of the solid
  that starts or ends inside the band: a slab edge, a beam soffit, a table top), and
* its cross-section at mid-band, filled even-odd (catches the parts that pass right through the
  band, such as columns and walls, whose clipped side faces project to mere lines).

The grid is in the world frame (metres, z up). Image row 0 is the north (max y) edge; the YAML
``origin`` is the world position of the lower-left pixel's corner, as map_server expects.
Pixels: occupied 0 (black), free 254 (white), ``mode: trinary``, ``negate: 0``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from PIL import Image, ImageDraw
import shapely
from shapely.geometry import Polygon

from bimrobot.core.errors import InputError

OCCUPIED, FREE = 0, 254
OCCUPIED_THRESH, FREE_THRESH = 0.65, 0.196


@dataclass
class OccupancyGrid:
    """A storey's map. ``occupied[row, col]``: row 0 is max y. ``origin``: world (x, y) of the
    lower-left corner (m). ``band``: world z range cut (m)."""

    name: str
    storey_id: str | None
    storey_name: str
    elevation: float
    band: tuple[float, float]
    resolution: float
    origin: tuple[float, float]
    occupied: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the image."""
        return self.occupied.shape

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the pixel that holds world point (x, y) (m)."""
        col = int(np.floor((x - self.origin[0]) / self.resolution))
        row = self.occupied.shape[0] - 1 - int(np.floor((y - self.origin[1]) / self.resolution))
        return row, col

    def is_occupied(self, x: float, y: float) -> bool:
        """Whether the cell holding world point (x, y) (m) is occupied."""
        row, col = self.cell_of(x, y)
        return bool(self.occupied[row, col])


MAX_MAP_CELLS = 100_000_000
"""The most cells one map may have (10^4 x 10^4: 500 m x 500 m at 5 cm; 100 MB while it is drawn)."""


def grid_frame(bounds_xy: np.ndarray, margin: float, resolution: float) -> tuple[tuple[float, float], tuple[int, int]]:
    """Origin (m) and (rows, cols) of a grid covering ``[[xmin, ymin], [xmax, ymax]]`` plus ``margin``.

    Raises InputError when the grid would have more than :data:`MAX_MAP_CELLS` cells (the model
    reaches far from the building, e.g. an element placed kilometres away) or the bounds are not finite.
    """
    bounds = np.asarray(bounds_xy, dtype=np.float64)
    if not np.isfinite(bounds).all():
        raise InputError(f"the occupancy maps cannot be sized: the model's extent in x and y is not finite ({_extent(bounds)})")
    with np.errstate(over="ignore", invalid="ignore"):  # a huge extent becomes inf cells, refused below
        lower = np.floor((bounds[0] - margin) / resolution) * resolution
        upper = bounds[1] + margin
        cells = np.maximum(np.ceil((upper - lower) / resolution), 1)  # (cols, rows), as floats: no overflow
    if not np.isfinite(cells).all() or cells[0] * cells[1] > MAX_MAP_CELLS:
        raise InputError(
            f"the occupancy maps would be {cells[0]:.3g} x {cells[1]:.3g} cells ({_extent(bounds)} plus "
            f"{margin:g} m around it, at {resolution:g} m per cell), more than the {MAX_MAP_CELLS:.0e} one map may "
            "have: move the elements that lie far from the building (or the IFC project origin), "
            "--exclude them, or use --no-maps or a coarser --map-resolution"
        )
    cols, rows = cells.astype(int)
    return (round(float(lower[0]), 9), round(float(lower[1]), 9)), (int(rows), int(cols))


def _extent(bounds: np.ndarray) -> str:
    """The xy bounds in words (metres)."""
    return f"x {bounds[0][0]:.6g} .. {bounds[1][0]:.6g} m, y {bounds[0][1]:.6g} .. {bounds[1][1]:.6g} m"


def occupancy(
    bodies: list[tuple[np.ndarray, np.ndarray]],
    band: tuple[float, float],
    origin: tuple[float, float],
    shape: tuple[int, int],
    resolution: float,
) -> np.ndarray:
    """Boolean grid (rows, cols) of the cells that the bodies occupy within the z band.

    ``bodies``: (world vertices (n, 3), faces (m, 3)) per element, metres.
    """
    rows, cols = shape
    image = Image.new("1", (cols, rows), 0)
    draw = ImageDraw.Draw(image)
    low, high = band

    def to_pixels(points: np.ndarray) -> list[tuple[float, float]]:
        # Continuous pixel coordinates (pixel i spans [i, i+1]) shifted by half a pixel, because
        # Pillow puts pixel centres on integer coordinates.
        # Rounded to a micro-pixel: Pillow truncates, and 20.999999999999996 must count as 21.
        u = np.round((points[:, 0] - origin[0]) / resolution - 0.5, 6)
        v = np.round(rows - (points[:, 1] - origin[1]) / resolution - 0.5, 6)
        return list(zip(u.tolist(), v.tolist()))

    outlines: list[np.ndarray] = []  # (k, 2, 2) segments whose cells are marked exactly (thin parts)
    for vertices, faces in bodies:
        if len(faces) == 0:
            continue
        zmin, zmax = vertices[:, 2].min(), vertices[:, 2].max()
        if zmax < low or zmin > high:
            continue
        # Only faces that reach into the band can leave anything on the map (the cuts below treat
        # each face on its own), so the others are dropped first: a tall or detailed body has many.
        face_z = vertices[:, 2][faces]
        faces = faces[(face_z.max(axis=1) >= low) & (face_z.min(axis=1) <= high)]
        if len(faces) == 0:
            continue
        triangles = _clipped_projected_triangles(vertices, faces, low, high)
        if len(triangles):
            pixels = to_pixels(triangles.reshape(-1, 2))
            for start in range(0, len(pixels), 3):
                draw.polygon(pixels[start : start + 3], fill=1)
            thin = triangles[_thin_triangles(triangles, resolution)]
            if len(thin):
                outlines.append(np.stack([thin, np.roll(thin, -1, axis=1)], axis=2).reshape(-1, 2, 2))
        middle = (low + high) / 2
        if zmin < middle < zmax:
            for polygon in _section_polygons(vertices, faces, middle):
                draw.polygon(to_pixels(np.asarray(polygon.exterior.coords)), fill=1)
                for hole in polygon.interiors:
                    draw.polygon(to_pixels(np.asarray(hole.coords)), fill=0)
                if 2 * polygon.area / max(polygon.length, 1e-12) < 2 * resolution:  # thinner than ~4 cells
                    for ring in [polygon.exterior, *polygon.interiors]:
                        coords = np.asarray(ring.coords)[:, :2]
                        outlines.append(np.stack([coords[:-1], coords[1:]], axis=1))
    grid = np.array(image, dtype=bool)
    if outlines:
        _mark_segments(grid, np.concatenate(outlines), origin, resolution)
    return grid


def _thin_triangles(triangles: np.ndarray, resolution: float) -> np.ndarray:
    """Mask of projected triangles (k, 3, 2) narrower than two cells: Pillow may skip their cells."""
    edges = np.roll(triangles, -1, axis=1) - triangles
    longest = np.linalg.norm(edges, axis=2).max(axis=1)
    doubled_area = np.abs(edges[:, 0, 0] * edges[:, 1, 1] - edges[:, 0, 1] * edges[:, 1, 0])
    return doubled_area / np.maximum(longest, 1e-12) < 2 * resolution


def _mark_segments(grid: np.ndarray, segments: np.ndarray, origin: tuple[float, float], resolution: float) -> None:
    """Mark every cell that a 2-D segment (k, 2, 2; metres) passes through, so parts thinner than a
    cell (a 9 mm web, a sheet) still block the map. Sampled every half cell (a corner clipped by
    less than that may stay free); segments that project onto each other are sampled once."""
    segments = _distinct_segments(np.round(segments, 5))
    starts, deltas = segments[:, 0], segments[:, 1] - segments[:, 0]
    lengths = np.linalg.norm(deltas, axis=1)
    counts = np.ceil(lengths / (resolution / 2)).astype(int) + 1
    steps = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    fraction = steps / np.maximum(np.repeat(counts, counts) - 1, 1)
    # start + (end - start) x fraction per sample, one coordinate at a time (np.repeat of each
    # segment's numbers: the same values as indexing rows by owner, at a fraction of the cost)
    x = np.repeat(starts[:, 0], counts) + np.repeat(deltas[:, 0], counts) * fraction
    y = np.repeat(starts[:, 1], counts) + np.repeat(deltas[:, 1], counts) * fraction
    rows, cols = grid.shape
    col = np.floor((x - origin[0]) / resolution).astype(int)
    row = rows - 1 - np.floor((y - origin[1]) / resolution).astype(int)
    inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
    grid[row[inside], col[inside]] = True


def _distinct_segments(segments: np.ndarray) -> np.ndarray:
    """The distinct segments (k, 2, 2), each from its lower (x, y) end to its higher one, sorted (as
    ``np.unique(axis=0)`` gives them, but without its slow sort of structured rows)."""
    start, end = segments[:, 0], segments[:, 1]
    swap = (start[:, 0] > end[:, 0]) | ((start[:, 0] == end[:, 0]) & (start[:, 1] > end[:, 1]))
    rows = np.where(swap[:, None, None], segments[:, ::-1], segments).reshape(-1, 4)
    rows = rows[np.lexsort(rows.T[::-1])]
    distinct = np.ones(len(rows), dtype=bool)
    distinct[1:] = np.any(rows[1:] != rows[:-1], axis=1)
    return rows[distinct].reshape(-1, 2, 2)


def _clipped_projected_triangles(vertices: np.ndarray, faces: np.ndarray, low: float, high: float) -> np.ndarray:
    """Triangles clipped to low <= z <= high, projected to xy (k, 3, 2); vertical ones dropped."""
    import trimesh  # imported by the work that needs it (about 1 s with SciPy and networkx)

    v, f = vertices, faces
    if v[:, 2].min() < low:
        v, f = trimesh.intersections.slice_faces_plane(v, f, np.array([0.0, 0, 1]), np.array([0.0, 0, low]))[:2]
    if len(f) and v[:, 2].max() > high:
        v, f = trimesh.intersections.slice_faces_plane(v, f, np.array([0.0, 0, -1]), np.array([0.0, 0, high]))[:2]
    if len(f) == 0:
        return np.zeros((0, 3, 2))
    triangles = v[f][:, :, :2]
    edge1, edge2 = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    area = np.abs(edge1[:, 0] * edge2[:, 1] - edge1[:, 1] * edge2[:, 0]) / 2
    return triangles[area > 1e-10]


def _section_polygons(vertices: np.ndarray, faces: np.ndarray, z: float) -> list[Polygon]:
    """The solid regions of the cross-section at height z (even-odd over the cut loops)."""
    import trimesh

    face_z = vertices[:, 2][faces]
    faces = faces[(face_z.min(axis=1) <= z) & (face_z.max(axis=1) >= z)]  # the faces the plane meets
    if len(faces) == 0:
        return []
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    segments = trimesh.intersections.mesh_plane(mesh, [0.0, 0, 1], [0.0, 0, z])
    if len(segments) == 0:
        return []
    lines = np.round(segments[:, :, :2], 6)
    lines = lines[np.any(lines[:, 0] != lines[:, 1], axis=1)]
    if len(lines) == 0:
        return []
    noded = shapely.union_all(shapely.linestrings(lines))
    faces_2d = [p for p in shapely.get_parts(shapely.polygonize(shapely.get_parts(noded))) if p.area > 0]
    shells = [Polygon(p.exterior) for p in faces_2d]
    solid = []
    for index, face in enumerate(faces_2d):
        inside = face.representative_point()
        depth = sum(1 for other, shell in enumerate(shells) if other != index and shell.contains(inside))
        if depth % 2 == 0:
            solid.append((depth, face))
    return [face for _, face in sorted(solid, key=lambda item: item[0])]


def write_map(grid: OccupancyGrid, directory: Path) -> tuple[Path, Path]:
    """Write ``<name>.pgm`` and ``<name>.yaml`` (map_server format) into ``directory``."""
    directory = Path(directory)
    pgm = directory / f"{grid.name}.pgm"
    pixels = np.where(grid.occupied, OCCUPIED, FREE).astype(np.uint8)
    Image.fromarray(pixels, mode="L").save(pgm)
    meta = {
        "image": pgm.name,
        "mode": "trinary",
        "resolution": float(grid.resolution),
        "origin": [float(grid.origin[0]), float(grid.origin[1]), 0.0],
        "negate": 0,
        "occupied_thresh": OCCUPIED_THRESH,
        "free_thresh": FREE_THRESH,
    }
    header = (
        f"# Storey {grid.storey_name!r} (GlobalId {grid.storey_id}), elevation {grid.elevation:.3f} m;\n"
        f"# occupied = any element within z {grid.band[0]:.3f} .. {grid.band[1]:.3f} m (world frame).\n"
    )
    yaml_path = directory / f"{grid.name}.yaml"
    yaml_path.write_text(header + yaml.safe_dump(meta, sort_keys=False), encoding="utf-8")
    return pgm, yaml_path


def read_map(yaml_path: Path) -> tuple[dict, np.ndarray]:
    """Read a map_server map back: (YAML dict, occupied boolean grid, row 0 = max y)."""
    meta = yaml.safe_load(Path(yaml_path).read_text(encoding="utf-8"))
    pixels = np.array(Image.open(Path(yaml_path).parent / meta["image"]))
    occupancy_probability = (255 - pixels) / 255.0 if not meta.get("negate") else pixels / 255.0
    return meta, occupancy_probability > meta["occupied_thresh"]


__all__ = ["OccupancyGrid", "grid_frame", "occupancy", "write_map", "read_map"]
