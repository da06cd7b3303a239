"""Write a :class:`~bimrobot.replay.inputs.BuildRecord` as a Rerun recording (``.rrd``) with a blueprint
a planner can read (:func:`blueprint`).

Entities (paths are Rerun entity paths; each part escaped):

- ``/building/<storey>/<IFC class>/<name>``: the element's mesh (local frame, lightened; an assembly's
  parts joined into one unit: :func:`bimrobot.replay.elements.drawn_record`) with a Transform3D over
  time, coloured by its component's state; properties ``global_id``, ``ifc_class``, ``name``,
  ``storey`` (and a unit's ``parts``, with the mesh) and ``state`` (over time), all in one chunk per
  element (:func:`_send_rows`). Elements of the same storey, class and name are told apart by
  `` (2)``, `` (3)``, ... in file order (:func:`bimrobot.replay.elements.element_paths`). A large model
  is drawn instead as ``/building/<state>``, each component its box, grouped by state
  (:mod:`bimrobot.replay.compact`: a few entities open in the web viewer in a fraction of the time);
- ``/ghost``: the work still to be built, translucent grey at its installed place from the start
  (static: on every timeline), as 4D tools show it; each element drawn 1 % smaller about its centre,
  so that the built element, once in place, hides it;
- ``/robots/<name>``: a box per robot, moved over time, with its current activity as its label;
- ``/nodes``: a point per connection node (hover: ``node <relating:related>``), grey -> orange while
  assembled -> green;
- ``/gantt/<robot>``: the robot's activities as bars of a Gantt chart (2D: x = time, one row per
  robot, coloured by activity), static; ``/gantt/now`` the time cursor over it, on ``sim_time``;
- ``/progress/<state>``: how many components are in each state (``Assembled``: installed);
- ``/events``: one text line per activity start.

Labels are recorded hidden (``show_labels=False``): names show on hover and in the selection panel.

Timelines: ``sim_time`` (seconds from the start of the build, a duration) and, when a start date is
given, ``calendar`` (wall-clock timestamps). An RCAN run adds ``rcan_time`` and, from the mujoco
backend's trajectory, ``physics_time`` (:mod:`bimrobot.replay.record_rcan`).
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np

from bimrobot.replay.compact import is_large, log_compact
from bimrobot.replay.elements import (STATE_COLOURS, UNSCHEDULED, drawn_record, element_paths, element_properties,
                                       entity, mesh3d, mesh_arrays, own_rgb, piece_timelines)
from bimrobot.replay.gantt import log_chart, schedule_bars
from bimrobot.replay.inputs import INSTALLED, STATES, BuildRecord, node_id_of
from bimrobot.replay.motion import component_poses, robot_tracks

APPLICATION_ID = "bimrobot"
TIMELINE = "sim_time"
CALENDAR = "calendar"

NODE_COLOURS = {"waiting": (140, 140, 140), "assembling": (255, 152, 0), "assembled": (67, 160, 71)}
ROBOT_COLOURS = {"transport": (30, 136, 229), "positioning": (142, 36, 170), "assembly": (216, 27, 96)}
#: Robot bodies: half sizes (x, y, z) in metres, by kind (simple boxes, not the real machines).
ROBOT_HALF_SIZES = {"transport": (0.6, 0.4, 0.25), "positioning": (0.45, 0.45, 0.7), "assembly": (0.35, 0.35, 0.9)}


class _Clock:
    """Sets the recording's time on the simulated timeline and, with a start date, on the calendar."""

    def __init__(self, rec, start: dt.datetime | None):
        self.rec, self.start = rec, start

    def at(self, seconds: float) -> None:
        self.rec.set_time(TIMELINE, duration=float(seconds))
        if self.start is not None:
            self.rec.set_time(CALENDAR, timestamp=self.start + dt.timedelta(seconds=float(seconds)))

    def columns(self, seconds) -> list:
        """The time columns of rows at ``seconds`` (for ``send_columns``): sim_time and, with a start, calendar."""
        import rerun as rr

        seconds = np.asarray(seconds, dtype=float)
        out = [rr.TimeColumn(TIMELINE, duration=seconds)]
        if self.start is not None:
            out.append(rr.TimeColumn(CALENDAR, timestamp=[self.start + dt.timedelta(seconds=float(t)) for t in seconds]))
        return out


