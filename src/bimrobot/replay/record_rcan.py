"""An RCAN run in the replay: the mujoco backend's recorded bodies and the run's activities.

Timelines (each its own clock, so that none is mistaken for the simulated schedule's ``sim_time``):

- ``physics_time``: simulated seconds of the MuJoCo scene. ``/building/...`` of a component the
  physics moved follows its recorded body pose (Transform3D = the body's pose, as the trajectory CSV
  gives it); the element's mesh rides on that body (see :func:`mesh_offset`). Robots are drawn from
  their recorded links under ``/bodies/<robot>``: a marker box on the base, a point per link and a
  line through the arm's links. Elements the physics run did not move stand at their installed pose,
  each its own entity, or, on a large model (:func:`bimrobot.replay.compact.is_large`), all of them in
  one, ``/building/not moved by the physics`` (their real shapes in their own colours, one mesh): the web
  viewer's time to open grows with the entities on a timeline, and only the moving ones need their own.
- ``rcan_time``: the RCAN run's own clock (the backend's simulated seconds; with the mujoco backend the
  same clock as ``physics_time``): ``/rcan/<robot>`` one text line per activity the robot finished,
  ``/rcan_gantt/<robot>`` a Gantt bar per done activity, from its recorded start to its finish (2D
  boxes, static, as the schedule's ``/gantt``; ``/rcan_gantt/now`` the time cursor),
  ``/rcan_progress/done`` the number of activities done.

Data logged on one timeline is not shown on another: ``/building`` carries the schedule's travel on
``sim_time`` and the recorded poses on ``physics_time``, each with its own mesh frame.
"""

from __future__ import annotations

import itertools
import logging

import numpy as np

from bimrobot.core.frames import xyzw_of_wxyz
from bimrobot.replay.elements import (STATE_COLOURS, element_paths, element_properties, entity, mesh3d, own_rgb,
                                       transform3d)
from bimrobot.replay.gantt import Bar, log_chart
from bimrobot.replay.inputs import STATES, BuildRecord
from bimrobot.replay.rcan import RcanRun

log = logging.getLogger(__name__)

PHYSICS_TIME = "physics_time"
RCAN_TIME = "rcan_time"
#: A component's state once an RCAN activity on it is done, as bimrobot.rcan's state manager advances
#: it (an install leaves it WorkingInAssembly until its last connection is fixed: the run's final
#: state, from report.json, is shown at its last activity).
STATE_AFTER = {"pick_up": "InTransit", "transport": "Arrived", "position_for_installing": "PositionFixed",
               "install": "WorkingInAssembly"}
#: The links of a robot of bimrobot.physics.robot from base to gripper: the arm's line.
ARM_CHAIN = ("base", "arm_base", "shoulder_pan_link", "shoulder_lift_link", "elbow_link", "wrist_1_link",
             "wrist_2_link", "wrist_3_link", "gripper")
#: The marker box on a robot's base (half sizes, m): a sign of where the base is, not its chassis.
BASE_MARKER_HALF = (0.4, 0.3, 0.15)
ROBOT_COLOUR = (216, 27, 96)


def installed(state: str | None) -> bool:
    """Whether a component in ``state`` stands at its target (PositionFixed or later)."""
    return state in STATES and STATES.index(state) >= STATES.index("PositionFixed")


def mesh_offset(record: BuildRecord, run: RcanRun, component: str, gid: str) -> np.ndarray:
    """The pose (4x4) of piece ``gid``'s mesh frame in its component's body frame.

    The physics simulates a component as a box whose origin is its bottom face's centre, which need not
    be the IFC placement's origin. A component the run installed (PositionFixed or later) ends at its
    target, so the mesh is fixed to the body such that it lies at its installed IFC pose at the body's
    last recorded pose. Any other component's mesh frame is the body frame itself."""
    if installed(run.component_states.get(component)):
        return np.linalg.inv(run.bodies[component].pose(-1)) @ record.pieces[gid].installed_pose
    return np.eye(4)


def state_changes(run: RcanRun, component: str, first_s: float) -> list[tuple[float, str]]:
    """[(time s, state)] of a component on the RCAN clock: OnYard from ``first_s``, then after each of
    its done activities (:data:`STATE_AFTER`), ending with the run's final state."""
    changes = [(first_s, "OnYard")]
    done = sorted((a for a in run.done if a.component_id == component and a.finish_s is not None),
                  key=lambda a: a.finish_s)
    for activity in done:
        if activity.kind in STATE_AFTER:
            changes.append((activity.finish_s, STATE_AFTER[activity.kind]))
    final = run.component_states.get(component)
    if done and final in STATES:
        changes.append((done[-1].finish_s, final))
    return changes


