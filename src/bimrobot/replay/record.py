"""Write a :class:`~bimrobot.replay.inputs.BuildRecord` as a Rerun recording (``.rrd``).

Entities (paths are Rerun entity paths; GlobalIds escaped as path parts):

- ``/building/<GlobalId>``: the element's mesh (local frame) with a Transform3D over time, coloured by
  its component's state; properties ``global_id``, ``ifc_class``, ``name``, ``storey`` (static) and
  ``state`` (over time);
- ``/robots/<name>``: a box per robot, moved over time, labelled with its current activity;
- ``/nodes/<relating:related>``: a point per connection node, grey -> orange while assembled -> green;
- ``/gantt/<robot>``: a scalar per robot, raised while it works (a Gantt chart you can scrub);
- ``/progress/<state>``: how many components are in each state (``Assembled``: installed);
- ``/events``: one text line per activity start.

Timelines: ``sim_time`` (seconds from the start of the build, a duration) and, when a start date is
given, ``calendar`` (wall-clock timestamps). An RCAN run adds ``rcan_time`` and, from the mujoco
backend's trajectory, ``physics_time`` (:mod:`bimrobot.replay.record_rcan`).
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np

from bimrobot.replay.inputs import INSTALLED, STATES, BuildRecord, node_id_of
from bimrobot.replay.motion import component_poses, robot_tracks

APPLICATION_ID = "bimrobot"
TIMELINE = "sim_time"
CALENDAR = "calendar"

#: Colours of the thesis' states (RGB): yard grey, transport blue, on site teal, positioning orange,
#: fixed yellow, assembling red, assembled green.
STATE_COLOURS = {
    "OnYard": (150, 150, 150), "InTransit": (66, 133, 244), "Arrived": (0, 172, 193), "InLocation": (0, 172, 193),
    "WorkingInPositioning": (255, 152, 0), "PositionFixed": (253, 216, 53), "WaitForAssembly": (253, 216, 53),
    "WorkingInAssembly": (229, 57, 53), "Assembled": (67, 160, 71),
}
NODE_COLOURS = {"waiting": (140, 140, 140), "assembling": (255, 152, 0), "assembled": (67, 160, 71)}
ROBOT_COLOURS = {"transport": (30, 136, 229), "positioning": (142, 36, 170), "assembly": (216, 27, 96)}
#: Robot bodies: half sizes (x, y, z) in metres, by kind (simple boxes, not the real machines).
ROBOT_HALF_SIZES = {"transport": (0.6, 0.4, 0.25), "positioning": (0.45, 0.45, 0.7), "assembly": (0.35, 0.35, 0.9)}


def entity(*parts: str) -> str:
    """A Rerun entity path from unescaped parts (GlobalIds may hold ``$``)."""
    import rerun as rr

    return "/" + "/".join(rr.escape_entity_path_part(p) for p in parts)


class _Clock:
    """Sets the recording's time on the simulated timeline and, with a start date, on the calendar."""

    def __init__(self, rec, start: dt.datetime | None):
        self.rec, self.start = rec, start

    def at(self, seconds: float) -> None:
        self.rec.set_time(TIMELINE, duration=float(seconds))
        if self.start is not None:
            self.rec.set_time(CALENDAR, timestamp=self.start + dt.timedelta(seconds=float(seconds)))


