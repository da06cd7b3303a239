"""Assembly planning on the IFC's own problem (issue 38).

- :mod:`bimrobot.planning.problem` writes the exact problem ``bimrobot simulate --per-joint`` runs (and the
  CP-SAT model of :mod:`bimrobot.planning.optimal` solves) as a versioned JSON instance.
- :mod:`bimrobot.planning.dispatch` is the dispatching environment ``bimrobot/Dispatch-v0`` (registered on
  import; it imports Gymnasium): an agent decides who does what on ``simulate``'s own event simulation.

docs/planning.md describes both.
"""
