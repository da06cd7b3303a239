"""SDF text for models, model.config files and worlds (SDF 1.9 for Gazebo Sim, 1.6 for Gazebo Classic).

A building element becomes one model with one link, both named by the element's safe GlobalId
(:func:`bimrobot.core.names.safe_name`): the thesis' mapping (fig. 3.3). The link frame is the
element's local IFC frame, so the meshes are the local ones and the pose is the placement.
Meshes are referenced as ``model://<name>/meshes/...``, which both simulators resolve through their
resource path (``GZ_SIM_RESOURCE_PATH`` / ``GAZEBO_MODEL_PATH``, set by the generated launch files).

World-level choices: the Gazebo Sim world lists no ``<plugin>``, so Gazebo Sim loads its default
systems (physics, user commands, scene broadcaster) whatever its release (Fortress, Harmonic, ...);
adding a plugin to the world disables those defaults, so a user who adds one must list them all.
The ground is an inline static plane (no ``model://ground_plane`` download needed).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from bimrobot.core.io import printable
from bimrobot.export.gazebo.layout import format_pose

SIM_VERSION = "1.9"
CLASSIC_VERSION = "1.6"


@dataclass(frozen=True)
class ModelSpec:
    """Everything one model.sdf says. Mass in kg, centre of mass in the link frame (m), inertia about
    it (3x3, kg m^2), pose 4x4 local-to-world (m)."""

    name: str
    pose: np.ndarray
    static: bool
    mass: float
    center_of_mass: np.ndarray
    inertia: np.ndarray
    visual_uri: str
    collision_uri: str


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attributes: str) -> ET.Element:
    # XML 1.0 cannot hold most control characters, not even as character references: names and
    # descriptions from the model are written with them escaped (bimrobot.core.io.printable).
    child = ET.SubElement(parent, tag, {key: printable(value) for key, value in attributes.items()})
    if text is not None:
        child.text = printable(text)
    return child


def _to_text(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _g(value: float) -> str:
    text = f"{value:.9g}"
    return "0" if text == "-0" else text


def model_element(spec: ModelSpec) -> ET.Element:
    """The ``<model>`` element of one building element."""
    model = ET.Element("model", name=printable(spec.name))
    _sub(model, "static", "true" if spec.static else "false")
    _sub(model, "pose", format_pose(spec.pose))
    link = _sub(model, "link", name=spec.name)
    inertial = _sub(link, "inertial")
    com = spec.center_of_mass
    _sub(inertial, "pose", f"{_g(com[0])} {_g(com[1])} {_g(com[2])} 0 0 0")
    _sub(inertial, "mass", _g(spec.mass))
    inertia = _sub(inertial, "inertia")
    tensor = spec.inertia
    for tag, (row, col) in (
        ("ixx", (0, 0)),
        ("ixy", (0, 1)),
        ("ixz", (0, 2)),
        ("iyy", (1, 1)),
        ("iyz", (1, 2)),
        ("izz", (2, 2)),
    ):
        _sub(inertia, tag, _g(tensor[row, col]))
    collision = _sub(link, "collision", name="collision")
    _sub(_sub(_sub(collision, "geometry"), "mesh"), "uri", spec.collision_uri)
    visual = _sub(link, "visual", name="visual")
    _sub(_sub(_sub(visual, "geometry"), "mesh"), "uri", spec.visual_uri)
    return model


# model.sdf and model.config are written once per element, so they are filled into text templates (about
# five times faster than building and serialising an ElementTree); the text is exactly what the tree
# gives (tests/export/test_package.py compares them), escaping included.


def _text(value: str) -> str:
    """An XML text node's content, escaped as ElementTree escapes it (after :func:`printable`)."""
    return printable(value).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _attr(value: str) -> str:
    """An XML attribute's value, escaped as ElementTree escapes it (after :func:`printable`)."""
    return (printable(value).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")
            .replace("\r", "&#13;").replace("\n", "&#10;").replace("\t", "&#09;"))


_MODEL_SDF = """<?xml version="1.0"?>
<sdf version="{version}">
  <model name="{name}">
    <static>{static}</static>
    <pose>{pose}</pose>
    <link name="{name}">
      <inertial>
        <pose>{com} 0 0 0</pose>
        <mass>{mass}</mass>
        <inertia>
          <ixx>{ixx}</ixx>
          <ixy>{ixy}</ixy>
          <ixz>{ixz}</ixz>
          <iyy>{iyy}</iyy>
          <iyz>{iyz}</iyz>
          <izz>{izz}</izz>
        </inertia>
      </inertial>
      <collision name="collision">
        <geometry>
          <mesh>
            <uri>{collision_uri}</uri>
          </mesh>
        </geometry>
      </collision>
      <visual name="visual">
        <geometry>
          <mesh>
            <uri>{visual_uri}</uri>
          </mesh>
        </geometry>
      </visual>
    </link>
  </model>
</sdf>
"""


def model_sdf(spec: ModelSpec, version: str = SIM_VERSION) -> str:
    """A complete model.sdf (the text of ``<sdf>`` around :func:`model_element`)."""
    com, tensor = spec.center_of_mass, spec.inertia
    return _MODEL_SDF.format(
        version=_attr(version),
        name=_attr(spec.name),
        static="true" if spec.static else "false",
        pose=_text(format_pose(spec.pose)),
        com=f"{_g(com[0])} {_g(com[1])} {_g(com[2])}",
        mass=_g(spec.mass),
        ixx=_g(tensor[0, 0]), ixy=_g(tensor[0, 1]), ixz=_g(tensor[0, 2]),
        iyy=_g(tensor[1, 1]), iyz=_g(tensor[1, 2]), izz=_g(tensor[2, 2]),
        collision_uri=_text(spec.collision_uri),
        visual_uri=_text(spec.visual_uri),
    )


