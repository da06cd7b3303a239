"""Assembly planning on the IFC's own problem (issue 38): the planning problem as data.

:mod:`bimrobot.planning.problem` writes the exact problem ``bimrobot simulate --per-joint`` runs (and the
CP-SAT model of :mod:`bimrobot.coordination.optimal` solves) as a versioned JSON instance; docs/planning.md
describes the format.
"""
