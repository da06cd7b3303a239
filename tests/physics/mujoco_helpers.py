"""Helpers of the MuJoCo tests: the world tests' trimesh frame, loaded without importing their package."""

import importlib.util
from pathlib import Path

_spec = importlib.util.spec_from_file_location("world_fixtures", Path(__file__).parents[1] / "export" / "conftest.py")
world_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(world_fixtures)

#: Table 5.2: which robot type performs which activity (the head of a capability table)
ROBOT_TYPES = """
robot_types:
  mobile_base: {activities: [move_to_component, transport]}
  manipulator: {activities: [position_for_picking_up, position_for_installing]}
  gripper: {activities: [pick_up, install]}
"""


def ur5_robots_at(tmp_path, homes: dict[str, tuple[float, float]]):
    """A mujoco backend with UR5-family robots (5 kg, 0.85 m reach; Husky footprint 0.99 x 0.67 m)
    at ``homes`` (name -> x, y m)."""
    from bimrobot.rcan.backends import create_backend
    from bimrobot.rcan.generation import load_capabilities

    table = tmp_path / "robots.yaml"
    table.write_text(ROBOT_TYPES + "robots:\n" + "".join(
        f"  {name}:\n    types: [mobile_base, manipulator, gripper]\n    payload_kg: 5.0\n    reach_m: 0.85\n"
        f"    home: [{x}, {y}, 0.0]\n" for name, (x, y) in homes.items()))
    return create_backend("mujoco", load_capabilities(str(table)))
