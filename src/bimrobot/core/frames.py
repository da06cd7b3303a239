"""Frames and rotations, said once: every part of bimrobot turns things with these functions.

Conventions
-----------
- **World (model) frame**: right-handed, z up, metres; the IFC project's world coordinates scaled to
  metres (:mod:`bimrobot.bim.reader`). Site, MuJoCo and Gazebo frames are this frame moved by the
  model-to-site offset, never turned.
- **Angles**: radians. A *yaw* turns about +z, counter-clockwise seen from above; 0 faces +x.
- **Transforms**: 4x4 homogeneous matrices from a local frame to its parent (world) frame; the
  rotation's columns are the local axes in the parent frame; points are columns (``T @ [x, y, z, 1]``).
- **SDF / URDF poses** ``x y z roll pitch yaw``: fixed (extrinsic) axes x, then y, then z, i.e.
  rotation = Rz(yaw) Ry(pitch) Rx(roll) (scipy's ``"xyz"`` in lower case). At gimbal lock
  (pitch = +-pi/2) the whole turn about z is given as yaw and roll is 0.
- **Quaternions**, unit, two orders in use:

  ============================== ====================== ===========================================
  order                          who                    functions
  ============================== ====================== ===========================================
  ``(w, x, y, z)`` scalar first  MuJoCo (MJCF ``quat``, :func:`quat_wxyz`, :func:`matrix_of_quat_wxyz`
                                 ``mjData.xquat``),
                                 bimrobot's RCAN trajectories
  ``(x, y, z, w)`` scalar last   ROS 2 (geometry_msgs/  :func:`quat_xyzw_of_yaw`, :func:`yaw_of_quat_xyzw`,
                                 Quaternion), Rerun     :func:`xyzw_of_wxyz`
                                 (``Transform3D``),
                                 scipy's default
  ============================== ====================== ===========================================

The conversions are scipy's (:class:`scipy.spatial.transform.Rotation`) where its result is the
one every output already holds; a matrix's quaternion is MuJoCo's own (``mju_mat2Quat``: the sign
MuJoCo picks, so MJCF files keep their numbers) and a matrix's roll, pitch, yaw the closed form of
SDF's convention (scipy puts a gimbal lock's turn into roll, and may give -pi where SDF files hold pi).
Plain turns about z (:func:`yaw_matrix`) are written out: cos and sin, exactly.
"""

from __future__ import annotations

import math

import numpy as np

#: Half a turn about the local x axis: a frame whose z points down (a gripper's approach axis).
_FLIP_X = np.array([1.0, -1.0, -1.0])


def yaw_matrix(yaw: float) -> np.ndarray:
    """Rz(yaw): the 3x3 rotation by ``yaw`` (rad) about +z."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def yaw_of(rotation: np.ndarray) -> float:
    """Heading (rad) of a rotation's local x axis in the xy plane: atan2 of its y over its x."""
    return math.atan2(rotation[1][0], rotation[0][0])


def transform(rotation: np.ndarray, position) -> np.ndarray:
    """4x4 local-to-parent transform of a 3x3 ``rotation`` and a ``position`` (x, y, z m)."""
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = position
    return out


def planar_transform(x: float, y: float, yaw: float, z: float = 0.0) -> np.ndarray:
    """4x4 transform of a planar pose: at (x, y, z) m, turned by ``yaw`` rad about +z."""
    return transform(yaw_matrix(yaw), (x, y, z))


def tool_down(yaw: float) -> np.ndarray:
    """Rotation of a tool pointing down: its approach axis z along -z and its x axis at ``yaw``, so its
    y axis (a gripper's closing axis) lies across ``yaw``. Rz(yaw) turned half a turn about its x."""
    return yaw_matrix(yaw) * _FLIP_X


def matrix_of_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """3x3 rotation of SDF angles (rad): Rz(yaw) Ry(pitch) Rx(roll), fixed axes."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_euler("xyz", (roll, pitch, yaw)).as_matrix()


def sdf_pose_matrix(x: float, y: float, z: float, roll: float, pitch: float, yaw: float) -> np.ndarray:
    """4x4 local-to-world transform of an SDF pose (metres, radians, :func:`matrix_of_rpy`)."""
    return transform(matrix_of_rpy(roll, pitch, yaw), (x, y, z))


def rpy_of(rotation: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) in radians with rotation = Rz(yaw) Ry(pitch) Rx(roll) (SDF's fixed axes); at
    gimbal lock roll is 0 and yaw holds the turn about z."""
    sin_pitch = -float(np.clip(rotation[2, 0], -1.0, 1.0))
    pitch = float(np.arcsin(sin_pitch))
    if abs(sin_pitch) < 1 - 1e-12:
        roll = float(np.arctan2(rotation[2, 1], rotation[2, 2]))
        yaw = float(np.arctan2(rotation[1, 0], rotation[0, 0]))
    else:  # gimbal lock: only yaw - roll (or yaw + roll) is defined; put it all in yaw
        roll = 0.0
        yaw = float(np.arctan2(-rotation[0, 1], rotation[1, 1]))
    return roll, pitch, yaw


def quat_wxyz(rotation: np.ndarray) -> np.ndarray:
    """(w, x, y, z) of a 3x3 rotation, as MuJoCo computes it (``mju_mat2Quat``; MJCF's order)."""
    import mujoco

    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=float).ravel())
    return quat


def matrix_of_quat_wxyz(quat) -> np.ndarray:
    """3x3 rotation of a (w, x, y, z) quaternion (MuJoCo's order)."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(np.asarray(quat, float), scalar_first=True).as_matrix()


def xyzw_of_wxyz(quats) -> np.ndarray:
    """Quaternions (..., 4) from MuJoCo's (w, x, y, z) to ROS's and Rerun's (x, y, z, w)."""
    return np.asarray(quats)[..., [1, 2, 3, 0]]


def quat_xyzw_of_yaw(yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a turn by ``yaw`` rad about +z (ROS's geometry_msgs/Quaternion order)."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_euler("z", yaw).as_quat()
    return (float(x), float(y), float(z), float(w))


def yaw_of_quat_xyzw(x: float, y: float, z: float, w: float) -> float:
    """The yaw (rad) of an (x, y, z, w) quaternion, as :func:`rpy_of` gives it (SDF's convention)."""
    from scipy.spatial.transform import Rotation

    return rpy_of(Rotation.from_quat((x, y, z, w)).as_matrix())[2]


__all__ = [
    "matrix_of_quat_wxyz", "matrix_of_rpy", "planar_transform", "quat_wxyz", "quat_xyzw_of_yaw", "rpy_of",
    "sdf_pose_matrix", "tool_down", "transform", "xyzw_of_wxyz", "yaw_matrix", "yaw_of", "yaw_of_quat_xyzw",
]  # fmt: skip
