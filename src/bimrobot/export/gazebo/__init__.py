"""BuildingModel -> Gazebo package: SDF models and worlds, meshes, launch files, occupancy maps.

``conversion.convert(ifc, out)`` / ``package.build_package(model, out)`` write the package (see
docs/world.md); ``bimrobot.core.names.safe_name`` makes GlobalIds file- and SDF-safe; ``bimrobot.export.inertia``
computes mass and inertia; ``layout`` the installed and yard poses; ``navmap`` the per-storey maps; ``merge`` the merged static
models of ``--merge-static``; ``bimrobot.core.pool`` runs the per-model work on every core; ``check`` validates a
written package (``validate_world`` in parallel batches, for thousands of models); ``render`` draws one.
"""