def is_replay_recording(path: Path) -> bool:
    """Whether ``path`` is a Rerun recording bimrobot wrote (the output policy's recogniser,
    :mod:`bimrobot.core.io`): its recording properties, the first chunks of the file as Rerun's own
    reader decodes them, name it with :data:`bimrobot.core.io.SIGNATURE`. The file's bytes cannot be
    searched for the signature: a recording is LZ4-compressed, and the compressor may write part of the
    signature as a reference to an earlier "bimrobot" (ROOT-staal's replay: not one plain copy in 1.2 MB)."""
    import warnings

    from rerun.chunk import RrdReader

    from bimrobot.core import io

    try:
        with warnings.catch_warnings():  # a truncated file is "legacy" to the reader: not ours either way
            warnings.simplefilter("ignore")
            for chunk in RrdReader(path).stream():
                if chunk.entity_path != "/__properties":
                    return False  # the properties come first (write_rrd sends the name before anything else)
                if io.SIGNATURE in str(chunk.to_record_batch().to_pylist()):
                    return True
    except (RuntimeError, ValueError, OSError):  # not a recording, or not a whole one
        return False
    return False


#: The unbuilt work: translucent grey (RGBA), each element shrunk about its centre by this factor.
GHOST_RGBA = (150, 150, 150, 100)
GHOST_SHRINK = 0.99


def write_rrd(record: BuildRecord, rrd: Path, start: dt.datetime | None = None, name: str | None = None,
              compact: bool | None = None) -> dict:
    """Write the replay of ``record`` to ``rrd`` (a path the caller made safe); return a summary dict
    (elements, entities drawn for them, components, installed, last installation time, meshes drawn
    simplified, ``drawn``: "meshes" or "boxes by state"). ``compact``: draw the building as boxes by state
    (:mod:`bimrobot.replay.compact`); None: when the model is large (:func:`bimrobot.replay.compact.is_large`)."""
    import rerun as rr

    from bimrobot.core import io
    from bimrobot.replay.layout import blueprint

    elements = len(record.pieces)
    record, simplified = drawn_record(record)
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=f"bimrobot-replay-{name or Path(rrd).stem}",
                             batcher_config=_batcher(rr))
    rec.set_log_time_enabled(False)  # a replay is the same whenever it is written
    # The signature in the recording's name lets bimrobot replace its own .rrd (docs/conventions.md,
    # is_replay_recording): sent before the file sink exists, it is buffered and written first, ahead of
    # the blueprint, so the recogniser finds it in the file's first chunks.
    rec.send_recording_name(f"{record.title} - {io.signature('replay')}")
    rec.save(str(rrd), default_blueprint=blueprint(record))
    clock = _Clock(rec, start)
    paths = element_paths(record)
    _log_ghost(rec, record)
    large = is_large(record) if compact is None else compact
    compact = bool(record.schedule) and large
    entities = _log_build(rec, clock, record, paths, compact) if record.schedule else len(record.pieces)
    summary = _log_progress(rec, clock, record)
    summary.update(pieces=elements, entities=entities, simplified=simplified,
                   drawn="boxes by state" if compact else "meshes")
    if record.rcan is not None:  # what RCAN executed, and the physics bodies, on their own clocks
        from bimrobot.replay.record_rcan import log_physics, log_rcan

        log_rcan(rec, record.rcan)
        summary["rcan_activities"] = len(record.rcan.activities)
        summary["rcan_done"] = len(record.rcan.done)
        if record.rcan.bodies:
            summary.update(log_physics(rec, record, record.rcan, together=large))
    if record.schedule:  # last: its time cursor ends the viewer's timeline once everything before is in
        rec.flush()  # the rows still batched go to the file first (send_columns chunks are written at once)
        log_gantt(rec, record)
    rec.flush()
    rec.disconnect()
    return summary


def _log_build(rec, clock: _Clock, record: BuildRecord, paths: dict[str, str], compact: bool) -> int:
    """The simulated build on sim_time: the building (each element's mesh, or boxes by state when
    ``compact``), the robots and the nodes; returns the entities drawn for the building."""
    tracks = robot_tracks(record)
    poses = component_poses(record, tracks)
    if compact:
        entities = log_compact(rec, clock, record, poses, _node_times(record))
    else:
        _log_pieces(rec, clock, record, poses, paths)
        entities = len(record.pieces)
    _log_robots(rec, clock, record, tracks)
    _log_nodes(rec, clock, record)
    return entities