def write_rrd(record: BuildRecord, rrd: Path, start: dt.datetime | None = None, name: str | None = None) -> dict:
    """Write the replay of ``record`` to ``rrd`` (a path the caller made safe); return a summary dict
    (entities, components, installed, last installation time)."""
    import rerun as rr

    from bimrobot import io

    rec = rr.RecordingStream(APPLICATION_ID, recording_id=f"bimrobot-replay-{name or Path(rrd).stem}")
    rec.set_log_time_enabled(False)  # a replay is the same whenever it is written
    # The signature near the file's start lets bimrobot replace its own .rrd (docs/conventions.md): sent
    # before the file sink exists, it is buffered and written first, ahead of the blueprint (after it,
    # it sometimes landed beyond the first 64 KB).
    rec.send_recording_name(f"{record.title} - {io.signature('replay')}")
    rec.save(str(rrd), default_blueprint=blueprint(record))
    clock = _Clock(rec, start)
    _log_properties(rec, record)
    summary = {}
    if record.schedule:  # a build: the simulated schedule on sim_time
        tracks = robot_tracks(record)
        poses = component_poses(record, tracks)
        _log_pieces(rec, clock, record, poses)
        _log_robots(rec, clock, record, tracks)
        _log_nodes(rec, clock, record)
    summary = _log_progress(rec, clock, record)
    if record.rcan is not None:  # what RCAN executed, and the physics bodies, on their own clocks
        from bimrobot.replay.record_rcan import log_physics, log_rcan

        log_rcan(rec, record.rcan)
        summary["rcan_activities"] = len(record.rcan.activities)
        summary["rcan_done"] = len(record.rcan.done)
        if record.rcan.bodies:
            summary.update(log_physics(rec, record, record.rcan))
    rec.flush()
    rec.disconnect()
    return summary


def blueprint(record: BuildRecord | None = None):
    """The default layout: the site in 3D beside the robots' Gantt, the state counts and the activities.

    With ``record``, the 3D camera looks at the whole site (building, yard, robot homes) from a fixed
    eye, so that pictures at different times show the same view, and the plots span the whole build."""
    import rerun as rr
    import rerun.blueprint as rrb

    eye, axis = None, None
    if record is not None:
        low, high = scene_bounds(record)
        centre, size = (low + high) / 2, float(np.max(high - low))
        eye = rrb.EyeControls3D(position=centre + np.array([0.2, -0.75, 0.5]) * size, look_target=centre,
                                eye_up=[0.0, 0.0, 1.0])
        whole = rr.TimeRange(start=rr.TimeRangeBoundary.absolute(seconds=0.0),
                             end=rr.TimeRangeBoundary.absolute(seconds=max(timeline_end(record), 1.0)))
        axis = rrb.TimeAxis(view_range=whole)
    panels = []
    if record is None or record.schedule:
        panels += [rrb.TimeSeriesView(name="Robots: raised while working", origin="/gantt", axis_x=axis),
                   rrb.TimeSeriesView(name="Components per state", origin="/progress", axis_x=axis),
                   rrb.TextLogView(name="Activities", origin="/events")]
    if record is not None and record.rcan is not None:
        panels += [rrb.TimeSeriesView(name="RCAN: activities done per robot (rcan_time)", origin="/rcan_done"),
                   rrb.TextLogView(name="RCAN activities (rcan_time)", origin="/rcan")]
        if any(a.start_s is not None for a in record.rcan.activities):
            panels.insert(-2, rrb.TimeSeriesView(name="RCAN: raised while working (rcan_time)", origin="/rcan_gantt"))
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(name="Site (model frame, m)", origin="/",
                              contents=["/building/**", "/robots/**", "/nodes/**", "/bodies/**"], eye_controls=eye),
            rrb.Vertical(*panels),
            column_shares=[3, 2],
        ),
        rrb.TimePanel(timeline=main_timeline(record), state="expanded", play_state="paused"),
        collapse_panels=True,
    )


def main_timeline(record: BuildRecord | None) -> str:
    """The timeline the viewer opens on: the physics run's when there is one, else the schedule's."""
    from bimrobot.replay.record_rcan import PHYSICS_TIME, RCAN_TIME

    if record is not None and record.rcan is not None and record.rcan.bodies:
        return PHYSICS_TIME
    if record is not None and not record.schedule and record.rcan is not None:
        return RCAN_TIME
    return TIMELINE