def model_config(name: str, sdf_files: dict[str, str], description: str) -> str:
    """model.config: ``sdf_files`` maps SDF version -> file name (Gazebo picks the best it supports)."""
    sdf_lines = "".join(f'  <sdf version="{_attr(version)}">{_text(file_name)}</sdf>\n'
                        for version, file_name in sdf_files.items())
    return (
        '<?xml version="1.0"?>\n<model>\n'
        f"  <name>{_text(name)}</name>\n  <version>1.0</version>\n{sdf_lines}"
        "  <author>\n    <name>bimrobot (generated from IFC)</name>\n    <email />\n  </author>\n"
        f"  <description>{_text(description)}</description>\n</model>\n"
    )


def model_config_tree(name: str, sdf_files: dict[str, str], description: str) -> ET.Element:
    """The ``<model>`` tree that :func:`model_config` writes as text."""
    root = ET.Element("model")
    _sub(root, "name", name)
    _sub(root, "version", "1.0")
    for version, file_name in sdf_files.items():
        _sub(root, "sdf", file_name, version=version)
    author = _sub(root, "author")
    _sub(author, "name", "bimrobot (generated from IFC)")
    _sub(author, "email", "")
    _sub(root, "description", description)
    return root


@dataclass(frozen=True)
class Include:
    """One model placed in the world: its ``model://`` name and 4x4 pose (m)."""

    name: str
    pose: np.ndarray


def world_sdf(
    world_name: str,
    includes: list[Include],
    version: str = SIM_VERSION,
    ground_z: float = 0.0,
    ground_size: tuple[float, float] = (100.0, 100.0),
    ground_center: tuple[float, float] = (0.0, 0.0),
    step_size: float = 0.001,
) -> str:
    """A world with physics, gravity, a sun, a ground plane and every model included at its pose.

    ``version`` "1.9" writes the Gazebo Sim flavour, "1.6" the Gazebo Classic one (ODE physics
    parameters, the same inline sun and ground).
    """
    root = ET.Element("sdf", version=version)
    world = _sub(root, "world", name=world_name)
    physics_attributes = {"name": "default_physics", "type": "ode"} if version == CLASSIC_VERSION else {
        "name": "default_physics",
        "type": "ignored",
    }
    physics = _sub(world, "physics", **physics_attributes)
    _sub(physics, "max_step_size", _g(step_size))
    _sub(physics, "real_time_factor", "1")
    _sub(physics, "real_time_update_rate", _g(1.0 / step_size))
    _sub(world, "gravity", "0 0 -9.80665")
    scene = _sub(world, "scene")
    _sub(scene, "ambient", "0.4 0.4 0.4 1")
    _sub(scene, "background", "0.7 0.8 0.9 1")
    _sub(scene, "shadows", "true")
    _add_sun(world)
    _add_ground(world, ground_z, ground_size, ground_center)
    for include in includes:
        element = _sub(world, "include")
        _sub(element, "uri", f"model://{include.name}")
        _sub(element, "name", include.name)
        _sub(element, "pose", format_pose(include.pose))
    return _to_text(root)


def _add_sun(world: ET.Element) -> None:
    sun = _sub(world, "light", type="directional", name="sun")
    _sub(sun, "cast_shadows", "true")
    _sub(sun, "pose", "0 0 50 0 0 0")
    _sub(sun, "diffuse", "0.8 0.8 0.8 1")
    _sub(sun, "specular", "0.2 0.2 0.2 1")
    attenuation = _sub(sun, "attenuation")
    _sub(attenuation, "range", "1000")
    _sub(attenuation, "constant", "0.9")
    _sub(attenuation, "linear", "0.01")
    _sub(attenuation, "quadratic", "0.001")
    _sub(sun, "direction", "-0.5 0.1 -0.9")


def _add_ground(world: ET.Element, ground_z: float, size: tuple[float, float], center: tuple[float, float]) -> None:
    model = _sub(world, "model", name="ground_plane")
    _sub(model, "static", "true")
    _sub(model, "pose", f"{_g(center[0])} {_g(center[1])} {_g(ground_z)} 0 0 0")
    link = _sub(model, "link", name="link")
    size_text = f"{_g(size[0])} {_g(size[1])}"
    collision = _sub(link, "collision", name="collision")
    plane = _sub(_sub(collision, "geometry"), "plane")
    _sub(plane, "normal", "0 0 1")
    _sub(plane, "size", size_text)
    visual = _sub(link, "visual", name="visual")
    _sub(visual, "cast_shadows", "false")
    plane = _sub(_sub(visual, "geometry"), "plane")
    _sub(plane, "normal", "0 0 1")
    _sub(plane, "size", size_text)
    material = _sub(visual, "material")
    _sub(material, "ambient", "0.6 0.6 0.55 1")
    _sub(material, "diffuse", "0.6 0.6 0.55 1")
    _sub(material, "specular", "0.1 0.1 0.1 1")
