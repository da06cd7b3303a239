"""The trajectory of a ``mujoco`` run: which recorded frames of which bodies are written, and how long
two robots' chassis overlapped in plan view.

Frames are (time s, body names, poses x y z qw qx qy qz) as :class:`bimrobot.physics.site.MujocoSite`
records them at :data:`bimrobot.physics.site.RECORD_HZ` (simulated time; metres, world frame, z up).
"""

from __future__ import annotations

import numpy as np

TRAJECTORY_POSITION_M = 1e-4  # a body moved when it is this far (m) ...
TRAJECTORY_QUATERNION = 1e-4  # ... or its unit quaternion this far (about 0.01 degrees) from its last written pose


def trajectory_rows(frames: list):
    """The rows of the trajectory file: (time s, body names, poses x y z qw qx qy qz) per recorded
    frame, only of the bodies that moved. A group of bodies (a robot's links, or one component) is
    written at a frame when one of its bodies moved (:data:`TRAJECTORY_POSITION_M`,
    :data:`TRAJECTORY_QUATERNION`) since the group was last written, together with the frame before
    when that was not written (so a track interpolates exactly where the motion starts); every body
    at the first and the last frame, and whenever the scene's bodies change (a support appears). A
    frame run's 4,477 s wrote every body at 20 Hz before: 726 MB."""
    for start, stop in _same_bodies(frames):
        names = np.array(frames[start][1], dtype=object)
        groups = np.unique([n.split("/", 1)[0] for n in names], return_inverse=True)[1]
        last = frames[start][2]
        yield frames[start][0], list(names), last
        written_at = np.full(groups.max() + 1, start)  # each group's last written frame
        for k in range(start + 1, stop):
            time_s, _, poses = frames[k]
            moved_body = ((np.abs(poses[:, :3] - last[:, :3]) > TRAJECTORY_POSITION_M).any(axis=1)
                          | (np.abs(poses[:, 3:] - last[:, 3:]) > TRAJECTORY_QUATERNION).any(axis=1))
            moved = np.zeros(len(written_at), dtype=bool)
            moved[groups[moved_body]] = True
            if k == len(frames) - 1:
                moved[:] = True
            held = moved & (written_at < k - 1)  # groups that start moving: their pose a frame before, too
            if held.any():
                rows = held[groups]
                yield frames[k - 1][0], list(names[rows]), frames[k - 1][2][rows]
            if moved.any():
                rows = moved[groups]
                yield time_s, list(names[rows]), poses[rows]
                last = np.where(rows[:, None], poses, last)
                written_at[moved] = k


def _same_bodies(frames: list):
    """(start, stop) index ranges of consecutive frames that record the same bodies."""
    start = 0
    for k in range(1, len(frames) + 1):
        if k == len(frames) or (frames[k][1] is not frames[start][1] and frames[k][1] != frames[start][1]):
            yield start, k
            start = k


def chassis_overlaps(frames: list, footprints: dict[str, tuple[float, float]]) -> dict[str, float]:
    """Simulated seconds during which two robots' chassis (boxes of their footprints, length x width m,
    centred on the base) overlap in plan view, per pair ("A & B", only pairs that did), counted over
    the recorded ``frames`` (time s, body names, poses x y z qw qx qy qz) at :data:`RECORD_HZ`."""
    import shapely
    from bimrobot.physics.site import RECORD_HZ

    if not frames or len(footprints) < 2:
        return {}
    robots = [r for r in footprints if f"{r}/base" in frames[0][1]]
    poses = []  # (frames, robots, 7): each robot's base, where the scene's bodies changed too
    for start, stop in _same_bodies(frames):
        rows = [frames[start][1].index(f"{r}/base") for r in robots]
        poses.extend(pose[rows] for _, _, pose in frames[start:stop])
    poses = np.stack(poses)
    yaw = 2 * np.arctan2(poses[:, :, 6], poses[:, :, 3])  # the base turns about z only
    chassis = {}
    for k, robot in enumerate(robots):
        length, width = footprints[robot]
        corners = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [length / 2, width / 2]
        c, s = np.cos(yaw[:, k])[:, None], np.sin(yaw[:, k])[:, None]
        x = poses[:, k, 0:1] + c * corners[:, 0] - s * corners[:, 1]
        y = poses[:, k, 1:2] + s * corners[:, 0] + c * corners[:, 1]
        chassis[robot] = shapely.polygons(np.stack([x, y], axis=2))
    overlaps = {}
    for i, a in enumerate(robots):
        for b in robots[i + 1:]:
            frames_overlapping = int(np.count_nonzero(shapely.area(shapely.intersection(chassis[a], chassis[b])) > 1e-6))
            if frames_overlapping:
                overlaps[f"{a} & {b}"] = round(frames_overlapping / RECORD_HZ, 2)
    return overlaps