def component_pieces(record: BuildRecord, component: str) -> list[str]:
    """The pieces (elements with a mesh) of an RCAN component: itself, or its assembly's parts."""
    if component in record.parts:
        return record.parts[component]
    return [component] if component in record.pieces else []


#: The one entity of the elements the physics did not move, on a large model (module docstring).
UNMOVED = "not moved by the physics"


def log_physics(rec, record: BuildRecord, run: RcanRun, together: bool = False) -> dict:
    """Log the recorded bodies on ``physics_time``; returns {components, robots} moved by the physics.
    ``together``: the elements it did not move as one entity (:data:`UNMOVED`), not one each."""
    import rerun as rr

    rec.reset_time()
    paths = element_paths(record)
    moved = set()
    components = [b for b in run.bodies if "/" not in b]
    for component in components:
        track = run.bodies[component]
        gids = component_pieces(record, component)
        if not gids:
            log.info("replay: the physics body %s is no element of the model; left out", component)
            continue
        changes = state_changes(run, component, float(track.times[0]))
        for gid in gids:
            path = paths[gid]
            offset = mesh_offset(record, run, component, gid)
            triangles = record.pieces[gid].triangles @ offset[:3, :3].T + offset[:3, 3]
            rec.set_time(PHYSICS_TIME, duration=changes[0][0])
            rec.log(path, mesh3d(rr, triangles, STATE_COLOURS[changes[0][1]]),
                    rr.AnyValues(state=changes[0][1], **element_properties(record, gid)))
            for t, state in changes[1:]:
                rec.set_time(PHYSICS_TIME, duration=t)
                rec.log(path, rr.Mesh3D.from_fields(albedo_factor=[*STATE_COLOURS[state], 255]), rr.AnyValues(state=state))
            rec.send_columns(path, indexes=[rr.TimeColumn(PHYSICS_TIME, duration=track.times)],
                             columns=rr.Transform3D.columns(translation=track.xyz, quaternion=xyzw_of_wxyz(track.quat_wxyz)))
            moved.add(gid)
    _log_unmoved(rec, record, run, moved, together)
    robots = run.robot_links()
    for robot, links in robots.items():
        _log_robot_bodies(rec, run, robot, links)
    rec.reset_time()
    return {"physics_components": len(moved), "physics_robots": len(robots)}


def _log_unmoved(rec, record: BuildRecord, run: RcanRun, moved: set[str], together: bool) -> None:
    """Elements the physics did not move: at their installed pose from 0 s in their own colour, except the
    pieces of RCAN's components, which the physics would have brought (not drawn without a body); each
    its own entity, or all in one mesh when ``together``."""
    import rerun as rr

    from bimrobot.replay.compact import context_columns

    rcan_pieces = {g for a in run.activities for g in component_pieces(record, a.component_id)}
    unmoved = [gid for gid in record.pieces if gid not in moved and gid not in rcan_pieces]
    if together:
        if unmoved:
            rec.send_columns(entity("building", UNMOVED), indexes=[rr.TimeColumn(PHYSICS_TIME, duration=[0.0])],
                             columns=context_columns(rr, record, unmoved, UNMOVED))
        return
    paths = element_paths(record)
    rec.set_time(PHYSICS_TIME, duration=0.0)
    for gid in unmoved:
        piece = record.pieces[gid]
        rec.log(paths[gid], mesh3d(rr, piece.triangles, own_rgb(piece)), transform3d(rr, piece.installed_pose),
                rr.AnyValues(**element_properties(record, gid)))


