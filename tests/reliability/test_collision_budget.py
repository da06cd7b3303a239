"""CoACD's convex decomposition is bounded by CPU time on one OpenMP thread, not by wall time: the
collision pieces of a scene do not depend on how loaded the machine is (issue 35, "same answer twice")."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

# found, not imported: CoACD runs in a forked process, and loaded in this one it makes a later
# `import rclpy` (the ROS 2 tests of the same run) crash with SIGSEGV
if importlib.util.find_spec("coacd") is None:
    pytest.skip("coacd is not installed (the physics extra)", allow_module_level=True)
if importlib.util.find_spec("trimesh") is None:
    pytest.skip("trimesh is not installed", allow_module_level=True)

from .conftest import tally  # noqa: E402

pytestmark = pytest.mark.chaos


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """trimesh and SciPy (about 1 s of imports, with networkx), imported when these tests run, not at collection."""
    global trimesh, collision, Body
    import trimesh

    from bimrobot.export.inertia import Body
    from bimrobot.export.mujoco import collision


def angle_body(length: float = 1.2, leg: float = 0.1, thickness: float = 0.01) -> Body:
    """An L100x10 angle 1.2 m long along x (m, local frame), a closed prism: a concave member."""
    outline = [(0, 0), (leg, 0), (leg, thickness), (thickness, thickness), (thickness, leg), (0, leg)]
    n = len(outline)
    vertices = np.array([(x, y, z) for x in (0.0, length) for y, z in outline], float)
    cap = [(3, 0, 1), (3, 1, 2), (3, 4, 5), (3, 5, 0)]  # a fan from the inner corner (3), which sees every edge
    faces = [(a, c, b) for a, b, c in cap] + [(a + n, b + n, c + n) for a, b, c in cap]
    for k in range(n):
        j = (k + 1) % n
        faces += [(k, j, j + n), (k, j + n, k + n)]
    faces = np.array(faces)
    if trimesh.Trimesh(vertices, faces, process=False).volume < 0:
        faces = faces[:, ::-1]
    return Body(vertices, faces)


def test_an_angle_is_decomposed_the_same_way_twice():
    first, second = collision.collision_pieces(angle_body()), collision.collision_pieces(angle_body())
    assert first.method.startswith("CoACD") and first.method == second.method
    assert len(first.pieces) == len(second.pieces) >= 2
    for (v1, f1), (v2, f2) in zip(first.pieces, second.pieces):
        assert np.array_equal(v1, v2) and np.array_equal(f1, f2)
    tally("collision budget")


def test_a_decomposition_over_its_cpu_budget_keeps_the_hull_and_says_so(monkeypatch):
    # a search far longer than 1 s of CPU: the kernel stops it (RLIMIT_CPU), however loaded the machine
    monkeypatch.setattr(collision, "TIME_BUDGET_S", 1)
    monkeypatch.setattr(collision, "COACD_SETTINGS",
                        dict(collision.COACD_SETTINGS, threshold=0.001, mcts_iterations=5000, mcts_nodes=40))
    result = collision.collision_pieces(angle_body())
    assert result.method == "convex hull (CoACD over its 1 s CPU budget)"
    assert len(result.pieces) == 1
    tally("collision budget")


def test_the_command_process_never_loads_coacd(tmp_path):
    """`import coacd` then `import rclpy` in one process segfaults: `convert --target mujoco`'s check for
    the physics extra and the decomposition itself leave CoACD out of the command's process."""
    import subprocess
    import sys

    body = angle_body()
    np.savez(tmp_path / "angle.npz", vertices=body.vertices, faces=body.faces)
    code = (f"import sys, numpy as np\n"
            f"from bimrobot.export.mujoco import collision\nfrom bimrobot.export.inertia import Body\n"
            f"collision.require_coacd()\nd = np.load({str(tmp_path / 'angle.npz')!r})\n"
            f"print(collision.collision_pieces(Body(d['vertices'], d['faces'])).method, 'coacd' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    method, loaded = done.stdout.split("\n")[-2].rsplit(" ", 1)
    assert method.startswith("CoACD (") and loaded == "False"
    tally("collision budget")
