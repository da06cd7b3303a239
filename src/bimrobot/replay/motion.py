"""Where robots and components are over time, from the schedule and the component states.

Robots drive in straight lines at their fleet speed, as `simulate` moves them: at the start of an
activity from where the last one ended to where this one begins (a transport: to the component on the
yard, then carrying it to its target; positioning and assembly: to a stand-off point beside the work).
A component lies on the yard until it is ``InTransit``, rides on its transport robot, is set down at
its target when it has ``Arrived``, is lifted into its installed pose while ``WorkingInPositioning``
(in at most :data:`MAX_LIFT_STEPS` steps) and stays there from ``PositionFixed``. On a site with ``idle_robots: yard`` a robot that has worked
and has no task when it finishes drives back to the nearest yard position until its next task starts,
as `simulate` sends it. Times in seconds from the start of the build; positions in the
package's model frame, metres, z up.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bimrobot.replay.inputs import BuildRecord, node_id_of

#: Height of a transport robot's deck: a carried component lies this high (m).
DECK_HEIGHT_M = 0.5
#: A positioning or assembly robot works from this far beside its work point (m).
STAND_OFF_M = 1.0
#: Longest time step between two samples of a movement (s), and the most samples of one movement.
SAMPLE_STEP_S = 2.0
MAX_SAMPLES = 24
#: Most steps of a lift (a component raised and turned from where it was set down into its installed
#: pose: a straight line and one turn): drawn in a few steps, it reads the same with fewer rows.
MAX_LIFT_STEPS = 4
#: A long build is sampled more coarsely: the step is at least the build's length divided by this
#: (the steel frame: 2 s, Prefab's 8-hour build: 29 s), so that the recording's time points stay few.
STEPS_PER_BUILD = 1000


def sample_step(record: BuildRecord) -> float:
    """The longest time step between two samples of a movement in this build (s)."""
    return max(SAMPLE_STEP_S, record.makespan / STEPS_PER_BUILD)


@dataclass
class RobotTrack:
    """A robot's positions (time s, x, y) and its activity labels (time s, label, busy)."""

    positions: list[tuple[float, float, float]] = field(default_factory=list)
    activities: list[tuple[float, str, bool]] = field(default_factory=list)
    #: the longest time step between two samples of its movements (s)
    step_s: float = SAMPLE_STEP_S


def sample_times(t0: float, t1: float, step_s: float = SAMPLE_STEP_S, most: int = MAX_SAMPLES) -> np.ndarray:
    """Times from t0 to t1 (both included) at most ``step_s`` apart, in at most ``most`` steps (s)."""
    if t1 <= t0:
        return np.array([t0])
    count = int(min(most, max(1, np.ceil((t1 - t0) / step_s))))
    return np.linspace(t0, t1, count + 1)


def _leg(track: RobotTrack, t0: float, t1: float, p0: np.ndarray, p1: np.ndarray) -> None:
    for t in sample_times(t0, t1, track.step_s):
        fraction = 0.0 if t1 <= t0 else (t - t0) / (t1 - t0)
        x, y = p0 + fraction * (p1 - p0)
        track.positions.append((float(t), float(x), float(y)))


def _stand_off(point: np.ndarray, came_from: np.ndarray) -> np.ndarray:
    away = came_from - point
    length = float(np.hypot(*away))
    return point + (away / length * STAND_OFF_M if length > 1e-6 else np.array([STAND_OFF_M, 0.0]))


def component_centre(record: BuildRecord, component: str, which: str = "yard") -> np.ndarray | None:
    """Centre (x, y, z) of the component's pieces on the yard (``which="yard"``) or installed."""
    boxes = []
    for gid in record.parts.get(component, []):
        piece = record.pieces[gid]
        pose = piece.yard_pose if which == "yard" else piece.installed_pose
        if pose is None:
            return None
        boxes.append(piece.world_bounds(pose))
    if not boxes:
        return None
    low = np.min([b[0] for b in boxes], axis=0)
    high = np.max([b[1] for b in boxes], axis=0)
    return (low + high) / 2


def first_time(record: BuildRecord, component: str, state: str) -> float | None:
    """When the component first entered ``state`` (s), or None."""
    return next((t for t, s in record.states.get(component, []) if s == state), None)


