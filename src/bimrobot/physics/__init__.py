"""Physics in MuJoCo: the converted building as an MJCF scene, the robots that build it, and their motion.

- :mod:`bimrobot.export.mujoco.collision`: collision pieces of an element (convex hull, or CoACD convex
  decomposition for concave members, under a per-element budget)
- :mod:`bimrobot.export.mujoco.scene`: ``convert --target mujoco``: one MJCF body per element
- :mod:`bimrobot.physics.robot`: the mobile manipulator family (wheeled base, UR5-kinematics arm, gripper)
- :mod:`bimrobot.physics.motion`: grid paths for the base, inverse kinematics for the arm, the weld grasp
- :mod:`bimrobot.physics.planning`: OMPL paths for an arm and a base, bounded by iterations, seeded
- :mod:`bimrobot.physics.placement`: where a component given only by its size lies or is installed
- :mod:`bimrobot.physics.site`: the site where robots act, as skills (world, control, contacts,
  clearance, paths, base, stands, arm, grasp); it knows nothing of RCAN

MuJoCo is imported only by these modules (and :mod:`bimrobot.rcan.backends.mujoco`). Units: metres,
kg, seconds, radians; z up.
"""
