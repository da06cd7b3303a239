"""Poses: IFC placements to SDF x y z roll pitch yaw."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bimrobot.export.gazebo.layout import format_pose, pose_xyz_rpy, rigid


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """SciPy's Rotation (about 0.5 s of imports), imported when these tests run, not at collection."""
    global Rotation
    from scipy.spatial.transform import Rotation


@settings(max_examples=200)
@given(st.lists(st.floats(-np.pi, np.pi), min_size=3, max_size=3))
def test_rpy_rebuilds_the_rotation_in_sdf_convention(angles):
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", angles).as_matrix()
    matrix[:3, 3] = (1.5, -2.0, 3.25)
    x, y, z, roll, pitch, yaw = pose_xyz_rpy(matrix)
    # SDF: fixed axes, R = Rz(yaw) Ry(pitch) Rx(roll).
    rebuilt = Rotation.from_euler("z", yaw) * Rotation.from_euler("y", pitch) * Rotation.from_euler("x", roll)
    np.testing.assert_allclose(rebuilt.as_matrix(), matrix[:3, :3], atol=1e-9)
    assert (x, y, z) == (1.5, -2.0, 3.25)


def test_gimbal_lock_pose_is_still_exact():
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", [0.3, np.pi / 2, 0.2]).as_matrix()
    _, _, _, roll, pitch, yaw = pose_xyz_rpy(matrix)
    rebuilt = Rotation.from_euler("z", yaw) * Rotation.from_euler("y", pitch) * Rotation.from_euler("x", roll)
    np.testing.assert_allclose(rebuilt.as_matrix(), matrix[:3, :3], atol=1e-9)


def test_a_beam_along_y_gets_a_quarter_turn_yaw():
    matrix = np.array([[0, -1, 0, 2.0], [1, 0, 0, 0.0], [0, 0, 1, 4.0], [0, 0, 0, 1]], float)
    assert format_pose(matrix) == "2 0 4 0 0 1.570796327"


def test_rigid_removes_scale_and_round_off():
    matrix = np.diag([1.0000001, 0.9999999, 1.0, 1.0])
    np.testing.assert_allclose(rigid(matrix)[:3, :3], np.eye(3), atol=1e-12)
    assert pytest.approx(np.linalg.det(rigid(matrix)[:3, :3])) == 1.0


def test_the_far_away_warning_names_the_yard_when_only_the_yard_is_far(tmp_path, capsys, steel_frame_ifc):
    """A site whose yard lies 3 km out is the site's doing, not the model's: the warning says so."""
    from bimrobot.cli import main

    frame = steel_frame_ifc
    site = tmp_path / "far.yaml"
    site.write_text("yard: [[3000, 0], [3000, 2]]\n")
    assert main(["convert", str(frame), "-o", str(tmp_path / "pkg"), "--layout", "yard", "--site", str(site),
                 "--no-progress", "--no-maps", "--no-preview"]) == 0
    printed = capsys.readouterr()
    text = printed.out + printed.err
    assert "the yard lies up to 3003 m from the world origin" in text and "the building stands within 4 m" in text
    assert "the model lies" not in text
