"""The ``sim`` backend: built-in kinematic robots that take travel and handling time.

Each robot has a mobile base (moves at ``speed_m_s`` in the xy plane), a manipulator (reaches
``reach_m`` horizontally from the base, moves the gripper at ``arm_speed_m_s``) and a gripper (takes
``handling_s[activity]`` to pick up or install). Robots check what a real robot would refuse: a target
out of the arm's reach, a pick-up without the gripper at the grasp pose, a component heavier than the
payload, transporting a component it does not hold, touching a component another robot holds. A
transport whose node releases the robot sets the component down at the drop-off point (the transport's
goal) and lets go; a later pick-up there takes it again. Any activity can also fail at random with
``failure_probability``; the draw is seeded by ``(seed, activity id, attempt)`` so a resumed run sees
the same failures as an uninterrupted one.

Time: every robot keeps its own clock in simulated seconds; an activity starts at
``max(robot clock, ready_at_s)`` (its predecessors' finish and its planned start). How long it takes is
the one time model's (:mod:`bimrobot.sco.timing`), the same as `simulate`'s: a drive (move to component,
transport) takes the distance between the points the robot works at (the activity's ``work_point``; the
base stands beside them) over its speed, a transport that sets the component down adds the unload time,
a pick-up from the yard the load time, a positioning the time per node, an install the time per
assembly point; arm motions take their distance over the arm's speed (nothing for a fleet robot, whose
handling times include them). Nothing here depends on the wall clock or on the order in which threads
run, so the same plan gives the same times. ``time_scale`` real seconds are slept per simulated second
(0: no sleeping, the default; 1: real time).

The world (robot poses, components, executed goals) lives in SQLite, in memory by default or in the
run's state database, so it survives a crash like a real site does. Executed goals are recorded in the
same transaction as their effect, keyed by activity id: a goal sent twice runs once, and a goal
whose activity already succeeded (any attempt) is refused with the earlier result.

Layout (compas_fab's backend features): :mod:`.site` holds :class:`KinematicSite`, the robots' world and
what every activity shares (the goal journal, the robot's clock, seeded failures, one transaction per
goal); each feature is a small class in :mod:`.drive` (*move to component*, *transport*), :mod:`.arm`
(*position for picking up*, *position for installing*) or :mod:`.gripper` (*pick up*, *install*), with
the step that says what the activity takes and does; :mod:`.backend` makes :class:`SimBackend` of them.
This module declares the backend (:data:`INFO`) and imports none of it until a name is asked for.
"""

from __future__ import annotations

import importlib

from bimrobot.rcan.backends.info import BackendInfo, BackendOption

#: the sim backend: its world lives in the run's state database; its options (also those of the ros2
#: backend's robot node, which runs the same robots)
INFO = BackendInfo(
    backend="bimrobot.rcan.backends.sim.backend:SimBackend",
    needs=("state_db",),
    simulated_time=True,
    options=(
        BackendOption(("--time-scale",),
                      "sim: real seconds slept per simulated second (default 0, as fast as possible)",
                      keyword="time_scale", default=0.0, low=0.0, high=1000.0,
                      unit="real seconds per simulated second"),
        BackendOption(("--failure-probability",), "sim: chance an activity fails (default 0)",
                      keyword="failure_probability", default=0.0, low=0.0, high=1.0),
        BackendOption(("--seed",), "sim: seed of the failure draws (default 0)", keyword="seed", type=int, default=0),
    ),
)

#: name -> the module of this package that defines it (imported when first asked for)
_NAMES = {"SimBackend": "backend", "KinematicSite": "site", "SCHEMA": "site", "Step": "site",
          "ARM_STOW_HEIGHT_M": "arm", "GRASP_TOLERANCE_M": "gripper"}

__all__ = ["INFO", *_NAMES]


def __getattr__(name: str):
    if name in _NAMES:
        return getattr(importlib.import_module(f"{__name__}.{_NAMES[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
