"""What robots build: a component is an element, or an ``IfcElementAssembly`` lifted as one unit.

In Tekla precast and steel exports the assembly (a cast unit, a steel sub-frame) is what is lifted and
placed; :attr:`BuildingModel.assemblies` keeps the outermost ones with their loaded parts. These
helpers give a component's parts, weight, bounds, position and section the same way for both, so the
graph and RCAN treat a schedule row on an assembly like one on an element.

Units and frames: metres (world frame, z up) and kg, as in :mod:`bimrobot.bim.model`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from bimrobot.bim.model import BuildingModel, Element


def is_assembly(model: BuildingModel, global_id: str | None) -> bool:
    """Whether ``global_id`` is one of the model's (outermost) assemblies."""
    return global_id in getattr(model, "assemblies", {})


def is_component(model: BuildingModel, global_id: str | None) -> bool:
    """Whether ``global_id`` is an element or an assembly of ``model``."""
    return global_id in model.elements or is_assembly(model, global_id)


def parts(model: BuildingModel, global_id: str) -> list[Element]:
    """The elements of a component: the element itself, or the assembly's loaded parts."""
    if global_id in model.elements:
        return [model.elements[global_id]]
    if is_assembly(model, global_id):
        return [model.elements[p] for p in model.assemblies[global_id].part_ids if p in model.elements]
    raise KeyError(f"no element or assembly {global_id!r} in {model.source or 'the model'}")


def weight_kg(model: BuildingModel, global_id: str) -> float | None:
    """The component's mass in kg: the element's weight, or the sum of the assembly's parts; None
    (unknown) when the element's weight, or any part's, is unknown."""
    weights = [e.weight_kg for e in parts(model, global_id)]
    if not weights or any(w is None for w in weights):
        return None
    return float(sum(weights))


def world_bounds(model: BuildingModel, global_id: str) -> np.ndarray | None:
    """Axis-aligned world bounds [[xmin, ymin, zmin], [xmax, ymax, zmax]] of the component's bodies
    (the union of the parts' for an assembly), metres; None when no part has a body."""
    boxes = [e.world_bounds for e in parts(model, global_id) if len(e.vertices)]
    if not boxes:
        return None
    return np.array([np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)])


def position(model: BuildingModel, global_id: str) -> np.ndarray:
    """Where the component is installed, metres, world frame: an element's placement origin; for an
    assembly, the origin of its main part (:func:`main_part`, the heaviest), which
    is the origin of the unit the simulation lifts and the schedule's ``TargetX/Y/Z``."""
    if global_id in model.elements:
        return model.elements[global_id].position
    return main_part(parts(model, global_id)).position


def extents(model: BuildingModel, global_id: str) -> np.ndarray | None:
    """The component's size along x, y, z in metres: an element's body in its local frame, an
    assembly's union of parts along the world axes; None without a body."""
    if global_id in model.elements:
        element = model.elements[global_id]
        if not len(element.vertices):
            return None
        lo, hi = element.local_bounds
        return hi - lo
    bounds = world_bounds(model, global_id)
    return None if bounds is None else bounds[1] - bounds[0]


def section_m(model: BuildingModel, global_id: str) -> tuple[float, float] | None:
    """The two smaller extents of the component (m): what a gripper closes on (thesis table 5.1)."""
    size = extents(model, global_id)
    if size is None:
        return None
    smaller = sorted(float(v) for v in size)[:2]
    return (round(smaller[0], 4), round(smaller[1], 4))


def storey_id(model: BuildingModel, global_id: str) -> str | None:
    """The storey GlobalId of an element, or of an assembly (its own, else its first part's)."""
    if global_id in model.elements:
        return model.elements[global_id].storey_id
    assembly = model.assemblies[global_id]
    return assembly.storey_id or next((e.storey_id for e in parts(model, global_id) if e.storey_id), None)


def main_part(parts: list[Element]) -> Element:
    """The part whose placement an assembly unit takes (the heaviest; the first of equals): the unit's
    origin, where the schedule, the graph and RCAN install it (issue 34: one position per component)."""
    return max(parts, key=mass_proxy)


def mass_proxy(element: Element) -> float:
    """Weight in kg, or (weight unknown) bounding-box volume x steel density, to compare sizes."""
    if element.weight_kg is not None:
        return float(element.weight_kg)
    extent = element.world_bounds[1] - element.world_bounds[0]
    return float(np.prod(extent)) * 7850.0
