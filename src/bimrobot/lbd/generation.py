"""What RCAN's generation system asks the construction graph (thesis l.5779-5790), as Python calls.

The questions are SPARQL ``.rq`` files in ``lbd/queries`` so that any SPARQL client can ask them too;
these functions run them on a :class:`bimrobot.lbd.graph.ConstructionGraph` (any store) and return
plain dicts. Units: seconds, metres (world frame), kg.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any
from bimrobot.core.tasks import TASKS

if TYPE_CHECKING:  # pragma: no cover
    from bimrobot.lbd.graph import ConstructionGraph

#: The component states in which each kind of activity may start (the rule ``rcan_ready_activities.rq``
#: encodes in its VALUES block; kept here for callers and tests).
ALLOWED_STATES = {task: tuple(str(state) for state in task.ready_states) for task in TASKS}


def ready_activities(graph: ConstructionGraph) -> list[dict[str, Any]]:
    """Activities RCAN may start now: not started, every predecessor Completed, and the component in a
    state of :data:`ALLOWED_STATES` for the activity's kind; in planned order, one dict each with
    ``activityId, activityType, globalId, componentState, robot, start, weightKg, targetX/Y/Z,
    nodeId, assemblyPoints, assemblyMethod`` (None where the graph has no value)."""
    return graph.query("rcan_ready_activities")


def activity_details(graph: ConstructionGraph, activity_id: str) -> dict[str, Any] | None:
    """One activity's robot, times, weight, size and goal (``component_activities`` of its component),
    or None when the graph has no such activity with a component."""
    rows = graph.query(
        "SELECT ?globalId WHERE { ?a <https://bimrobot.example/ns#identification> ?activityId ; "
        "<https://w3id.org/digitalconstruction/0.5/Processes#hasObject>/<https://bimrobot.example/ns#globalId> ?globalId }",
        activityId=activity_id,
    )
    if not rows:
        return None
    for row in graph.query("component_activities", globalId=rows[0]["globalId"]):
        if row["activityId"] == activity_id:
            return {"globalId": rows[0]["globalId"], **row}
    return None
