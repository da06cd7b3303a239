"""Where a ``mujoco`` run's robots and components start: robots at their homes or beside them, the
components of a plan on the yard (or in place), the thesis' experiments with their known shapes.
Metres, world frame, z up.
"""

from __future__ import annotations

import numpy as np

from bimrobot.rcan.activities import ActivityKind, RcanActivity

START_GAP_M = 0.2  # between the chassis of robots that start at one home
START_STEP_M = 0.25


def starts_apart(robots: dict[str, tuple[tuple[float, float], tuple[float, float]]], work_xy,
                 obstacles: list[tuple[tuple[float, float], tuple[float, float]]] = ()) -> dict[str, tuple[float, float]]:
    """Where each robot starts (x, y m): its home, unless a robot listed before it starts there or one
    of ``obstacles`` lies there (their boxes, the chassis facing +x, would come within
    :data:`START_GAP_M`): then the first spot clear of them on the line from the work's centre
    ``work_xy`` through the home, further out in steps of :data:`START_STEP_M`. (A site may have fewer
    homes than robots: fleet 2's six robots share four; and the yard's rows may cover a home.)
    ``robots``: name -> (home (x, y) m, footprint (length, width) m); ``obstacles``: (centre (x, y) m,
    axis-aligned size (x, y) m) of what lies on the ground, e.g. the components on the yard."""
    placed: list[tuple[np.ndarray, tuple[float, float]]] = [(np.asarray(c, float), size) for c, size in obstacles]
    starts = {}
    for name, (home, footprint) in robots.items():
        spot = np.asarray(home, float)
        outward = spot - np.asarray(work_xy, float)
        outward = outward / np.linalg.norm(outward) if np.linalg.norm(outward) > 1e-9 else np.array([1.0, 0.0])

        def taken(p):
            return any(abs(p[0] - q[0]) < (footprint[0] + f[0]) / 2 + START_GAP_M
                       and abs(p[1] - q[1]) < (footprint[1] + f[1]) / 2 + START_GAP_M for q, f in placed)

        while taken(spot):
            spot = spot + START_STEP_M * outward
        placed.append((spot, footprint))
        starts[name] = (float(spot[0]), float(spot[1]))
    return starts


def starting_activities(plan, shapes: dict) -> dict[str, RcanActivity | None]:
    """Component -> the activity that says where it starts: its first *position for picking up* (it
    lies on the yard at that target), or its first *position for installing* when no activity lifts
    it (it is in place, a footing), or None when a transport comes first (not on the yard as far as
    the plan says). Components of ``shapes`` or without a size or weight are left out."""
    first: dict[str, RcanActivity | None] = {}
    lifted = {a.component_id for a in plan if a.lifts}
    for activity in plan:
        gid = activity.component_id
        if gid in first or gid in shapes or activity.size_m is None or activity.weight_kg is None:
            continue
        if activity.kind is ActivityKind.TRANSPORT:
            first[gid] = None
        elif activity.kind is ActivityKind.POSITION_FOR_PICKING_UP and gid in lifted:
            first[gid] = activity
        elif activity.kind is ActivityKind.POSITION_FOR_INSTALLING and gid not in lifted:
            first[gid] = activity
    return first


def yard_footprints(plan, shapes: dict) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """(centre (x, y) m, axis-aligned size (x, y) m) of every component that starts lying on the yard
    (:func:`starting_activities`), as the scene lays it (:func:`bimrobot.physics.placement.lying_pose`)."""
    from bimrobot.physics.placement import body_size, yaw_frame

    footprints = []
    for activity in starting_activities(plan, shapes).values():
        if activity is None or activity.kind is not ActivityKind.POSITION_FOR_PICKING_UP:
            continue
        t = activity.target
        size = np.abs(yaw_frame(t.yaw)) @ np.array(body_size(sorted(activity.size_m)))
        footprints.append(((t.x, t.y), (float(size[0]), float(size[1]))))
    return footprints


def experiment_shapes() -> dict[str, tuple[float, float, float]]:
    """Shapes of the components of the thesis' experiments (the RCAN plan gives weight and section
    only): GlobalId -> (width, depth, length) m, from their IFC models (bimrobot.bim.examples)."""
    from bimrobot.bim.examples import RCAN_EXPERIMENTS

    return {entry[1]: (entry[3][0], entry[3][1], entry[4]) for entry in RCAN_EXPERIMENTS.values()}