def robot_tracks(record: BuildRecord) -> dict[str, RobotTrack]:
    """Each robot's path and activity labels over the build (see the module docstring)."""
    tracks = {}
    for name, robot in record.robots.items():
        track = RobotTrack(step_s=sample_step(record))
        position = robot.home.copy()
        track.positions.append((0.0, float(position[0]), float(position[1])))
        track.activities.append((0.0, "idle", False))
        rows = [r for r in record.schedule if r["Robot"] == name]
        for index, row in enumerate(rows):
            if index and record.idle_robots == "yard" and record.yard is not None and len(record.yard):
                position = _return_to_yard(track, robot, position, rows[index - 1]["Finish"], row["Start"], record.yard)
            start, finish = row["Start"], row["Finish"]
            target = np.array([row["TargetX"], row["TargetY"]])
            label = _label(record, row)
            track.activities.append((start, label, True))
            if row["Activity"] == "transport":
                pick = component_centre(record, row["GlobalId"])
                pick = target if pick is None else pick[:2]
                picked = first_time(record, row["GlobalId"], "InTransit")
                if picked is None or not start <= picked <= finish:
                    picked = min(finish, start + float(np.hypot(*(pick - position))) / robot.speed)
                _leg(track, start, picked, position, pick)
                depart = min(finish, picked + robot.load_time)
                _leg(track, depart, max(depart, finish - robot.unload_time), pick, target)
                position = target
            else:
                point = target
                if row["Activity"] == "assemble" and node_id_of(row) in record.nodes:
                    point = record.nodes[node_id_of(row)].position[:2]
                spot = _stand_off(point, position)
                arrive = min(finish, start + float(np.hypot(*(spot - position))) / robot.speed)
                _leg(track, start, arrive, position, spot)
                position = spot
            track.activities.append((finish, "idle", False))
        if rows and record.idle_robots == "yard" and record.yard is not None and len(record.yard):
            _return_to_yard(track, robot, position, rows[-1]["Finish"], None, record.yard)
        tracks[name] = track
    return tracks


def _return_to_yard(track: RobotTrack, robot, position: np.ndarray, free_s: float, next_s: float | None,
                    yard: np.ndarray) -> np.ndarray:
    """With the site's ``idle_robots: yard``, a robot that has worked and has no task when it finishes
    drives to the nearest yard position, as `simulate` sends it (thesis 4.5.3), until it arrives or its
    next task starts at ``next_s`` (then it stops where it is). Returns where it is then (model frame, m)."""
    if next_s is not None and next_s <= free_s:
        return position  # given its next task as it finished: it never left
    target = yard[int(np.argmin(np.hypot(*(yard - position).T)))]
    distance = float(np.hypot(*(target - position)))
    if distance < 1e-6:
        return position
    arrive_s = free_s + distance / robot.speed
    stop_s = arrive_s if next_s is None else min(arrive_s, next_s)
    end = position + (target - position) * (stop_s - free_s) / (arrive_s - free_s)
    track.activities.append((free_s, "idle: returning to the yard", False))
    _leg(track, free_s, stop_s, position, end)
    if stop_s == arrive_s:
        track.activities.append((arrive_s, "idle at the yard", False))
    return end


def _label(record: BuildRecord, row: dict) -> str:
    component = row["GlobalId"]
    names = [record.pieces[g].name for g in record.parts.get(component, []) if record.pieces[g].name]
    what = names[0] if len(names) == 1 else component
    if row["Activity"] == "assemble" and node_id_of(row):
        return f"assemble node {node_id_of(row)}"
    return f"{row['Activity']} {what}"


