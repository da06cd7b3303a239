"""How ``bimrobot convert`` converts: targets, layouts, collision meshes and every option of a conversion,
checked before any work (lengths in metres, densities in kg/m^3)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from bimrobot.bim.unknown_weight import UnknownWeightRule
from bimrobot.core.errors import InputError

if TYPE_CHECKING:  # the site module reads YAML and its schema: imported by the work that needs it
    from bimrobot.site.site import Site

TARGETS = ("sim", "classic", "both", "mujoco")  # mujoco: the sim package + mujoco/scene.xml
LAYOUTS = ("installed", "yard")
COLLISIONS = ("convex", "decimated")


@dataclass
class ConvertOptions:
    """How to convert. Lengths in metres, densities in kg/m^3.

    ``static``: None means static models for the installed layout and dynamic ones on the yard (where
    robots pick them up). ``merge_static``: merge the static elements into one model per storey and
    IFC class, except the components robots handle: the classes in ``keep_separate`` (IFC class names,
    subclasses count), which keep one model per element. ``workers``: processes for the per-model
    work (default: every core). ``map_band``: (low, high) above each storey's elevation. ``max_triangles``:
    triangle budget of each collision mesh. ``unknown_weight``: the rule for elements without a weight
    in the model (:mod:`bimrobot.bim.unknown_weight`; default: volume x 2400 kg/m3). ``preview``: draw
    ``preview.png``, a picture of the world (:mod:`bimrobot.export.gazebo.render`).
    """

    target: str = "sim"
    static: bool | None = None
    layout: str = "installed"
    collision: str = "convex"
    max_triangles: int = 500
    map_resolution: float = 0.05
    map_band: tuple[float, float] = (0.1, 1.5)
    map_margin: float = 1.0
    package_name: str | None = None
    unknown_weight: UnknownWeightRule = field(default_factory=UnknownWeightRule)
    maps: bool = True
    merge_static: bool = False
    keep_separate: tuple[str, ...] = ()
    workers: int | None = None
    preview: bool = True  # skipped above render.PREVIEW_MAX_TRIANGLES visual triangles
    site: Site | None = None  # where the yard is (--layout yard); None: bimrobot.site.site.site_for decides

    def validate(self) -> None:
        """Raise InputError naming the first option that is out of range."""
        checks = [
            (self.target in TARGETS, f"--target must be one of {', '.join(TARGETS)}, not {self.target!r}"),
            (self.layout in LAYOUTS, f"--layout must be one of {', '.join(LAYOUTS)}, not {self.layout!r}"),
            (self.collision in COLLISIONS, f"--collision must be one of {', '.join(COLLISIONS)}, not {self.collision!r}"),
            (self.max_triangles >= 4, f"--max-triangles must be at least 4 (a tetrahedron), not {self.max_triangles}"),
            (self.map_resolution > 0, f"--map-resolution must be positive, not {self.map_resolution}"),
            (self.map_band[0] < self.map_band[1], f"--map-band must be LOW HIGH with LOW < HIGH, not {self.map_band}"),
            (self.map_margin >= 0, f"--map-margin must not be negative, not {self.map_margin}"),
            (isinstance(self.unknown_weight, UnknownWeightRule),
             f"--unknown-weight must be a density in kg/m3 or 'refuse', not {self.unknown_weight!r}"),
            (not self.merge_static or self.is_static,
             "--merge-static merges static models, but these models are dynamic (--dynamic or --layout yard): "
             "leave out --merge-static or use --static"),
            (not self.keep_separate or self.merge_static, "--keep-separate only applies with --merge-static"),
            (self.workers is None or self.workers >= 1, f"workers must be at least 1, not {self.workers}"),
        ]
        for ok, message in checks:
            if not ok:
                raise InputError(message)

    @property
    def is_static(self) -> bool:
        """Whether the models are static (fixed in the world)."""
        return self.static if self.static is not None else self.layout == "installed"
