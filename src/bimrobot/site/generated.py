"""Generated buildings for training and scaling studies (issue 38): steel frames, precast column-beam-slab
frames, panel buildings and cross-wall buildings with precast floor plates, with a random fleet and a site,
all drawn from one seed.

The building is a real IFC4 file written by :func:`bimrobot.bim.examples.generated_building` (metres, kg,
z up), so every command reads it exactly as it reads a user's model. This module draws its shape
(:class:`~bimrobot.bim.examples.Layout`: grid, bays, storey height, sections, fasteners per node), a
fleet varied from a built-in one (robots per kind, speeds and handling times) and a site derived from
the building (:func:`bimrobot.site.site.derive_site`), and parses the ``generated:`` model spec.

Specs (usable wherever a model path is)::

    generated:6x6x4                      the in-memory steel frame of bimrobot.coordination.generate (no file)
    generated:precast:4x3x5:seed=7       a precast frame of 4 x 3 column lines and 5 floors, seed 7
    generated:steel:1000                 a steel frame of about 1,000 components (the grid drawn from seed 0)
    generated:panel:3x2x2:bolts=3        a panel building of 3 x 2 bays, 2 floors, 3 fasteners per node
    generated:plates:4x3x2               a cross-wall building of 4 bays, 3 floor plates per bay, 2 floors

Real IFC models are never generated or trained on: they are the test set.
"""

from __future__ import annotations

import hashlib
import os
import re
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from bimrobot.core.errors import InputError

#: The kinds of generated building (bimrobot.bim.examples.BUILDING_KINDS, repeated to keep imports light).
KINDS = ("steel", "precast", "panel", "plates")
#: Bump when the same spec would write a different file (the cache of generated models is keyed on it).
GENERATOR_VERSION = 1
MAX_COMPONENTS = 20_000
_SPEC = re.compile(r"^generated:(?P<kind>[a-z]+):(?P<size>[^:]+)(?P<options>(:[a-z]+=[^:]*)*)$")
_DIMS = re.compile(r"^(\d+)x(\d+)x(\d+)$")

#: Ranges a layout is drawn from, per kind: bay_x, bay_y (m), storey heights (m), fasteners per node.
#: Steel: the chapter-4 sections, spans whose beams stay under fleet2's 300 kg and columns 4 m high at
#: most (fleet2's 4 m reach). Precast: office-frame grids (5-8 m by 4.8-7.2 m). Panel: housing bays.
#: Plates: cross-wall housing, 3.6-6 m between bearing walls, floor plates 2.0-3.0 m wide (transportable).
RANGES = {
    "steel": ((2.8, 6.0), (2.8, 4.5), (3.0, 3.5, 4.0), (2, 8)),
    "precast": ((5.0, 8.0), (4.8, 7.2), (3.0, 3.3, 3.6), (2, 4)),
    "panel": ((3.0, 5.4), (3.6, 6.0), (2.7, 2.8, 3.0), (2, 4)),
    "plates": ((3.6, 6.0), (2.0, 3.0), (2.7, 2.8, 3.0), (2, 4)),  # span between wall lines, plate width
}
#: The built-in fleet each kind's random fleet is varied from (precast and panel units weigh tonnes).
BASE_FLEETS = {"steel": ("fleet1", "fleet2"), "precast": ("site-crane",), "panel": ("site-crane",),
               "plates": ("site-crane",)}


@dataclass(frozen=True)
class Spec:
    """A parsed ``generated:KIND:SIZE[:seed=S][:bolts=B]`` spec: ``dims`` (nx, ny, floors) or ``components``."""

    kind: str
    dims: tuple[int, int, int] | None
    components: int | None
    seed: int = 0
    bolts: int | None = None

    def text(self) -> str:
        size = "x".join(map(str, self.dims)) if self.dims else str(self.components)
        bolts = f":bolts={self.bolts}" if self.bolts is not None else ""
        return f"generated:{self.kind}:{size}:seed={self.seed}{bolts}"


def is_generated(spec: str) -> bool:
    """Whether ``spec`` names a generated building written as an IFC file (not the in-memory ``NXxNYxF``)."""
    return isinstance(spec, str) and spec.startswith("generated:") and not _DIMS.match(spec[len("generated:"):])


def parse_spec(text: str) -> Spec:
    """The :class:`Spec` of ``text``; InputError with one sentence when it is malformed."""
    match = _SPEC.match(text)
    if not match:
        raise InputError(f"{text!r} is not a generated-building spec: expected generated:KIND:NXxNYxFLOORS or "
                         f"generated:KIND:COMPONENTS, optionally :seed=S and :bolts=B (KIND {', '.join(KINDS)})")
    kind = match["kind"]
    if kind not in KINDS:
        raise InputError(f"{text!r}: building kind must be one of {', '.join(KINDS)}, got {kind!r}")
    options = {}
    for item in filter(None, match["options"].split(":")):
        key, _, value = item.partition("=")
        if key not in ("seed", "bolts") or not value.isdigit():
            raise InputError(f"{text!r}: option {item!r} must be seed=S or bolts=B with a whole number")
        options[key] = int(value)
    dims, components = _size(text, kind, match["size"])
    bolts = options.get("bolts")
    if bolts is not None and not 1 <= bolts <= 12:
        raise InputError(f"{text!r}: bolts per node must be from 1 to 12, got {bolts}")
    return Spec(kind, dims, components, options.get("seed", 0), bolts)


