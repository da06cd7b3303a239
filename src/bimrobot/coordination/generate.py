"""Generated steel frames as BuildingModels, for tests and benchmarks (no IFC file needed).

A grid of ``nx`` x ``ny`` columns per floor on prebuilt footings, beams between neighbouring columns at
the top of each floor, base plates and column splices (plates) and clip angles at every beam end as
connectors, bolts as realizing elements (listed as skipped products: they carry no geometry here).
Sizes and weights follow the thesis' chapter-4 frame: W250x73 columns (72.9 kg/m), W310x38.7 beams
(38.7 kg/m). Metres, z up, kg.
"""

from __future__ import annotations

import numpy as np

from bimrobot.bim.model import BuildingModel, Connection, Element, SkippedProduct, Storey, WeightSource

COLUMN_KG_PER_M = 72.9
BEAM_KG_PER_M = 38.7
_UNIT_BOX = np.array(
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float
)
_BOX_FACES = np.array(
    [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]],
    dtype=np.int64,
)


def box_element(gid: str, ifc_class: str, name: str, storey: str, low, high, weight: float | None) -> Element:
    """An axis-aligned box from ``low`` to ``high`` (world, metres); local origin at ``low``."""
    low, high = np.asarray(low, float), np.asarray(high, float)
    placement = np.eye(4)
    placement[:3, 3] = low
    return Element(
        global_id=gid,
        ifc_class=ifc_class,
        name=name,
        storey_id=storey,
        placement=placement,
        vertices=_UNIT_BOX * (high - low),
        faces=_BOX_FACES,
        material="S355",
        weight_kg=weight,
        weight_source=WeightSource.QUANTITY if weight is not None else WeightSource.UNKNOWN,
    )


#: Half the flange of a W250x73 column (254 mm), m.
_HALF_COLUMN = 0.127


class _Frame:
    """The elements, bolted connections and skipped bolts of a frame as they are generated."""

    def __init__(self, bolts_per_node: int):
        self.bolts_per_node = bolts_per_node
        self.elements: dict[str, Element] = {}
        self.connections: list[Connection] = []
        self.skipped: list[SkippedProduct] = []
        self.bolt_count = 0

    def bolts(self, n: int) -> tuple[str, ...]:
        """``n`` new bolts, listed as skipped products (no geometry)."""
        ids = []
        for _ in range(n):
            self.bolt_count += 1
            gid = f"bolt-{self.bolt_count}"
            ids.append(gid)
            self.skipped.append(SkippedProduct(gid, "IfcMechanicalFastener", "M20 bolt", "generated without geometry"))
        return tuple(ids)

    def relate(self, relating: str, related: str) -> None:
        """Bolt ``related`` to ``relating`` with one node of bolts."""
        self.connections.append(Connection(relating, related, self.bolts(self.bolts_per_node), "BOLTED"))

    def add(self, element: Element) -> str:
        self.elements[element.global_id] = element
        return element.global_id


def _columns(frame: _Frame, k: int, nx: int, ny: int, bay_x: float, bay_y: float, height: float, storey: str) -> None:
    """Floor ``k``'s columns on their plates, each plate on a footing (ground floor) or on the column
    below (a splice). Metres, z up; kg."""
    half_col = _HALF_COLUMN
    z0, z1 = k * height, (k + 1) * height
    for i in range(nx):
        for j in range(ny):
            x, y = i * bay_x, j * bay_y
            column = frame.add(box_element(f"column-{k}-{i}-{j}", "IfcColumn", "W250x73", storey, (x - half_col, y - half_col, z0 + 0.02), (x + half_col, y + half_col, z1), COLUMN_KG_PER_M * (height - 0.02)))
            plate = frame.add(box_element(f"plate-{k}-{i}-{j}", "IfcPlate", "Base plate" if k == 0 else "Splice plate", storey, (x - 0.2, y - 0.2, z0), (x + 0.2, y + 0.2, z0 + 0.02), 25.0))
            frame.relate(column, plate)
            if k == 0:
                footing = frame.add(box_element(f"footing-{i}-{j}", "IfcFooting", "Isolated footing", storey, (x - 0.6, y - 0.6, -0.6), (x + 0.6, y + 0.6, 0.0), 2000.0))
                frame.relate(footing, plate)
            else:
                frame.relate(f"column-{k - 1}-{i}-{j}", plate)