def _log_robot_bodies(rec, run: RcanRun, robot: str, links: list[str]) -> None:
    import rerun as rr

    for body in links:
        track = run.bodies[body]
        path = entity("bodies", robot, body.split("/", 1)[1])
        if body.endswith("/base"):
            rec.log(path, rr.Boxes3D(half_sizes=[BASE_MARKER_HALF], centers=[[0.0, 0.0, BASE_MARKER_HALF[2]]],
                                     colors=[ROBOT_COLOUR], labels=[robot], fill_mode="solid", show_labels=False),
                    static=True)
        else:
            rec.log(path, rr.Points3D([[0.0, 0.0, 0.0]], radii=[0.03], colors=[ROBOT_COLOUR]), static=True)
        rec.send_columns(path, indexes=[rr.TimeColumn(PHYSICS_TIME, duration=track.times)],
                         columns=rr.Transform3D.columns(translation=track.xyz, quaternion=xyzw_of_wxyz(track.quat_wxyz)))
    chain = [run.bodies.get(f"{robot}/{link}") for link in ARM_CHAIN]
    if any(track is None for track in chain) or len({len(track.times) for track in chain}) != 1:
        return  # not a robot of bimrobot.physics (or its links were not recorded together): no arm line
    strips = np.stack([track.xyz for track in chain], axis=1)  # (frames, links, 3)
    rec.send_columns(entity("bodies", robot, "arm"), indexes=[rr.TimeColumn(PHYSICS_TIME, duration=chain[0].times)],
                     columns=rr.LineStrips3D.columns(strips=list(strips), colors=[ROBOT_COLOUR] * len(strips),
                                                     radii=[0.02] * len(strips)).partition([1] * len(strips)))


def log_rcan(rec, run: RcanRun) -> None:
    """Log what the RCAN run executed on ``rcan_time`` (module docstring): per robot a line per finished
    activity, the count it has done (a staircase) and, where starts were recorded, its Gantt bars."""
    import rerun as rr

    rec.reset_time()
    # the mujoco backend's activity times are the seconds of its scene: shown on physics_time as well
    timelines = (RCAN_TIME, PHYSICS_TIME) if run.bodies else (RCAN_TIME,)
    robots = sorted({a.robot for a in run.activities if a.robot})
    for robot in robots:
        mine = sorted((a for a in run.activities if a.robot == robot and a.finish_s is not None),
                      key=lambda a: (a.finish_s, a.activity_id))
        lines, done = entity("rcan", robot), entity("rcan_done", robot)
        rec.log(done, rr.SeriesLines(names=robot), static=True)
        _at(rec, 0.0, timelines)
        rec.log(done, rr.Scalars(0.0))
        count = 0
        # activities that finish in the same second share one line: a timeline keeps one row per time
        for finish, group in itertools.groupby(mine, key=lambda a: a.finish_s):
            group = list(group)
            _at(rec, finish, timelines)
            level = "INFO" if all(a.status == "done" for a in group) else "WARN"
            text = "\n".join(f"{robot}: {a.label}: {a.status}" + (f" ({a.message})" if a.message else "") for a in group)
            rec.log(lines, rr.TextLog(text, level=level),
                    rr.AnyValues(activity_id=[a.activity_id for a in group], status=[a.status for a in group]))
            count += sum(1 for a in group if a.status == "done")
            rec.log(done, rr.Scalars(float(count)))
    rec.reset_time()
    log_rcan_gantt(rec, run, timelines)


def _at(rec, seconds: float, timelines) -> None:
    for timeline in timelines:
        rec.set_time(timeline, duration=float(seconds))


def timed_activities(activities) -> list:
    """The done activities with a recorded start and finish, by start (then finish, id): RCAN's Gantt bars."""
    return sorted((a for a in activities if a.status == "done" and a.start_s is not None and a.finish_s is not None),
                  key=lambda a: (a.start_s, a.finish_s, a.activity_id))


#: The schedule activity (bar colour of :mod:`bimrobot.replay.gantt`) of each RCAN activity kind.
GANTT_ACTIVITY = {"move_to_component": "transport", "position_for_picking_up": "transport", "pick_up": "transport",
                  "transport": "transport", "position_for_installing": "position", "install": "assemble"}


def log_rcan_gantt(rec, run: RcanRun, timelines) -> int:
    """RCAN's Gantt chart, drawn as the schedule's (:mod:`bimrobot.replay.gantt`): per robot a bar per
    done activity from its recorded start to its finish (s on ``rcan_time``), coloured by kind (moving
    and picking up as transport, positioning, installing as assembly), its id, kind, component and
    times on hover; ``/rcan_gantt/now`` the time cursor on ``timelines``. Nothing is drawn when no start
    was recorded (an older state database). Returns the number of bars."""
    timed = timed_activities(run.activities)
    if not timed:
        return 0
    robots = sorted({a.robot for a in run.activities if a.robot})
    bars = [Bar(a.robot, a.start_s, a.finish_s, GANTT_ACTIVITY.get(a.kind, a.kind),
                f"{a.robot}: {a.label} ({a.start_s:,.1f}-{a.finish_s:,.1f} s)") for a in timed]
    return log_chart(rec, "rcan_gantt", robots, bars, max(a.finish_s for a in timed), tuple(timelines))