def _batcher(rr):
    """Few large chunks rather than many small ones (the SDK flushes every 8 ms by default): the web
    viewer takes a recording in chunk by chunk between frames, so fewer chunks load in fewer frames."""
    return rr.ChunkBatcherConfig(flush_tick=3600.0, flush_num_bytes=32 << 20, flush_num_rows=1 << 20)


def ghost_pieces(record: BuildRecord) -> list[str]:
    """The elements the replay builds: the pieces of every component that is not in place at its start
    and the bolts, plates and welds of the joints it assembles; for an RCAN run replayed alone (no
    schedule), the pieces of RCAN's components."""
    built = {gid for component, history in record.states.items() if history and not _in_place(history[0][1])
             for gid in record.parts.get(component, [])}
    built |= {r for node in record.nodes.values() for r in node.realizing}
    if record.rcan is not None and not record.schedule:
        from bimrobot.replay.record_rcan import component_pieces

        built |= {g for a in record.rcan.activities for g in component_pieces(record, a.component_id)}
    return [gid for gid in record.pieces if gid in built]


def _in_place(state: str) -> bool:
    return STATES.index(state) >= STATES.index("PositionFixed")


def _log_ghost(rec, record: BuildRecord) -> None:
    """``/ghost``: the work still to be built at its installed place, translucent grey (static)."""
    import rerun as rr

    gids = ghost_pieces(record)
    if not gids:
        return
    parts = []
    for gid in gids:
        piece = record.pieces[gid]
        pose = piece.installed_pose
        world = piece.triangles @ pose[:3, :3].T + pose[:3, 3]
        centre = world.reshape(-1, 3).mean(axis=0)
        parts.append(centre + GHOST_SHRINK * (world - centre))
    rec.log("/ghost", mesh3d(rr, np.concatenate(parts), GHOST_RGBA[:3], GHOST_RGBA[3]), static=True)


def _log_pieces(rec, clock: _Clock, record: BuildRecord, poses: dict, paths: dict[str, str]) -> None:
    """Each element's mesh (at 0 s, or when its joint is assembled), pose and state over time: one
    chunk per element (:func:`_send_rows`), so that the viewer takes a large model in few pieces."""
    for gid, (kind, when) in piece_timelines(record, _node_times(record)).items():
        piece = record.pieces[gid]
        own = own_rgb(piece)
        if kind == "component":
            history = when
            moves = poses.get(gid) or []
            rows = [(0.0, "mesh", STATE_COLOURS[history[0][1]])] + [(t, "pose", pose) for t, pose in moves]
            rows += [(t, "colour", STATE_COLOURS[state]) for t, state in history] + [(t, "state", s) for t, s in history]
        elif kind == "joint":
            # a bolt, plate or weld of a joint: brought by the assembly robot, shown from the joint's assembly
            begin, end = when
            rows = [(begin, "mesh", NODE_COLOURS["assembling"]), (begin, "pose", piece.installed_pose),
                    (begin, "state", "WorkingInAssembly"), (end, "colour", own), (end, "state", INSTALLED)]
        else:
            # not built by the fleet (work of others, or not in the simulated selection): as the model has it
            rows = [(0.0, "mesh", own), (0.0, "pose", piece.installed_pose), (0.0, "state", UNSCHEDULED)]
        _send_rows(rec, clock, paths[gid], piece.triangles, rows, element_properties(record, gid))