def _size(text: str, kind: str, size: str) -> tuple[tuple[int, int, int] | None, int | None]:
    dims = _DIMS.match(size)
    if dims:
        nx, ny, floors = (int(v) for v in dims.groups())
        if min(nx, ny, floors) < 1:
            raise InputError(f"{text!r}: NX, NY and FLOORS must be at least 1")
        count = _count(kind, nx, ny, floors)
        if count > MAX_COMPONENTS:
            raise InputError(f"{text!r}: at most {MAX_COMPONENTS:,} components, this building has {count:,}")
        return (nx, ny, floors), None
    if size.isdigit() and 1 <= int(size) <= MAX_COMPONENTS:
        return None, int(size)
    raise InputError(f"{text!r}: the size must be NXxNYxFLOORS or a number of components from 1 to {MAX_COMPONENTS:,}, got {size!r}")


def _count(kind: str, nx: int, ny: int, floors: int) -> int:
    from bimrobot.bim.examples import building_components

    return building_components(kind, nx, ny, floors)


def grid_for(kind: str, components: int, rng: np.random.Generator) -> tuple[int, int, int]:
    """(nx, ny, floors) whose component count is closest to ``components``, with a plan no longer than
    3 x its width. The number of floors is drawn first, from half the cube root of ``components`` to the
    cube root (at most 12: small buildings are not towers, large ones not one storey); then, among the grids of that
    many floors within 2 % (or 2 components) of the count, one is drawn. Where no grid of that many
    floors comes so close, the draw is among the closest grids of any number of floors."""
    found: dict[tuple[int, int, int], int] = {}
    most = min(12, max(1, round(components ** (1 / 3))))
    for floors in range(1, most + 1):
        for nx in range(1, 160):
            for ny in range(max(1, -(-nx // 3)), 3 * nx + 1):  # plans up to 3 x as long as wide, either way
                count = _count(kind, nx, ny, floors)
                if count > components * 1.05 + 5:
                    break
                found[nx, ny, floors] = abs(count - components)
    tolerance = max(2, 0.02 * components)
    floors = int(rng.integers(max(1, -(-most // 2)), most + 1))
    near = sorted(g for g, err in found.items() if g[2] == floors and err <= tolerance)
    if not near:
        best = min(found.values())
        near = sorted(g for g, err in found.items() if err <= max(best, tolerance))
    return near[int(rng.integers(len(near)))]


def draw_layout(spec: Spec):
    """The :class:`~bimrobot.bim.examples.Layout` of ``spec``, drawn from its seed (bays, storey height,
    fasteners per node; the grid too when the spec gives a number of components)."""
    from bimrobot.bim.examples import Layout

    rng = np.random.default_rng([spec.seed, KINDS.index(spec.kind)])
    (bx, by, heights, bolts) = RANGES[spec.kind]
    bay_x = round(float(rng.uniform(*bx)), 1)
    bay_y = round(float(rng.uniform(*by)), 1)
    height = float(heights[int(rng.integers(len(heights)))])
    per_node = int(rng.integers(bolts[0], bolts[1] + 1))
    dims = spec.dims or grid_for(spec.kind, spec.components, rng)
    return Layout(spec.kind, *dims, bay_x=bay_x, bay_y=bay_y, storey_height=height,
                  bolts_per_node=spec.bolts or per_node, name=f"{spec.text()} ({'x'.join(map(str, dims))})")


def draw_fleet(spec: Spec, layout):
    """A fleet varied from a built-in one: fleet1 or fleet2 for a steel frame whose members fit those
    robots, else site-crane (:data:`BASE_FLEETS`). 1-3 robots of each kind, each a copy of one of the base
    fleet's robots of that kind with its speed and handling times scaled by 0.8-1.25 (same limits), so
    the fleet can build ``layout``. Seeded by ``spec.seed``."""
    from bimrobot.site.fleet import fleet_from_dict, fleet_to_dict, load_fleet

    rng = np.random.default_rng([spec.seed, KINDS.index(spec.kind), 1])
    names = BASE_FLEETS[spec.kind] if _fits_small_robots(layout) else ("site-crane",)
    base = fleet_to_dict(load_fleet(names[int(rng.integers(len(names)))]))
    by_kind: dict[str, list[dict]] = {}
    for robot in base["robots"]:
        by_kind.setdefault(robot["kind"], []).append(robot)
    robots = []
    for kind, choices in by_kind.items():
        for number in range(1, int(rng.integers(1, 4)) + 1):
            robot = dict(choices[int(rng.integers(len(choices)))])
            robot["name"] = f"{robot['name']}-{number}"
            for key in ("speed_m_s", "time_per_node_s", "time_per_point_s", "load_s", "unload_s"):
                if robot.get(key):
                    robot[key] = round(float(robot[key]) * float(rng.uniform(0.8, 1.25)), 2)
            robots.append(robot)
    data = {"version": base["version"], "name": f"{spec.kind}-seed{spec.seed}-from-{base['name']}", "robots": robots}
    return fleet_from_dict(data, f"generated fleet of {spec.text()}")


#: What the chapter-4 robots (fleet1, fleet2) take: 300 kg, members up to 4 m long (their 4 x 1 m
#: platform), work up to 4 m above their floor.
SMALL_ROBOT_LIMITS = (300.0, 4.0, 4.0)


def _fits_small_robots(layout) -> bool:
    """Whether a steel ``layout``'s members fit the chapter-4 robots (:data:`SMALL_ROBOT_LIMITS`)."""
    kg, length, reach = SMALL_ROBOT_LIMITS
    if layout.kind != "steel" or layout.storey_height > reach:
        return False
    longest_beam = max(layout.bay_x, layout.bay_y) - layout.column.depth
    return (longest_beam <= length and layout.beam.mass_per_m * longest_beam <= kg
            and layout.column.mass_per_m * layout.storey_height <= kg)


def draw_site(spec: Spec, layout):
    """The site derived from the building's footprint (:func:`bimrobot.site.site.derive_site`: yard east of it,
    robot homes south of it), with idle robots staying or driving back to the yard, drawn by the seed."""
    from bimrobot.site.site import derive_site

    rng = np.random.default_rng([spec.seed, KINDS.index(spec.kind), 2])
    margin = 0.6 if layout.kind == "steel" else 0.3  # footings 1.2 m wide; precast units, panels
    lines = layout.kind not in ("panel", "plates")  # nx, ny count grid lines, not bays
    width = (layout.nx - lines) * layout.bay_x
    depth = (layout.ny - lines) * layout.bay_y
    box = SimpleNamespace(world_bounds=np.array([[-margin, -margin, 0.0], [width + margin, depth + margin, 1.0]]))
    site = derive_site([box])
    return replace(site, idle_robots=("stay", "yard")[int(rng.integers(2))],
                   source=f"site derived from the generated building {spec.text()} (bimrobot.site.site.derive_site)")


@dataclass
class Generated:
    """A generated building: its IFC file, layout, fleet and site, and how many components it has."""

    spec: Spec
    layout: object
    path: Path
    fleet: object
    site: object

    @property
    def components(self) -> int:
        return self.layout.components()


def generate(spec: Spec | str, path: str | Path) -> Generated:
    """Write the building of ``spec`` to ``path`` (IFC4) and draw its fleet and site."""
    from bimrobot.bim.examples import generated_building

    spec = parse_spec(spec) if isinstance(spec, str) else spec
    layout = draw_layout(spec)
    generated_building(path, layout)
    return Generated(spec, layout, Path(path), draw_fleet(spec, layout), draw_site(spec, layout))


def cache_folder() -> Path:
    """Where ``generated:KIND:...`` models are written once and read again: ``$BIMROBOT_CACHE`` or
    ``$XDG_CACHE_HOME/bimrobot/generated`` (default ``~/.cache/bimrobot/generated``)."""
    if os.environ.get("BIMROBOT_CACHE"):
        return Path(os.environ["BIMROBOT_CACHE"])
    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return root / "bimrobot" / "generated"


def model_path(text: str) -> Path:
    """The IFC file of the spec ``text``, written into :func:`cache_folder` the first time it is asked for
    (the same spec always gives the same building, so a later run reads the file again)."""
    spec = parse_spec(text)
    from bimrobot import __version__

    digest = hashlib.sha1(f"{spec.text()} v{GENERATOR_VERSION} {__version__}".encode()).hexdigest()[:10]
    size = "x".join(map(str, spec.dims)) if spec.dims else f"{spec.components}c"
    path = cache_folder() / f"{spec.kind}-{size}-seed{spec.seed}{f'-b{spec.bolts}' if spec.bolts else ''}-{digest}.ifc"
    if not path.is_file():
        from bimrobot.bim.examples import generated_building

        generated_building(path, draw_layout(spec))
    return path


def summary(generated: Generated) -> dict:
    """What ``plan generate`` writes to ``generated.json``: the spec, the layout, the counts."""
    layout = asdict(generated.layout)
    for key in ("column", "beam"):
        layout[key] = layout[key]["name"]
    return {
        "spec": generated.spec.text(),
        "kind": generated.spec.kind,
        "seed": generated.spec.seed,
        "components": generated.components,
        "layout": layout,
        "fleet": generated.fleet.name,
        "robots": len(generated.fleet.robots),
        "units": {"length": "m", "mass": "kg"},
    }


__all__ = ["KINDS", "Spec", "Generated", "parse_spec", "is_generated", "draw_layout", "draw_fleet", "draw_site",
           "generate", "model_path", "cache_folder", "summary", "grid_for"]
