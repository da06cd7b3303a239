"""Policies shipped with bimrobot: ``dispatch.zip``, the learned dispatching policy (``--planner learned``),
which reads the dispatching environment's local observation; how it was trained is in its
``bimrobot.json`` (see docs/planning.md, "Learned planner")."""
