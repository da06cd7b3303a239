"""``bimrobot convert --target mujoco``: the converted building as one MJCF scene.

Written beside the Gazebo package (same models, maps and report), under ``mujoco/``::

    mujoco/scene.xml                 MJCF: ground, lights, site, one body per element
    mujoco/meshes/<id>.stl           visual mesh (local frame, metres)
    mujoco/meshes/<id>_c<k>.stl      convex collision pieces (bimrobot.export.mujoco.collision)

Every element is one body named by its IFC GlobalId, at its pose (installed placement, or its yard
pick-up pose), with ``<inertial>`` = the BIM mass, centre of mass and the full inertia tensor of
:mod:`bimrobot.export.inertia`. Installed (static) elements are bodies without joints: fixed to the
world. Elements on the yard (dynamic) get a free joint. The ground is a plane at the lowest storey's
elevation; the site (construction area, yard positions of the site file, and the yard rectangle of
``--layout yard``) is drawn on it as flat marks that nothing collides with.

Geom groups: 1 visual meshes (no contact), 3 collision pieces (not drawn by default), 0 ground/site.
Load it with ``mujoco.MjModel.from_xml_path("scene/mujoco/scene.xml")``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from bimrobot.core.frames import quat_wxyz as quaternion  # MuJoCo's (w, x, y, z), said in bimrobot.core.frames
from bimrobot.export.inertia import Body, MassProperties
from bimrobot.export.mujoco.collision import DEFAULT_BUDGET, collision_pieces

TIMESTEP_S = 0.002
"""Simulation step (s): 500 Hz, stable for the building's contacts and the robots' position servos."""

CLASS_RGBA = {"IfcColumn": "0.55 0.6 0.7 1", "IfcBeam": "0.45 0.55 0.75 1", "IfcMember": "0.6 0.5 0.4 1",
              "IfcPlate": "0.5 0.5 0.5 1", "IfcFooting": "0.7 0.7 0.65 1", "IfcSlab": "0.75 0.75 0.72 1",
              "IfcWall": "0.85 0.82 0.75 1", "IfcMechanicalFastener": "0.3 0.3 0.3 1"}
DEFAULT_RGBA = "0.7 0.7 0.7 1"


def _num(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


def scene_root(name: str, ground_z: float, extent_xy: np.ndarray | None = None) -> tuple[ET.Element, ET.Element, ET.Element]:
    """(mujoco root, asset, worldbody) of a scene with ground, lights and the simulation options."""
    root = ET.Element("mujoco", model=name)
    ET.SubElement(root, "compiler", angle="radian", meshdir="meshes", inertiafromgeom="false", autolimits="true")
    ET.SubElement(root, "option", timestep=f"{TIMESTEP_S}", gravity="0 0 -9.81", integrator="implicitfast",
                  cone="elliptic", impratio="10")
    visual = ET.SubElement(root, "visual")
    ET.SubElement(visual, "headlight", ambient="0.35 0.35 0.35", diffuse="0.5 0.5 0.5")
    ET.SubElement(visual, "global", offwidth="1280", offheight="960")
    asset = ET.SubElement(root, "asset")
    ET.SubElement(asset, "texture", name="grid", type="2d", builtin="checker", rgb1="0.42 0.45 0.40",
                  rgb2="0.38 0.41 0.36", width="512", height="512")
    ET.SubElement(asset, "material", name="ground", texture="grid", texrepeat="1 1", texuniform="true")
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", name="sun", directional="true", pos="0 0 50", dir="0.3 0.2 -1",
                  diffuse="0.7 0.7 0.7", castshadow="true")
    centre = np.zeros(2) if extent_xy is None else (extent_xy[0] + extent_xy[1]) / 2
    ET.SubElement(world, "geom", name="ground", type="plane", pos=_num([*centre, ground_z]), size="200 200 0.1",
                  material="ground", friction="0.8 0.005 0.0001")
    return root, asset, world


def add_mark(world: ET.Element, name: str, lower_xy, upper_xy, z: float, rgba: str) -> None:
    """A flat coloured rectangle on the ground that nothing collides with (site areas)."""
    lower, upper = np.asarray(lower_xy, float), np.asarray(upper_xy, float)
    half = np.maximum((upper - lower) / 2, 0.05)
    ET.SubElement(world, "geom", name=name, type="box", pos=_num([*((lower + upper) / 2), z + 0.001]),
                  size=_num([*half, 0.001]), rgba=rgba, contype="0", conaffinity="0", group="0")


def mjcf_text(root: ET.Element, what: str) -> str:
    """The MJCF document of ``root`` as well-formed XML 1.0: a header comment with the bimrobot
    signature (``what`` says what wrote it; a comment may not hold ``--``, so it is replaced), and every
    attribute value and text with its control characters written as escapes (``\\x0d``): XML 1.0 cannot
    hold most of them even as character references. A GlobalId or name from a damaged IFC file is thus
    kept legible, not dropped; lookups by such an id fail, as its schedule is refused before."""
    from bimrobot.core.io import printable, signature

    for element in root.iter():
        for key, value in element.attrib.items():
            element.set(key, printable(value))
        if element.text and not element.text.isspace():
            element.text = printable(element.text)
    ET.indent(root)
    comment = signature(what).replace("--", "- -")
    return f"<!-- {comment} -->\n{ET.tostring(root, encoding='unicode')}\n"


def write_mesh(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    trimesh.Trimesh(vertices, faces, process=False).export(path, file_type="stl")


def add_element_body(world, asset, meshes_dir: Path, global_id: str, file_name: str, pose: np.ndarray, mass,
                     body, ifc_class: str, free: bool, pieces) -> None:
    """One element: body named ``global_id`` at ``pose`` (4x4), inertial, visual mesh, collision pieces."""
    write_mesh(meshes_dir / f"{file_name}.stl", body.vertices, body.faces)
    ET.SubElement(asset, "mesh", name=f"{file_name}", file=f"{file_name}.stl")
    element = ET.SubElement(world, "body", name=global_id, pos=_num(pose[:3, 3]), quat=_num(quaternion(pose[:3, :3])))
    if free:
        ET.SubElement(element, "freejoint", name=f"{global_id}/free")
    inertia = mass.inertia
    ET.SubElement(element, "inertial", pos=_num(mass.center_of_mass), mass=f"{mass.mass:.9g}",
                  fullinertia=_num([inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]))
    ET.SubElement(element, "geom", name=f"{global_id}/visual", type="mesh", mesh=file_name, group="1",
                  contype="0", conaffinity="0", rgba=CLASS_RGBA.get(ifc_class, DEFAULT_RGBA))
    for k, (vertices, faces) in enumerate(pieces):
        piece = f"{file_name}_c{k}"
        write_mesh(meshes_dir / f"{piece}.stl", vertices, faces)
        ET.SubElement(asset, "mesh", name=piece, file=f"{piece}.stl")
        ET.SubElement(element, "geom", name=f"{global_id}/collision{k}", type="mesh", mesh=piece, group="3",
                      rgba="0.8 0.3 0.3 0.4", friction="0.8 0.005 0.0001")


def write_scene(package_dir: Path, converted: list, options, ground_z: float, yard=None,
                budget: int = DEFAULT_BUDGET) -> dict:
    """Write ``mujoco/`` into the package folder being written (``converted``: the package's elements,
    with ``element``, ``name``, ``pose``, ``mass``, ``body`` and ``geometry``); return the report entry
    {"scene": path, "collision": {GlobalId: method}, "free_bodies": n, ...}."""
    from bimrobot.site.site import site_for
    from bimrobot.export.gazebo.layout import site_offset

    folder = package_dir / "mujoco"
    meshes_dir = folder / "meshes"
    meshes_dir.mkdir(parents=True)
    elements = [item.element for item in converted]
    root, asset, world = scene_root("construction_site", ground_z)
    site = site_for(options.site, elements)
    offset = site_offset(elements, site)  # site frame -> model frame: subtract
    (x0, y0), (x1, y1) = site.construction_area
    add_mark(world, "site/construction_area", np.array([x0, y0]) - offset, np.array([x1, y1]) - offset,
             ground_z, "0.75 0.65 0.45 0.35")
    for k, (x, y) in enumerate(site.yard):
        xy = np.array([x, y]) - offset
        add_mark(world, f"site/yard_{k}", xy - 0.5, xy + 0.5, ground_z, "0.4 0.6 0.9 0.45")
    if yard is not None:
        add_mark(world, "site/yard", yard.bounds[0], yard.bounds[1], ground_z, "0.4 0.6 0.9 0.25")
    free = not options.is_static
    methods: dict[str, str] = {}
    by_geometry: dict[int, object] = {}  # elements sharing an IFC geometry share its decomposition
    for item in converted:
        key = id(item.geometry)
        if key not in by_geometry:
            by_geometry[key] = collision_pieces(item.body, budget)
        collision = by_geometry[key]
        methods[item.element.global_id] = collision.method
        add_element_body(world, asset, meshes_dir, item.element.global_id, item.name, item.pose, item.mass,
                         item.body, item.element.ifc_class, free, collision.pieces)
    (folder / "scene.xml").write_text(mjcf_text(root, "convert, MuJoCo target"), encoding="utf-8")
    counts: dict[str, int] = {}
    for method in methods.values():
        kind = method.split(" (")[0]
        counts[kind] = counts.get(kind, 0) + 1
    return {
        "scene": "mujoco/scene.xml",
        "timestep_s": TIMESTEP_S,
        "free_bodies": len(converted) if free else 0,
        "fixed_bodies": 0 if free else len(converted),
        "collision_budget": budget,
        "collision_methods": dict(sorted(counts.items())),
        "collision": methods,
    }


@dataclass(frozen=True)
class Settled:
    """Where a body came to rest in :func:`drop_on_ground`: pose (4x4, world), centre of mass (world,
    m), its speed (m/s) and angular speed (rad/s) at the end, and the seconds simulated."""

    pose: np.ndarray
    center_of_mass: np.ndarray
    speed: float
    angular_speed: float
    seconds: float


def drop_on_ground(pieces: list[tuple[np.ndarray, np.ndarray]], mass: MassProperties, pose: np.ndarray,
                   seconds: float = 2.0) -> Settled:
    """Drop a rigid body on a ground plane at z = 0 in MuJoCo and return where it rests.

    ``pieces``: convex collision pieces [(vertices, faces)] in the body frame (m; MuJoCo collides each
    as its hull), ``mass``: its mass properties, ``pose``: the 4x4 start pose. This is the check
    the project's physics engine makes of a converted element (it replaced pybullet's)."""
    import tempfile

    import mujoco

    with tempfile.TemporaryDirectory() as folder:  # MuJoCo reads meshes from files
        root, asset, world = scene_root("drop", 0.0)
        (Path(folder) / "meshes").mkdir()
        body = Body(*pieces[0])
        add_element_body(world, asset, Path(folder) / "meshes", "body", "body", pose, mass, body, "", True, pieces)
        (Path(folder) / "drop.xml").write_text(ET.tostring(root, encoding="unicode"), encoding="utf-8")
        model = mujoco.MjModel.from_xml_path(str(Path(folder) / "drop.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=int(round(seconds / model.opt.timestep)))
    moved = np.eye(4)
    moved[:3, :3] = data.body("body").xmat.reshape(3, 3)
    moved[:3, 3] = data.body("body").xpos
    return Settled(moved, data.body("body").xipos.copy(), float(np.linalg.norm(data.qvel[:3])),
                   float(np.linalg.norm(data.qvel[3:6])), seconds)
