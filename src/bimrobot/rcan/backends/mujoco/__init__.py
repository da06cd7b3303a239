"""The ``mujoco`` backend: the six activities executed physically in MuJoCo (bimrobot.physics).

Each robot of the fleet becomes a mobile manipulator of the family of
:mod:`bimrobot.physics.robot` (``ur5`` for payload <= 5 kg and reach <= 0.85 m, else ``heavy``; its
base ``footprint_m`` when the table gives one) at its home, or beside it when a robot listed before it
starts there (:func:`starts_apart`). Components are boxes:

- given by ``shapes`` or :func:`experiment_shapes` (the thesis' experiments): upright, centred on the
  activity's target, entering the scene when an activity first names it, as before;
- else of the plan's ``size_m``, placed by :mod:`bimrobot.physics.placement` (lying on the yard
  centred on the pick-up target; installed by the IFC origin: upright column, horizontal beam
  between the members it spans, flat footing). Given the ``plan`` (``run_plan`` passes it), every
  one starts in the scene: on the yard, or in place when no activity lifts it.

Under a box above the ground stands a support (a pedestal; a prop under a beam's middle third); one
below the ground gets a pit with a support at its floor. Components collide with the ground, the
supports and the robots, not with each other (the connections are not modelled). Robots collide
with each other, and each robot's paths and stands keep clear of the others as they stand (the
site's obstacles); a component one holds passes through the others, as through components.

- *move to component*, *transport*: the base drives along a collision-free path on an occupancy grid
  of the scene (supports and components on the ground, grown by half the base width and a clearance;
  pyastar2d's A*), turning and driving straight per leg; with a component held, in the carry posture.
- *position for picking up*: the base turns to face the component (backing away first when its
  corners would sweep into something), the arm moves through a pre-grasp 0.10 m above to the grasp
  pose (mink inverse kinematics, quintic joint-space interpolation, torque-limited servos).
- *pick up*: the gripper closes and a weld holds the component when the tool centre point is within
  5 mm and 2 degrees of the grasp pose; then it lifts 0.10 m. A component heavier than the arm's
  torque limits allow makes the lift fail (the arm sags): the activity fails naming its weight and
  the robot's rated payload, and the gripper lets go.
- *position for installing*: the held component goes through a point 0.10 m above its target to the
  target itself (its pose in the gripper, as gripped, taken into account).
- *install*: the gripper opens, the arm retracts; after 2 s the component's position error (mm) and
  angle error (degrees) to its target are measured, and it must not move more than 1 mm in 2 s more.
  Over :data:`POSITION_TOLERANCE_M` / :data:`ANGLE_TOLERANCE_DEG` the activity fails.

Turns: the robots share one physical world, so activities are executed one at a time. When the
coordinator runs in this process (``run_plan`` attaches it, :meth:`MujocoBackend.coordinator_settled`),
the next activity is chosen only once the coordinator has handled every result and every node it
has sent has arrived here, and it is the one ready first in simulated time (ties: activity id, then
attempt): a run is the same, activity for activity, whatever the threads' timing. An activity whose
way is blocked by other robots' work gives up its turn and is tried again after another activity has
finished (at most :data:`BLOCKED_WAITS` times); when every activity here is so blocked and nothing
else is coming, the first of them fails at once, with the reason it was last blocked. Before it gives
up its turn, the robots standing idle near it or its work (in no chain of activities: they have
placed their last component, or have had none yet) drive back to where they started, and it tries
once more (``made way (...)`` in its result). An activity that frees its robot ends with the robot's
empty arm taken back from its work and tucked (``its arm was left out: ...`` when it could not be). Without a
coordinator (tests, executors in another process) activities run in the order they arrive, and a
blocked one waits real seconds (:data:`BLOCKED_WAIT_S`, :data:`IDLE_WAIT_S`) for other work.

Times in results are simulated seconds. Every body's pose is recorded at 20 Hz (simulated time) and
written on close to ``<state db>.trajectory.csv`` beside the run's state database (or
``trajectory_path``): ``time_s, body, x, y, z, qw, qx, qy, qz``, the rows of the bodies that moved
(:func:`trajectory_rows`: a body's pose at any recorded time is its last row at or before it). The
physical world is not persisted: a resumed run starts the scene anew (completed goals are still
answered from memory within a run).

Layout (compas_fab's backend features): :mod:`.backend` holds :class:`MujocoBackend`, the turns
(:mod:`.turns`) and the run's outputs (:mod:`.trajectory`); each activity feature it declares in
:data:`FEATURES` is one module: :mod:`.move` (*move to component*), :mod:`.pick` (*position for
picking up*, *pick up*), :mod:`.transport`, :mod:`.position` (*position for installing*),
:mod:`.install`; :mod:`.scene` puts components and supports into the scene, :mod:`.layout` says
where robots and components start. The physics (:mod:`bimrobot.physics.site`) knows nothing of RCAN;
this package uses its public methods only. This module declares the backend (:data:`INFO`) and
imports none of it (nor numpy, nor MuJoCo) until a name is asked for.
"""

from __future__ import annotations

import importlib

from bimrobot.rcan.backends.info import BackendInfo

#: the mujoco backend: it sees the whole plan at the start (every component starts in the scene), writes
#: its trajectory where the run says, and its robots share one world, acting in turns
INFO = BackendInfo(backend="bimrobot.rcan.backends.mujoco.backend:MujocoBackend", needs=("plan", "trajectory_path"),
                   acts_in_turns=True)

#: name -> the module of this package that defines it (imported when first asked for)
_NAMES = {
    "MujocoBackend": "backend", "FEATURES": "backend",
    **dict.fromkeys(("ANGLE_TOLERANCE_DEG", "LIFT_M", "MAKE_WAY_M", "POSITION_TOLERANCE_M", "RESEAT_LIFT_M",
                     "RESEAT_TRIES", "SETTLE_S", "SUPPORT_MIN_Z_M"), "common"),
    **dict.fromkeys(("START_GAP_M", "START_STEP_M", "experiment_shapes", "starting_activities", "starts_apart",
                     "yard_footprints"), "layout"),
    **dict.fromkeys(("TRAJECTORY_POSITION_M", "TRAJECTORY_QUATERNION", "chassis_overlaps", "trajectory_rows"),
                    "trajectory"),
    **dict.fromkeys(("BLOCKED_WAIT_S", "BLOCKED_WAITS", "IDLE_WAIT_S"), "turns"),
}

__all__ = ["INFO", *_NAMES]


def __getattr__(name: str):
    if name in _NAMES:
        return getattr(importlib.import_module(f"{__name__}.{_NAMES[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