def _beams(frame: _Frame, k: int, nx: int, ny: int, bay_x: float, bay_y: float, height: float, beam_storey: str) -> None:
    """Floor ``k``'s beams along x and y at the top of its columns, each end on a clip angle bolted to
    the column and to the beam. Metres, z up; kg."""
    half_col = _HALF_COLUMN
    z1 = (k + 1) * height
    for i in range(nx):
        for j in range(ny):
            x, y = i * bay_x, j * bay_y
            for di, dj, axis in ((1, 0, "x"), (0, 1, "y")):
                if i + di >= nx or j + dj >= ny:
                    continue
                x2, y2 = (i + di) * bay_x, (j + dj) * bay_y
                span = (bay_x if axis == "x" else bay_y) - 2 * half_col
                if axis == "x":
                    low, high = (x + half_col, y - 0.0825, z1 - 0.31), (x2 - half_col, y + 0.0825, z1)
                else:
                    low, high = (x - 0.0825, y + half_col, z1 - 0.31), (x + 0.0825, y2 - half_col, z1)
                beam = frame.add(box_element(f"beam-{k}-{axis}-{i}-{j}", "IfcBeam", "W310x38.7", beam_storey, low, high, BEAM_KG_PER_M * span))
                for end, (cx, cy, ci, cj) in enumerate(((x, y, i, j), (x2, y2, i + di, j + dj))):
                    clip = frame.add(box_element(f"clip-{beam}-{end}", "IfcPlate", "Clip angle", beam_storey, (cx - 0.15, cy - 0.15, z1 - 0.25), (cx + 0.15, cy + 0.15, z1 - 0.05), 3.0))
                    frame.relate(f"column-{k}-{ci}-{cj}", clip)
                    frame.relate(beam, clip)


def generated_frame(
    nx: int = 2,
    ny: int = 2,
    floors: int = 1,
    bay_x: float = 3.5,
    bay_y: float = 2.846,
    height: float = 4.0,
    bolts_per_node: int = 6,
    beams_on_storey_above: bool = True,
) -> BuildingModel:
    """A frame of ``floors`` storeys; with the defaults it has the thesis' chapter-4 shape.

    ``beams_on_storey_above``: beams belong to the storey at their top (as Revit and the thesis' frame
    do); otherwise to the storey of the columns that carry them.
    """
    storey_count = floors + 1 if beams_on_storey_above else floors
    storeys = [Storey(f"storey-{k}", f"Level {k + 1}", k * height) for k in range(storey_count)]
    frame = _Frame(bolts_per_node)
    for k in range(floors):
        storey = storeys[k].global_id
        beam_storey = storeys[k + 1].global_id if beams_on_storey_above else storey
        _columns(frame, k, nx, ny, bay_x, bay_y, height, storey)
        _beams(frame, k, nx, ny, bay_x, bay_y, height, beam_storey)
    return BuildingModel(
        source=None,
        schema="generated",
        project_name=f"generated frame {nx}x{ny}x{floors}",
        site_name="generated",
        units={"length": "METRE", "length_scale_to_m": 1.0, "mass": "KILOGRAM"},
        storeys=storeys,
        elements=frame.elements,
        connections=frame.connections,
        skipped=frame.skipped,
    )


def components_in_frame(nx: int, ny: int, floors: int) -> int:
    """Number of components (columns + beams, footings excluded) of :func:`generated_frame`."""
    return floors * (nx * ny + (nx - 1) * ny + nx * (ny - 1))