def _send_rows(rec, clock: _Clock, path: str, triangles: np.ndarray, rows: list[tuple], properties: dict) -> None:
    """Send an element's history as one chunk: ``rows`` of (time s, what, value), in time order (rows
    of one time in the given order), where ``what`` is "mesh" (its geometry, coloured RGB ``value``),
    "colour" (RGB), "state" (the ``state`` property) or "pose" (4x4, model frame). A row sets only its
    own components; the others are null there. ``properties`` (:func:`element_properties`) go with the mesh."""
    import rerun as rr

    rows = sorted(rows, key=lambda row: row[0])  # stable: a time's rows keep their order
    n = len(rows)
    which = {kind: [i for i, row in enumerate(rows) if row[1] == kind] for kind in ("mesh", "colour", "state", "pose")}
    columns = []
    for i in which["mesh"]:
        columns += [_Sparse(c, [i], n) for c in _geometry_columns(rr, triangles)]
        columns += [_Sparse(c, [i], n) for c in _one_row(rr.AnyValues.columns(**{k: [v] for k, v in properties.items()}))]
    colours = sorted(which["mesh"] + which["colour"])
    if colours:
        rgba = [[*rows[i][2], 255] for i in colours]
        columns += [_Sparse(c, colours, n) for c in rr.Mesh3D.columns(albedo_factor=rgba)]
    if which["state"]:
        columns += [_Sparse(c, which["state"], n) for c in rr.AnyValues.columns(state=[rows[i][2] for i in which["state"]])]
    if which["pose"]:
        matrices = np.array([rows[i][2] for i in which["pose"]], dtype=np.float32)
        columns += [_Sparse(c, which["pose"], n) for c in
                    rr.Transform3D.columns(translation=matrices[:, :3, 3], mat3x3=matrices[:, :3, :3])]
    rec.send_columns(path, indexes=clock.columns([row[0] for row in rows]), columns=columns)


class _Sparse:
    """A component column over some rows of a chunk (``rows`` of ``n``; null, i.e. not logged, in the
    others), for ``send_columns``: Rerun's chunks are sparse, so one chunk carries what an element's
    rows set at different times (geometry once, colours at state changes, poses while moving)."""

    def __init__(self, column, rows: list[int], n: int):
        self.column, self.rows, self.n = column, np.asarray(rows, dtype=int), n

    def component_descriptor(self):
        return self.column.component_descriptor()

    def as_arrow_array(self):
        import pyarrow as pa

        dense = self.column.as_arrow_array()  # a list array, one entry per row in self.rows
        lengths = np.zeros(self.n, dtype=np.int32)
        lengths[self.rows] = np.diff(dense.offsets.to_numpy())
        offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int32)
        null = np.ones(self.n, dtype=bool)
        null[self.rows] = False
        return pa.ListArray.from_arrays(pa.array(offsets), dense.flatten(), mask=pa.array(null))


def _geometry_columns(rr, triangles: np.ndarray) -> list:
    """The mesh of :func:`_mesh` (without its colour) as columns of one row each."""
    vertices, indices, normals = mesh_arrays(triangles)
    return _one_row(rr.Mesh3D.columns(vertex_positions=vertices, triangle_indices=indices, vertex_normals=normals))


def _one_row(columns) -> list:
    """Columns (``Archetype.columns(...)``) each as a single row holding all its values."""
    return [c.partition([len(c.component_batch.as_arrow_array())]) for c in columns]


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
    """Each robot's box over time, with its current activity as a hidden label (shown on hover): one
    chunk per robot, the box itself once (at 0 s), its position while it moves and its label when its
    activity changes (:func:`_send_rows`' sparse columns); ``/events``, one text line per activity start."""
    import rerun as rr

    lines: list[tuple[float, str]] = []
    for name, robot in record.robots.items():
        half = ROBOT_HALF_SIZES.get(robot.kind, (0.4, 0.4, 0.4))
        colour = ROBOT_COLOURS.get(robot.kind, (120, 120, 120))
        track = tracks[name]
        rows = sorted([(t, "pose", (x, y)) for t, x, y in track.positions] +
                      [(t, "label", f"{name}: {label}") for t, label, _ in track.activities], key=lambda row: row[0])
        n = len(rows)
        poses = [i for i, row in enumerate(rows) if row[1] == "pose"]
        labels = [i for i, row in enumerate(rows) if row[1] == "label"]
        columns = [_Sparse(c, labels[:1], n) for c in _one_row(rr.Boxes3D.columns(
            half_sizes=[half], centers=[[0.0, 0.0, half[2]]], colors=[colour], fill_mode="solid", show_labels=[False]))]
        columns += [_Sparse(c, labels, n) for c in rr.Boxes3D.columns(labels=[rows[i][2] for i in labels])]
        columns += [_Sparse(c, poses, n) for c in
                    rr.Transform3D.columns(translation=[(*rows[i][2], 0.0) for i in poses])]
        rec.send_columns(entity("robots", name), indexes=clock.columns([row[0] for row in rows]), columns=columns)
        lines += [(t, f"t = {t:,.1f} s  {name}: {label}") for t, label, busy in track.activities if busy]
    if lines:
        lines.sort(key=lambda line: line[0])
        rec.send_columns("/events", indexes=clock.columns([t for t, _ in lines]),
                         columns=rr.TextLog.columns(text=[text for _, text in lines], level=["INFO"] * len(lines)))


