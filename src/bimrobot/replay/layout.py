"""The replay's blueprint: what the viewer shows when a recording opens (Rerun's ``rerun.blueprint``).

- the 3D view, left, looks at the building (not the whole site) from the south-east and above, as
  close as lets the whole building fit the view, centred in it (:func:`building_eye`);
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
#: Width / height of the 3D view the eye is framed for: 3/5 of the window beside the panels, above
#: the expanded time panel (a 1280 x 800 browser window: 755 x 445 pixels, 1.7; a 1920 x 1080 screen
#: about 1.5). A wider view leaves room at the sides; a narrower one, down to 1.5 x FILL (1.35), still shows
#: the whole building.
VIEW_ASPECT = 1.5
#: Share of the view's half width and half height the building may take (1.0: to the view's edge).
FILL = 0.9
SCHEDULE_TAB = "Schedule (sim_time)"
RCAN_TAB = "RCAN (rcan_time, physics_time)"


def blueprint(record: BuildRecord | None = None):
    """The default layout (module docstring); without ``record``, the schedule's panels and a free eye."""
    import rerun.blueprint as rrb

    eye = building_eye(record) if record is not None and record.pieces else None  # nothing drawn: a free eye
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


def building_points(record: BuildRecord) -> np.ndarray:
    """(N, 3) the corners of each element's box at its installed pose (m): the building's outline,
    tighter than the corners of its one bounding box (a sparse building leaves those in empty air)."""
    signs = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])
    boxes = np.array([p.world_bounds(p.installed_pose) for p in record.pieces.values()])  # (n, 2, 3)
    return boxes[:, signs, [0, 1, 2]].reshape(-1, 3)


def screen_position(eye: np.ndarray, target: np.ndarray, points: np.ndarray, aspect: float = VIEW_ASPECT) -> np.ndarray:
    """(N, 2) where ``points`` appear in a 3D view looking from ``eye`` at ``target`` with z up, as
    Rerun's eye projects them (vertical field of view :data:`FIELD_OF_VIEW_DEG`, ``aspect`` width /
    height): x right and y up, -1 and 1 at the view's edges; a point behind the eye is at infinity."""
    right, up, back = _eye_axes(eye - target)
    relative = points - eye
    depth = np.maximum(-(relative @ back), 1e-9)
    half = np.tan(np.radians(FIELD_OF_VIEW_DEG) / 2)
    return np.stack([relative @ right / depth / (half * aspect), relative @ up / depth / half], axis=1)


def building_eye(record: BuildRecord):
    """The 3D eye framing the building: looking from :data:`EYE_DIRECTION`, z up, as close as keeps
    every element within :data:`FILL` of the view's half width and half height (a view of
    :data:`VIEW_ASPECT`), with the building centred in the view (:func:`frame_points`)."""
    import rerun.blueprint as rrb

    eye, target = frame_points(building_points(record))
    return rrb.EyeControls3D(position=eye, look_target=target, eye_up=[0.0, 0.0, 1.0])


def frame_points(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(eye, target) in metres: the eye along :data:`EYE_DIRECTION` from the target, at the distance
    where the farthest of ``points`` reaches :data:`FILL` of the view's edge (bisection), the target
    moved (a few rounds) until the points' extent on screen is centred."""
    direction = EYE_DIRECTION / np.linalg.norm(EYE_DIRECTION)
    low, high = points.min(axis=0), points.max(axis=0)
    target, size = (low + high) / 2, max(float(np.linalg.norm(high - low)), 1.0)
    for _ in range(6):
        near, far = 0.01, 100.0 * size
        for _ in range(60):  # bisection: the farthest point's place on screen falls with the distance
            distance = (near + far) / 2
            reach = np.abs(screen_position(target + distance * direction, target, points)).max()
            near, far = (distance, far) if reach > FILL else (near, distance)
        eye = target + far * direction
        on_screen = screen_position(eye, target, points)
        middle = (on_screen.min(axis=0) + on_screen.max(axis=0)) / 2
        right, up, _ = _eye_axes(direction)
        half = np.tan(np.radians(FIELD_OF_VIEW_DEG) / 2)  # the shift at the target's depth
        target = target + far * half * (middle[0] * VIEW_ASPECT * right + middle[1] * up)
    return target + far * direction, target


def _eye_axes(backward: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit right, up and back axes of an eye whose back axis is ``backward`` (target -> eye), z up."""
    back = backward / np.linalg.norm(backward)
    right = np.cross([0.0, 0.0, 1.0], back)
    right = right / np.linalg.norm(right)
    return right, np.cross(back, right), back


def main_timeline(record: BuildRecord | None) -> str:
    """The timeline the viewer opens on: the physics run's when there is one, else the schedule's."""
    from bimrobot.replay.record_rcan import PHYSICS_TIME, RCAN_TIME

    if record is not None and record.rcan is not None and record.rcan.bodies:
        return PHYSICS_TIME
    if record is not None and not record.schedule and record.rcan is not None:
        return RCAN_TIME
    return "sim_time"
