"""One frames module: each consumer gets the quaternion order and the angles it reads."""

import math

import numpy as np
import pytest

from bimrobot.core import frames


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """SciPy's Rotation (about 0.5 s of imports), imported when these tests run, not at collection."""
    global Rotation
    from scipy.spatial.transform import Rotation


def _rotations():
    turns = [Rotation.random(random_state=seed).as_matrix() for seed in range(20)]
    return turns + [frames.matrix_of_rpy(0.3, math.pi / 2, 1.1), frames.matrix_of_rpy(0.0, -math.pi / 2, -2.0)]


def test_sdf_angles_give_back_the_rotation_and_keep_yaw_at_gimbal_lock():
    for rotation in _rotations():  # arcsin near pitch = +-pi/2 keeps about 8 digits
        assert frames.matrix_of_rpy(*frames.rpy_of(rotation)) == pytest.approx(rotation, abs=1e-7)
    roll, pitch, yaw = frames.rpy_of(frames.matrix_of_rpy(0.3, math.pi / 2, 1.1))
    assert (roll, pitch, yaw) == pytest.approx((0.0, math.pi / 2, 0.8), abs=1e-7)  # Rz(1.1) Ry(pi/2) Rx(0.3): the turn is 1.1 - 0.3
    pose = frames.sdf_pose_matrix(1.0, 2.0, 3.0, 0.0, 0.0, math.pi / 2)
    assert pose @ [1.0, 0.0, 0.0, 1.0] == pytest.approx([1.0, 3.0, 3.0, 1.0])  # x turned onto +y, then moved


def test_mujoco_reads_the_wxyz_quaternion_as_the_rotation_it_came_from():
    mujoco = pytest.importorskip("mujoco")
    rotation = frames.matrix_of_rpy(0.2, -0.4, 2.5)
    quat = frames.quat_wxyz(rotation)
    xml = f'<mujoco><worldbody><body name="b" quat="{" ".join(map(str, quat))}"><geom size="0.1"/></body></worldbody></mujoco>'
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    assert data.body("b").xmat.reshape(3, 3) == pytest.approx(rotation, abs=1e-9)
    assert frames.matrix_of_quat_wxyz(quat) == pytest.approx(rotation, abs=1e-12)
    # Rerun and ROS take (x, y, z, w): the same rotation for scipy's default order
    assert Rotation.from_quat(frames.xyzw_of_wxyz(quat)).as_matrix() == pytest.approx(rotation, abs=1e-12)


def test_ros_yaw_quaternions_are_xyzw_and_read_back():
    x, y, z, w = frames.quat_xyzw_of_yaw(math.pi / 2)
    assert (x, y, z, w) == pytest.approx((0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)))
    for yaw in np.linspace(-3.0, 3.0, 13):
        assert frames.yaw_of_quat_xyzw(*frames.quat_xyzw_of_yaw(yaw)) == pytest.approx(yaw, abs=1e-12)
        assert frames.yaw_of(frames.planar_transform(1.0, 2.0, yaw)) == pytest.approx(yaw, abs=1e-12)
    down = frames.tool_down(0.5)
    assert down[:, 2] == pytest.approx([0.0, 0.0, -1.0]) and frames.yaw_of(down) == pytest.approx(0.5)
