"""Exports of a read building to robot simulators: the Gazebo package (:mod:`.gazebo`), the MuJoCo scene
(:mod:`.mujoco`), the mass and inertia both use (:mod:`.inertia`) and the ``bimrobot convert``
command (:mod:`.cli`). Metres, kg, z up.
"""
