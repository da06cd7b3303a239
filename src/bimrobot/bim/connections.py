"""Connections inferred from geometry: bodies that touch or overlap.

Most BIM tools (Revit among them) export no ``IfcRelConnectsWithRealizingElements``, so the joint graph
a construction simulation needs must often be inferred from the geometry. Two elements are connected
when their bodies intersect or their surfaces come within ``tolerance`` metres of each other.

Broad phase: world axis-aligned boxes grown by the tolerance, sorted and swept along x. Narrow phase:
exact triangle-mesh collision and distance queries with FCL (``python-fcl``, the collision library
behind MoveIt and trimesh's CollisionManager) on bounding-volume hierarchies built once per mesh.
Limitation: a body completely inside another one without its surface coming within the tolerance
(e.g. a rebar cast inside a footing) is not reported, since only surfaces are compared.

Direction: the relating element is the one whose body reaches lower (smaller world z minimum), i.e.
usually the supporting one; ties keep file order.
"""

from __future__ import annotations

import numpy as np

from bimrobot.bim.model import BuildingModel, Connection, Element
from bimrobot.core.errors import require_extra


def candidate_pairs(boxes: np.ndarray, tolerance: float) -> list[tuple[int, int]]:
    """Index pairs (i < j) whose boxes, each grown by ``tolerance``, overlap. ``boxes``: (n, 2, 3) metres."""
    lower = boxes[:, 0, :] - tolerance
    upper = boxes[:, 1, :] + tolerance
    order = np.argsort(lower[:, 0], kind="stable")
    sorted_lower_x = lower[order, 0]
    pairs = []
    for rank, i in enumerate(order):
        end = np.searchsorted(sorted_lower_x, upper[i, 0], side="right")
        others = order[rank + 1 : end]
        if len(others) == 0:
            continue
        overlap = np.all((lower[others, 1:] <= upper[i, 1:]) & (upper[others, 1:] >= lower[i, 1:]), axis=1)
        pairs.extend((min(i, j), max(i, j)) for j in others[overlap])
    return sorted(pairs)


def infer_connections(model: BuildingModel, tolerance: float = 0.005) -> list[Connection]:
    """Connections between every two elements whose bodies touch or overlap within ``tolerance`` metres.

    Returned with ``inferred=True``, no GlobalId, no realizing elements and an empty connection type,
    ordered by (relating, related) file order.
    """
    fcl = require_extra("fcl", "all")
    elements = list(model.elements.values())
    if len(elements) < 2:
        return []
    boxes = np.stack([e.world_bounds for e in elements])
    objects = _CollisionObjects(fcl)
    connections = []
    for i, j in candidate_pairs(boxes, tolerance):
        a, b = elements[i], elements[j]
        if not objects.within(a, b, tolerance):
            continue
        relating, related = (a, b) if boxes[i, 0, 2] <= boxes[j, 0, 2] else (b, a)
        connections.append(Connection(relating.global_id, related.global_id, inferred=True))
    order = {gid: k for k, gid in enumerate(model.elements)}
    return sorted(connections, key=lambda c: (order[c.relating_id], order[c.related_id]))


class _CollisionObjects:
    """FCL collision objects per element; the bounding-volume hierarchy is shared by equal meshes."""

    def __init__(self, fcl):
        self.fcl = fcl
        self.models: dict[int, object] = {}
        self.objects: dict[str, object] = {}

    def object_for(self, element: Element):
        if element.global_id not in self.objects:
            rotation = element.placement[:3, :3]
            if np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-6) and np.linalg.det(rotation) > 0:
                key, vertices = id(element.vertices), element.vertices
                transform = self.fcl.Transform(rotation, element.placement[:3, 3])
            else:  # a scaled or mirrored placement: FCL needs a rigid transform, so use world vertices
                key, vertices = element.global_id, element.world_vertices
                transform = self.fcl.Transform()
            if key not in self.models:
                model = self.fcl.BVHModel()
                model.beginModel(len(vertices), len(element.faces))
                model.addSubModel(np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(element.faces, dtype=np.int32))
                model.endModel()
                self.models[key] = model
            self.objects[element.global_id] = self.fcl.CollisionObject(self.models[key], transform)
        return self.objects[element.global_id]

    def within(self, a: Element, b: Element, tolerance: float) -> bool:
        """True when the bodies of ``a`` and ``b`` intersect or come within ``tolerance`` metres."""
        first, second = self.object_for(a), self.object_for(b)
        if self.fcl.collide(first, second, self.fcl.CollisionRequest(), self.fcl.CollisionResult()) > 0:
            return True
        distance = self.fcl.distance(first, second, self.fcl.DistanceRequest(), self.fcl.DistanceResult())
        return distance <= tolerance
