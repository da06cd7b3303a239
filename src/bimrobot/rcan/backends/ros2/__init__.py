"""The ``ros2`` executor backend: RCAN nodes executed as ROS 2 actions on RCAN's own
``bimrobot_interfaces/action/ConstructionActivity``.

Action names: ``/bimrobot/<robot>/<activity>`` (e.g. ``/bimrobot/husky_ur5/pick_up``), so each of the
six activity features of a robot is its own action server, as in the thesis where each RCAN node drives
its own ROS script. A real robot serves the same actions.

Three modules, and only they import ROS (each only when called):

- :mod:`~bimrobot.rcan.backends.ros2.environment`: finding and loading ROS 2 (:func:`load_ros2`), the
  action names, Fast DDS shared-memory cleanup (:func:`stale_fastdds_files`, :func:`cleanup_fastdds`);
- :mod:`~bimrobot.rcan.backends.ros2.client`: :class:`Ros2Backend`, the executor backend (action client);
- :mod:`~bimrobot.rcan.backends.ros2.robot_node`: the shipped robot node (:func:`serve_robot_node`, on
  the kinematic robots of the ``sim`` backend) and :func:`robot_node_process`, which runs it in a
  subprocess; :mod:`~bimrobot.rcan.backends.ros2.commands` its command, ``bimrobot rcan robot-node``.

The names are re-exported here, so ``from bimrobot.rcan.backends.ros2 import X`` works for each; this
module declares the backend (:data:`INFO`) and imports none of them until a name is asked for.
"""

from __future__ import annotations

import importlib

from bimrobot.rcan.backends.info import BackendInfo, BackendOption

#: the ros2 backend: its goals' deadlines and liveness, and whether ``rcan run`` starts the shipped robot
#: node (which also takes the sim backend's --time-scale, --failure-probability and --seed)
INFO = BackendInfo(
    backend="bimrobot.rcan.backends.ros2.client:Ros2Backend",
    options=(
        BackendOption(("--deadline-factor",),
                      "ros2: a goal is cancelled after --deadline-min + F x its expected duration "
                      "(robot seconds x the robots' time scale; default 3)",
                      keyword="deadline_factor", default=3.0, metavar="F", low=0.0, high=86400.0),
        BackendOption(("--deadline-min",), "ros2: the least time a goal gets, seconds (default 30)",
                      keyword="deadline_min_s", default=30.0, metavar="S", low=0.1, high=86400.0),
        BackendOption(("--liveness",),
                      "ros2: a robot whose server sends no feedback for this long while it works is "
                      "taken for dead; its activity goes to another capable robot (default 4 s)",
                      keyword="liveness_s", default=4.0, metavar="S", low=0.1, high=86400.0),
        BackendOption(("--robot-node",),
                      "ros2: start the shipped robot node for the run (spawn, default) or use robots "
                      "that already serve /bimrobot/<robot>/<activity> (external)",
                      type=str, choices=("spawn", "external"), default="spawn", run_only=True),
    ),
    commands=("bimrobot.rcan.backends.ros2.commands:register",),  # bimrobot rcan robot-node
)

#: name -> the module of this package that defines it (imported when first asked for)
_NAMES = {"Ros2Backend": "client", "robot_node_process": "robot_node", "serve_robot_node": "robot_node",
          **dict.fromkeys(("HEARTBEAT", "HEARTBEAT_S", "SETUP_HINT", "SHM_PATTERNS", "action_name", "cleanup_fastdds",
                           "fastdds_files", "interfaces_install", "load_ros2", "ros2_available",
                           "stale_fastdds_files"), "environment")}

__all__ = ["INFO", *sorted(_NAMES)]


def __getattr__(name: str):
    if name in _NAMES:
        return getattr(importlib.import_module(f"{__name__}.{_NAMES[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
