"""BuildingModel -> Gazebo package: SDF models and worlds, meshes, launch files, occupancy maps.

``package.convert(ifc, out)`` / ``package.build_package(model, out)`` write the package (see
docs/world.md); ``names.safe_name`` makes GlobalIds file- and SDF-safe; ``physics`` computes mass and
inertia; ``layout`` the installed and yard poses; ``navmap`` the per-storey maps; ``check`` validates a
written package; ``render`` draws one.
"""