def _log_nodes(rec, clock: _Clock, record: BuildRecord) -> None:
    """``/nodes``: every connection node a point (one entity: hover a point for its node), grey while
    waiting, orange while assembled, green once assembled; one row per time a node changes."""
    import rerun as rr

    if not record.nodes:
        return
    times = _node_times(record)
    ids = list(record.nodes)
    steps = sorted({0.0} | {t for node in ids for t in times[node]})
    colours = [[NODE_COLOURS[_node_phase(times[node], t)] for node in ids] for t in steps]
    columns = [_Sparse(c, [0], len(steps)) for c in _one_row(rr.Points3D.columns(
        positions=[record.nodes[node].position for node in ids], radii=[0.08] * len(ids),
        labels=[f"node {node}" for node in ids], show_labels=[False]))]
    columns += list(rr.Points3D.columns(colors=[c for row in colours for c in row]).partition([len(ids)] * len(steps)))
    rec.send_columns("/nodes", indexes=clock.columns(steps), columns=columns)


def _node_phase(times: tuple[float, float], t: float) -> str:
    begin, end = times
    return "assembled" if t >= end else "assembling" if t >= begin else "waiting"


def _log_progress(rec, clock: _Clock, record: BuildRecord) -> dict:
    """Counts of components per state over time (``/progress/<state>``); returns the replay's summary.
    A count is logged only where it changes (and at the first and last time), drawn as steps (Rerun's
    ``StepAfter`` interpolation: a count holds until its next row)."""
    import rerun as rr

    times, counts, current = _state_counts(record)
    for column, state in enumerate(STATES if record.states else ()):
        path = entity("progress", state)
        rec.log(path, rr.SeriesLines(names=state, colors=[STATE_COLOURS[state]],
                                     interpolation_mode=rr.components.InterpolationMode.StepAfter), static=True)
        keep = _changes(counts[:, column])
        rec.send_columns(path, indexes=clock.columns(times[keep]), columns=rr.Scalars.columns(scalars=counts[keep, column]))
    return {
        "pieces": len(record.pieces),
        "components": len(record.states),
        "robots": len(record.robots),
        "nodes": len(record.nodes),
        "installed": sum(1 for s in current.values() if s == INSTALLED),
        "last_installation_s": _last_installation(record),
        "makespan_s": record.makespan,
    }


def _events(record: BuildRecord) -> list[tuple[float, str, str]]:
    return sorted((t, component, state) for component, history in record.states.items() for t, state in history)


def _state_counts(record: BuildRecord) -> tuple[np.ndarray, np.ndarray, dict[str, str]]:
    """(times s, counts (times, states) of components per state after each time, final state of each
    component)."""
    events = _events(record)
    current: dict[str, str] = {}
    times, counts = [], []
    for index, (t, component, state) in enumerate(events):
        current[component] = state
        if index + 1 == len(events) or events[index + 1][0] != t:
            row = {s: 0 for s in STATES}
            for s in current.values():
                row[s] += 1
            times.append(t)
            counts.append([row[s] for s in STATES])
    return np.array(times, dtype=float), np.array(counts, dtype=float).reshape(-1, len(STATES)), current


def _changes(values: np.ndarray) -> np.ndarray:
    """Indices of a series worth a row when drawn as steps: the first, the last, and where it differs
    from the row before (the rows left out repeat the value before them)."""
    keep = np.zeros(len(values), dtype=bool)
    if len(values):
        keep[[0, -1]] = True
        keep[1:] |= values[1:] != values[:-1]
    return np.flatnonzero(keep)


def _last_installation(record: BuildRecord) -> float | None:
    """The last time a component became installed (s; None when none did)."""
    current: dict[str, str] = {}
    last = None
    for t, component, state in _events(record):
        if state == INSTALLED and current.get(component) != INSTALLED:
            last = t
        current[component] = state
    return last


def log_gantt(rec, record: BuildRecord) -> int:
    """The schedule's chart (:mod:`bimrobot.replay.gantt`), ``/gantt`` on ``sim_time``; returns the
    number of bars."""
    return log_chart(rec, "gantt", list(record.robots), schedule_bars(record), record.makespan, (TIMELINE,))
