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
    elements: dict[str, Element] = {}
    connections: list[Connection] = []
    skipped: list[SkippedProduct] = []
    bolt_counter = [0]

    def bolts(n: int) -> tuple[str, ...]:
        ids = []
        for _ in range(n):
            bolt_counter[0] += 1
            gid = f"bolt-{bolt_counter[0]}"
            ids.append(gid)
            skipped.append(SkippedProduct(gid, "IfcMechanicalFastener", "M20 bolt", "generated without geometry"))
        return tuple(ids)

    def relate(relating: str, related: str) -> None:
        connections.append(Connection(relating, related, bolts(bolts_per_node), "BOLTED"))

    def add(element: Element) -> str:
        elements[element.global_id] = element
        return element.global_id

    half_col = 0.127  # W250x73: 254 mm flange
    for k in range(floors):
        z0, z1 = k * height, (k + 1) * height
        storey = storeys[k].global_id
        beam_storey = storeys[k + 1].global_id if beams_on_storey_above else storey
        for i in range(nx):
            for j in range(ny):
                x, y = i * bay_x, j * bay_y
                column = add(box_element(f"column-{k}-{i}-{j}", "IfcColumn", "W250x73", storey, (x - half_col, y - half_col, z0 + 0.02), (x + half_col, y + half_col, z1), COLUMN_KG_PER_M * (height - 0.02)))
                plate = add(box_element(f"plate-{k}-{i}-{j}", "IfcPlate", "Base plate" if k == 0 else "Splice plate", storey, (x - 0.2, y - 0.2, z0), (x + 0.2, y + 0.2, z0 + 0.02), 25.0))
                relate(column, plate)
                if k == 0:
                    footing = add(box_element(f"footing-{i}-{j}", "IfcFooting", "Isolated footing", storey, (x - 0.6, y - 0.6, -0.6), (x + 0.6, y + 0.6, 0.0), 2000.0))
                    relate(footing, plate)
                else:
                    relate(f"column-{k - 1}-{i}-{j}", plate)
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
                    beam = add(box_element(f"beam-{k}-{axis}-{i}-{j}", "IfcBeam", "W310x38.7", beam_storey, low, high, BEAM_KG_PER_M * span))
                    for end, (cx, cy, ci, cj) in enumerate(((x, y, i, j), (x2, y2, i + di, j + dj))):
                        clip = add(box_element(f"clip-{beam}-{end}", "IfcPlate", "Clip angle", beam_storey, (cx - 0.15, cy - 0.15, z1 - 0.25), (cx + 0.15, cy + 0.15, z1 - 0.05), 3.0))
                        relate(f"column-{k}-{ci}-{cj}", clip)
                        relate(beam, clip)
    return BuildingModel(
        source=None,
        schema="generated",
        project_name=f"generated frame {nx}x{ny}x{floors}",
        site_name="generated",
        units={"length": "METRE", "length_scale_to_m": 1.0, "mass": "KILOGRAM"},
        storeys=storeys,
        elements=elements,
        connections=connections,
        skipped=skipped,
    )


def components_in_frame(nx: int, ny: int, floors: int) -> int:
    """Number of components (columns + beams, footings excluded) of :func:`generated_frame`."""
    return floors * (nx * ny + (nx - 1) * ny + nx * (ny - 1))
