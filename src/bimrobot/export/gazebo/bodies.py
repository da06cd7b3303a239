"""The distinct bodies of a package's elements and their mesh files' content, each made once.

IFC files share one mesh between many elements (mapped representations), and some exporters write the
same body anew for every element (Tekla's precast parts); either way a body's merged vertices, convex
hull, mass integrals, collision STL and DAE text depend on its numbers alone, so they are made once per
distinct body (:class:`Geometries`) and every element that has it shares them. Units: metres, local frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from bimrobot.bim.model import Element
from bimrobot.export.gazebo import meshes

if TYPE_CHECKING:  # mass properties need trimesh and SciPy: imported where the bodies are made
    from bimrobot.export import inertia as physics
    from bimrobot.export.gazebo.options import ConvertOptions


@dataclass
class Geometry:
    """One distinct body (shared by every element that has it) and its mesh files' content (made by
    :meth:`finish` in the process that writes the models)."""

    body: physics.Body
    collision: tuple[np.ndarray, np.ndarray] | None = None
    stl: bytes = b""
    dae: dict[str, str] = field(default_factory=dict)  # IFC class -> DAE text (colour per class)

    def finish(self, options: "ConvertOptions") -> None:
        """Collision mesh and its STL, once per geometry."""
        if self.collision is None:
            self.collision = meshes.collision_mesh(self.body, options.collision, options.max_triangles)
            self.stl = meshes.stl_bytes(*self.collision)

    def dae_for(self, ifc_class: str) -> str:
        if ifc_class not in self.dae:
            self.dae[ifc_class] = meshes.dae_text(self.body.vertices, self.body.faces, ifc_class,
                                                  meshes.colour_of(ifc_class))
        return self.dae[ifc_class]


class Geometries:
    """One :class:`Geometry` per distinct body: elements whose meshes are the same arrays (a shared IFC
    representation) or hold the same numbers (a body exported once per element, as Tekla does: GEELEN's
    279 elements have 52 distinct bodies, MULTICOM-Prefab's 301 have 121) get the same one, so its
    merged vertices, hull, mass integrals, STL and DAE are made once. Equal input, equal output: the
    package is the same as with one per element."""

    def __init__(self):
        self._by_arrays: dict[tuple[int, int], Geometry] = {}
        self._by_content: dict[tuple, Geometry] = {}

    def of(self, element: Element) -> Geometry:
        from bimrobot.export.inertia import Body  # trimesh and SciPy: imported by the work that needs them

        arrays = (id(element.vertices), id(element.faces))
        if arrays not in self._by_arrays:
            vertices, faces = np.asarray(element.vertices), np.asarray(element.faces)
            content = (vertices.dtype.str, vertices.shape, faces.dtype.str, faces.shape,
                       vertices.tobytes(), faces.tobytes())
            if content not in self._by_content:
                self._by_content[content] = Geometry(Body(vertices, faces))
            self._by_arrays[arrays] = self._by_content[content]
        return self._by_arrays[arrays]
