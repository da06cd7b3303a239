"""Policies shipped with bimrobot: ``dispatch.zip``, the learned dispatching policy (``--planner learned``;
how it was trained is in its ``bimrobot.json``, see docs/planning.md, "Learned planner")."""