def timeline_end(record: BuildRecord) -> float:
    """The last second of the main timeline (:func:`main_timeline`)."""
    from bimrobot.replay.record_rcan import PHYSICS_TIME, RCAN_TIME

    main = main_timeline(record)
    if main == PHYSICS_TIME:
        return max(float(track.times[-1]) for track in record.rcan.bodies.values())
    if main == RCAN_TIME:
        return max((a.finish_s for a in record.rcan.activities if a.finish_s is not None), default=0.0)
    return record.makespan


def scene_bounds(record: BuildRecord) -> tuple[np.ndarray, np.ndarray]:
    """[xmin, ymin, zmin], [xmax, ymax, zmax] of the building, the yard and the robot homes (m)."""
    boxes = [p.world_bounds(p.installed_pose) for p in record.pieces.values()]
    boxes += [p.world_bounds(p.yard_pose) for p in record.pieces.values() if p.yard_pose is not None]
    points = np.concatenate([np.concatenate(boxes)] + [[[*r.home, 0.0]] for r in record.robots.values()]
                            + [track.xyz[[0, -1]] for body, track in (record.rcan.bodies if record.rcan else {}).items()
                               if body.endswith("/base")])
    return points.min(axis=0), points.max(axis=0)


def _mesh(rr, triangles: np.ndarray, rgb) -> object:
    """A flat-shaded mesh: every triangle its own three vertices with the face normal."""
    vertices = triangles.reshape(-1, 3)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    return rr.Mesh3D(
        vertex_positions=vertices.astype(np.float32),
        triangle_indices=np.arange(len(vertices), dtype=np.uint32).reshape(-1, 3),
        vertex_normals=np.repeat(normals, 3, axis=0).astype(np.float32),
        albedo_factor=[*rgb, 255],
    )


def _transform(rr, pose: np.ndarray):
    return rr.Transform3D(translation=pose[:3, 3].astype(np.float32), mat3x3=pose[:3, :3].astype(np.float32))


def _log_properties(rec, record: BuildRecord) -> None:
    """Each element's GlobalId, IFC class, name and storey (static: on every timeline)."""
    import rerun as rr

    for gid, piece in record.pieces.items():
        rec.log(entity("building", gid), rr.AnyValues(global_id=gid, ifc_class=piece.ifc_class, name=piece.name,
                                                      storey=piece.storey_id or ""), static=True)


def _state_changes(record: BuildRecord) -> dict[str, list[tuple[float, str]]]:
    """Piece -> [(time, state)] from its component (the first change at time 0 at the latest)."""
    out = {}
    for component, history in record.states.items():
        for gid in record.parts.get(component, []):
            out[gid] = history
    return out


def _log_pieces(rec, clock: _Clock, record: BuildRecord, poses: dict) -> None:
    import rerun as rr

    changes = _state_changes(record)
    realizing = {r: node for node in record.nodes.values() for r in node.realizing}
    node_times = _node_times(record)
    for gid, piece in record.pieces.items():
        path = entity("building", gid)
        own_rgb = tuple(int(round(255 * c)) for c in piece.colour[:3])
        if gid in changes:
            history = changes[gid]
            clock.at(0.0)
            rec.log(path, _mesh(rr, piece.triangles, STATE_COLOURS[history[0][1]]))
            for t, state in history:
                clock.at(t)
                rec.log(path, rr.Mesh3D.from_fields(albedo_factor=[*STATE_COLOURS[state], 255]), rr.AnyValues(state=state))
            for t, pose in poses.get(gid, []):
                clock.at(t)
                rec.log(path, _transform(rr, pose))
        elif gid in realizing and realizing[gid].node_id in node_times:
            # a bolt, plate or weld of a joint: brought by the assembly robot, shown from the joint's assembly
            begin, end = node_times[realizing[gid].node_id]
            clock.at(begin)
            rec.log(path, _mesh(rr, piece.triangles, NODE_COLOURS["assembling"]), _transform(rr, piece.installed_pose),
                    rr.AnyValues(state="WorkingInAssembly"))
            clock.at(end)
            rec.log(path, rr.Mesh3D.from_fields(albedo_factor=[*own_rgb, 255]), rr.AnyValues(state=INSTALLED))
        else:
            # not built by the fleet (work of others, or not in the simulated selection): as the model has it
            clock.at(0.0)
            rec.log(path, _mesh(rr, piece.triangles, own_rgb), _transform(rr, piece.installed_pose),
                    rr.AnyValues(state="not in the schedule"))