def component_poses(record: BuildRecord, tracks: dict[str, RobotTrack]) -> dict[str, list[tuple[float, np.ndarray]]]:
    """Each piece's pose over time: [(time s, 4x4)], from the component states (module docstring).

    A piece that is on the yard in the package starts there; one whose component starts installed
    (prebuilt: its first state is PositionFixed or later) starts at its installed pose; pieces of no
    component are handled by the caller."""
    poses: dict[str, list[tuple[float, np.ndarray]]] = {}
    transports = {row["GlobalId"]: row for row in record.schedule if row["Activity"] == "transport"}
    for component, history in record.states.items():
        gids = record.parts.get(component, [])
        if not gids:
            continue
        first_state = history[0][1] if history else "PositionFixed"
        if STATE_INDEX[first_state] >= STATE_INDEX["PositionFixed"]:
            for gid in gids:
                poses[gid] = [(0.0, record.pieces[gid].installed_pose)]
            continue
        rest = _rest_poses(record, gids)  # pose of each piece relative to the component's resting frame
        timeline: list[tuple[float, dict[str, np.ndarray]]] = []
        yard_centre = component_centre(record, component)
        if yard_centre is not None:
            timeline.append((0.0, {g: record.pieces[g].yard_pose for g in gids}))
        picked = first_time(record, component, "InTransit")
        arrived = first_time(record, component, "Arrived")
        row = transports.get(component)
        if picked is not None and row is not None and row["Robot"] in tracks:
            drop_time = arrived if arrived is not None else row["Finish"]
            for t, x, y in tracks[row["Robot"]].positions:
                if picked <= t <= drop_time:
                    timeline.append((t, _placed(rest, x, y, DECK_HEIGHT_M)))
        set_down = np.array([transports[component]["TargetX"], transports[component]["TargetY"]]) if row else None
        if arrived is not None and set_down is not None:
            down = _placed(rest, set_down[0], set_down[1], 0.0)
            timeline.append((arrived, down))
        else:
            down = None
        lift = first_time(record, component, "WorkingInPositioning")
        # in place from PositionFixed, or from the first later state when the history skips it
        # (a precast unit goes from WorkingInPositioning straight to Assembled)
        fixed = next((t for t, s in history if STATE_INDEX[s] >= STATE_INDEX["PositionFixed"]), None)
        installed = {g: record.pieces[g].installed_pose for g in gids}
        if lift is not None and fixed is not None and down is not None:
            times = sample_times(lift, fixed, sample_step(record), MAX_LIFT_STEPS)
            fractions = np.zeros(len(times)) if fixed <= lift else (times - lift) / (fixed - lift)
            lifted = {g: _blend(down[g], installed[g], fractions) for g in gids}
            for index, t in enumerate(times):
                timeline.append((float(t), {g: lifted[g][index] for g in gids}))
        if fixed is not None:
            timeline.append((fixed, installed))
        for t, pose_of in sorted(timeline, key=lambda item: item[0]):
            for gid in gids:
                poses.setdefault(gid, []).append((t, pose_of[gid]))
    return poses


STATE_INDEX = {
    "OnYard": 0, "InTransit": 1, "Arrived": 2, "InLocation": 3, "WorkingInPositioning": 4,
    "PositionFixed": 5, "WaitForAssembly": 6, "WorkingInAssembly": 7, "Assembled": 8,
}


def _rest_poses(record: BuildRecord, gids: list[str]) -> dict[str, np.ndarray]:
    """Each piece's pose relative to a frame at the component's lying centre, bottom face at z = 0:
    as it lies on the yard, or, without a yard pose, upright as installed."""
    base = {g: (record.pieces[g].yard_pose if record.pieces[g].yard_pose is not None else record.pieces[g].installed_pose)
            for g in gids}
    boxes = [record.pieces[g].world_bounds(base[g]) for g in gids]
    low = np.min([b[0] for b in boxes], axis=0)
    high = np.max([b[1] for b in boxes], axis=0)
    shift = np.eye(4)
    shift[:3, 3] = -np.array([(low[0] + high[0]) / 2, (low[1] + high[1]) / 2, low[2]])
    return {g: shift @ base[g] for g in gids}


def _placed(rest: dict[str, np.ndarray], x: float, y: float, z: float) -> dict[str, np.ndarray]:
    move = np.eye(4)
    move[:3, 3] = (x, y, z)
    return {g: move @ pose for g, pose in rest.items()}


def _blend(a: np.ndarray, b: np.ndarray, fractions: np.ndarray) -> np.ndarray:
    """The poses (k, 4, 4) the given fractions of the way from pose a to pose b: a straight line for
    the origin, slerp for the turn."""
    from scipy.spatial.transform import Rotation, Slerp

    fractions = np.asarray(fractions, dtype=float)
    out = np.repeat(np.eye(4)[None], len(fractions), axis=0)
    out[:, :3, 3] = (1 - fractions)[:, None] * a[:3, 3] + fractions[:, None] * b[:3, 3]
    turns = Rotation.from_matrix(np.stack([a[:3, :3], b[:3, :3]]))
    out[:, :3, :3] = Slerp([0.0, 1.0], turns)(fractions).as_matrix()
    return out
