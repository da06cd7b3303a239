"""The replay's blueprint: what the viewer shows when a recording opens (Rerun's ``rerun.blueprint``).

- the 3D view, left, looks at the building (not the whole site) from the south-east and above, as
  close as lets the whole building fit the view (:func:`building_eye`);
- on the right one set of panels per timeline the recording has, as tabs: the schedule's
  (``sim_time``: the Gantt of bars, components per state, the activities) and RCAN's (``rcan_time``
  and ``physics_time``: RCAN's Gantt, activities done, RCAN's activities); the tab of the timeline
  the viewer opens on (:func:`main_timeline`) is the one shown, so that no panel is empty there;
- the time panel on that timeline, paused at its start.
"""

from __future__ import annotations

import numpy as np

from bimrobot.replay.inputs import BuildRecord

#: Direction from the building's centre to the eye (south-east, above), and the view's vertical
#: field of view the distance is chosen for (degrees; Rerun's default eye).
EYE_DIRECTION = np.array([0.55, -0.7, 0.45])
FIELD_OF_VIEW_DEG = 55.0
#: Share of the half field of view the building's farthest corner may take (1.0: at the view's edge).
FILL = 0.8
SCHEDULE_TAB = "Schedule (sim_time)"
RCAN_TAB = "RCAN (rcan_time, physics_time)"


def blueprint(record: BuildRecord | None = None):
    """The default layout (module docstring); without ``record``, the schedule's panels and a free eye."""
    import rerun.blueprint as rrb

    eye = building_eye(record) if record is not None else None
    tabs = []
    if record is None or record.schedule:
        tabs.append(_schedule_panels(record))
    if record is not None and record.rcan is not None:
        tabs.append(_rcan_panels(record))
    main = main_timeline(record)
    active = 0 if main == "sim_time" or len(tabs) == 1 else len(tabs) - 1
    side = rrb.Tabs(*tabs, active_tab=active) if len(tabs) > 1 else tabs[0]
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(name="Site (model frame, m)", origin="/",
                              contents=["/building/**", "/ghost", "/robots/**", "/nodes/**", "/bodies/**"],
                              eye_controls=eye),
            side,
            column_shares=[3, 2],
        ),
        rrb.TimePanel(timeline=main, state="expanded", play_state="paused"),
        collapse_panels=True,
    )


def _schedule_panels(record: BuildRecord | None):
    import rerun as rr
    import rerun.blueprint as rrb

    from bimrobot.replay.gantt import bounds as chart_bounds

    axis, bounds = None, None
    if record is not None:
        whole = rr.TimeRange(start=rr.TimeRangeBoundary.absolute(seconds=0.0),
                             end=rr.TimeRangeBoundary.absolute(seconds=max(record.makespan, 1.0)))
        axis = rrb.TimeAxis(view_range=whole)
        x_range, y_range = chart_bounds(record)
        bounds = rrb.VisualBounds2D(x_range=x_range, y_range=y_range)
    return rrb.Vertical(
        rrb.Spatial2DView(name="Gantt: robots' activities (hover a bar)", origin="/gantt", visual_bounds=bounds,
                          background=[255, 255, 255]),
        # no legend over the lines: the colours are the 3D view's state colours; hover a line for its state
        rrb.TimeSeriesView(name="Components per state (colours as in 3D; hover a line)", origin="/progress",
                           axis_x=axis, plot_legend=rrb.PlotLegend(visible=False)),
        rrb.TextLogView(name="Activities", origin="/events"),
        name=SCHEDULE_TAB,
    )


def _rcan_panels(record: BuildRecord):
    import rerun.blueprint as rrb

    from bimrobot.replay.gantt import chart_bounds
    from bimrobot.replay.record_rcan import timed_activities

    panels = [rrb.TimeSeriesView(name="RCAN: activities done per robot", origin="/rcan_done"),
              rrb.TextLogView(name="RCAN activities", origin="/rcan")]
    if timed_activities(record.rcan.activities):
        x_range, y_range = chart_bounds(len({a.robot for a in record.rcan.activities if a.robot}))
        panels.insert(0, rrb.Spatial2DView(name="RCAN Gantt: what each robot executed (hover a bar)",
                                           origin="/rcan_gantt", background=[255, 255, 255],
                                           visual_bounds=rrb.VisualBounds2D(x_range=x_range, y_range=y_range)))
    return rrb.Vertical(*panels, name=RCAN_TAB)


def building_bounds(record: BuildRecord) -> tuple[np.ndarray, np.ndarray]:
    """[xmin, ymin, zmin], [xmax, ymax, zmax] of the building: every element at its installed pose (m)."""
    boxes = np.concatenate([p.world_bounds(p.installed_pose) for p in record.pieces.values()])
    return boxes.min(axis=0), boxes.max(axis=0)


def building_eye(record: BuildRecord):
    """The 3D eye framing the building: looking at its centre from :data:`EYE_DIRECTION`, as close as
    lets every corner of its bounding box lie within :data:`FILL` of the half field of view; z up."""
    import rerun.blueprint as rrb

    low, high = building_bounds(record)
    centre = (low + high) / 2
    corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
    direction = EYE_DIRECTION / np.linalg.norm(EYE_DIRECTION)
    limit = FILL * np.radians(FIELD_OF_VIEW_DEG) / 2
    near, far = 0.01, 100.0 * max(float(np.linalg.norm(high - low)), 1.0)
    for _ in range(60):  # bisection: the corners' largest angle from the view axis falls with distance
        distance = (near + far) / 2
        near, far = (distance, far) if corner_angle(centre + distance * direction, centre, corners) > limit else (near, distance)
    return rrb.EyeControls3D(position=centre + far * direction, look_target=centre, eye_up=[0.0, 0.0, 1.0])


def corner_angle(eye: np.ndarray, target: np.ndarray, corners: np.ndarray) -> float:
    """The largest angle (radians) between the view axis (eye -> target) and a ray to a corner."""
    axis = (target - eye) / np.linalg.norm(target - eye)
    rays = corners - eye
    rays = rays / np.maximum(np.linalg.norm(rays, axis=1, keepdims=True), 1e-12)
    return float(np.arccos(np.clip(rays @ axis, -1.0, 1.0)).max())


def main_timeline(record: BuildRecord | None) -> str:
    """The timeline the viewer opens on: the physics run's when there is one, else the schedule's."""
    from bimrobot.replay.record_rcan import PHYSICS_TIME, RCAN_TIME

    if record is not None and record.rcan is not None and record.rcan.bodies:
        return PHYSICS_TIME
    if record is not None and not record.schedule and record.rcan is not None:
        return RCAN_TIME
    return "sim_time"
