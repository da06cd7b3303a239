"""The MuJoCo scene of a building (``convert --target mujoco``): one MJCF body per element
(:mod:`.scene`) with collision pieces, a convex hull or a CoACD decomposition (:mod:`.collision`).
"""
