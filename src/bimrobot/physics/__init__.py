"""Physics in MuJoCo: the converted building as an MJCF scene, the robots that build it, and their motion.

- :mod:`bimrobot.physics.collision`: collision pieces of an element (convex hull, or CoACD convex
  decomposition for concave members, under a per-element budget)
- :mod:`bimrobot.physics.scene`: ``convert --target mujoco``: one MJCF body per element
- :mod:`bimrobot.physics.robot`: the mobile manipulator family (wheeled base, UR5-kinematics arm, gripper)
- :mod:`bimrobot.physics.motion`: grid paths for the base, inverse kinematics for the arm, the weld grasp

MuJoCo is imported only by these modules (and :mod:`bimrobot.rcan.backends.mujoco`). Units: metres,
kg, seconds, radians; z up.
"""