def _node_times(record: BuildRecord) -> dict[str, tuple[float, float]]:
    """Node -> (first assembly start, last assembly finish), seconds."""
    times: dict[str, tuple[float, float]] = {}
    for row in record.schedule:
        node = node_id_of(row)
        if node is None:
            continue
        begin, end = times.get(node, (row["Start"], row["Finish"]))
        times[node] = (min(begin, row["Start"]), max(end, row["Finish"]))
    return times


def _log_robots(rec, clock: _Clock, record: BuildRecord, tracks: dict) -> None:
    import rerun as rr

    count = len(record.robots)
    for index, (name, robot) in enumerate(record.robots.items()):
        path = entity("robots", name)
        half = ROBOT_HALF_SIZES.get(robot.kind, (0.4, 0.4, 0.4))
        colour = ROBOT_COLOURS.get(robot.kind, (120, 120, 120))
        track = tracks[name]
        for t, x, y in track.positions:
            clock.at(t)
            rec.log(path, rr.Transform3D(translation=[x, y, 0.0]))
        gantt = entity("gantt", name)
        level = float(count - index)
        rec.log(gantt, rr.SeriesLines(names=name, colors=[colour]), static=True)
        busy_before = False
        for t, label, busy in track.activities:
            clock.at(t)
            rec.log(path, rr.Boxes3D(half_sizes=[half], centers=[[0.0, 0.0, half[2]]], colors=[colour],
                                     labels=[f"{name}: {label}"], fill_mode="solid"))
            rec.log(gantt, rr.Scalars(level + (0.6 if busy_before else 0.0)))
            rec.log(gantt, rr.Scalars(level + (0.6 if busy else 0.0)))
            busy_before = busy
            if busy:
                rec.log("/events", rr.TextLog(f"t = {t:,.1f} s  {name}: {label}", level="INFO"))


def _log_nodes(rec, clock: _Clock, record: BuildRecord) -> None:
    import rerun as rr

    times = _node_times(record)
    for node_id, node in record.nodes.items():
        path = entity("nodes", node_id)
        begin, end = times[node_id]
        for t, phase in ((0.0, "waiting"), (begin, "assembling"), (end, "assembled")):
            clock.at(t)
            rec.log(path, rr.Points3D([node.position], radii=[0.08], colors=[NODE_COLOURS[phase]], labels=[phase]))


def _log_progress(rec, clock: _Clock, record: BuildRecord) -> dict:
    """Counts of components per state over time; returns the replay's summary."""
    import rerun as rr

    events = sorted((t, component, state) for component, history in record.states.items() for t, state in history)
    current: dict[str, str] = {}
    for state in STATES if record.states else ():
        rec.log(entity("progress", state), rr.SeriesLines(names=state, colors=[STATE_COLOURS[state]]), static=True)
    index = 0
    last_installed = None
    while index < len(events):
        t = events[index][0]
        while index < len(events) and events[index][0] == t:
            _, component, state = events[index]
            if state == INSTALLED and current.get(component) != INSTALLED:
                last_installed = t
            current[component] = state
            index += 1
        clock.at(t)
        counts = {state: 0 for state in STATES}
        for state in current.values():
            counts[state] += 1
        for state, number in counts.items():
            rec.log(entity("progress", state), rr.Scalars(number))
    installed = sum(1 for s in current.values() if s == INSTALLED)
    return {
        "pieces": len(record.pieces),
        "components": len(record.states),
        "robots": len(record.robots),
        "nodes": len(record.nodes),
        "installed": installed,
        "last_installation_s": last_installed,
        "makespan_s": record.makespan,
    }
