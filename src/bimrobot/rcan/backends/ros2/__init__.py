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
  the kinematic robots of :class:`~bimrobot.rcan.backends.sim.KinematicSite`) and
  :func:`robot_node_process`, which runs it in a subprocess.

The names are re-exported here, so ``from bimrobot.rcan.backends.ros2 import X`` works for each.
"""

from bimrobot.rcan.backends.ros2.client import Ros2Backend
from bimrobot.rcan.backends.ros2.environment import (HEARTBEAT, HEARTBEAT_S, SETUP_HINT, SHM_PATTERNS, action_name,
                                                     cleanup_fastdds, fastdds_files, interfaces_install, load_ros2,
                                                     ros2_available, stale_fastdds_files)
from bimrobot.rcan.backends.ros2.robot_node import robot_node_process, serve_robot_node

__all__ = ["HEARTBEAT", "HEARTBEAT_S", "SETUP_HINT", "SHM_PATTERNS", "Ros2Backend", "action_name", "cleanup_fastdds",
           "fastdds_files", "interfaces_install", "load_ros2", "robot_node_process", "ros2_available",
           "serve_robot_node", "stale_fastdds_files"]
