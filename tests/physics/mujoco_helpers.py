"""Helpers of the MuJoCo tests: the world tests' trimesh frame, loaded without importing their package."""

import importlib.util
from pathlib import Path

_spec = importlib.util.spec_from_file_location("world_fixtures", Path(__file__).parents[1] / "world" / "conftest.py")
world_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(world_fixtures)
