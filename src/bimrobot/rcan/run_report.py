"""What an RCAN run reports (:class:`RunReport`), and the plan's signature that ties a state database to
one plan. Times: simulated/robot seconds, and real (wall) seconds where named so.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field

from bimrobot.rcan.activities import RcanActivity
from bimrobot.rcan.state_manager import DONE, EscalationReport


@dataclass
class RunReport:
    """The outcome of a run. ``status``: ``completed``, ``escalated`` (some activity needs a technician)
    or ``blocked`` (activities left that no free robot can take). Times: ``makespan_s`` simulated/robot
    seconds, ``wall_s`` real seconds; ``latencies_s`` real seconds from sending each node to its result.
    """

    status: str
    done: list[str]
    escalations: list[EscalationReport]
    component_states: dict[str, str]
    makespan_s: float
    wall_s: float
    latencies_s: list[float] = field(default_factory=list)
    resumed: int = 0
    blocked: list[str] = field(default_factory=list)
    #: blocked activity -> the escalated activity it waits for (directly or through its predecessors);
    #: a blocked activity not in here waits for a robot that never became free
    blocked_by: dict[str, str] = field(default_factory=dict)
    #: activity -> the robot it was given to (the one the schedule assigned, unless re-allocated)
    robots: dict[str, str] = field(default_factory=dict)
    #: activity -> {robot, started_s, finished_s, result}, in plan order: ``result`` its status (done,
    #: escalated, pending, started); the times robot seconds of a done activity, else None (unknown)
    activities: dict[str, dict] = field(default_factory=dict)
    #: what the backend measured, when it says (``mujoco``: placement error per installed component)
    backend_summary: dict = field(default_factory=dict)

    @property
    def escalated(self) -> list[str]:
        return [r.activity_id for r in self.escalations]


def plan_signature(activities: list[RcanActivity]) -> str:
    """A hash of the plan, so a state database is never resumed with a different plan."""
    text = json.dumps([(a.activity_id, a.component_id, a.kind.value, a.target.as_tuple(), a.predecessors)
                       for a in activities])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def activity_timing(row: dict | None) -> dict:
    """An activity's entry in :attr:`RunReport.activities` from its state database row."""
    row = row or {}
    done = row.get("status") == DONE  # times of an activity that is not done are unknown (None)
    return {"robot": row.get("robot"), "started_s": row.get("started_s") if done else None,
            "finished_s": row.get("finished_s") if done else None, "result": row.get("status") or "pending"}


def dependents(activities: list[RcanActivity], roots: list[str]) -> dict[str, str]:
    """Activity -> the first of ``roots`` it depends on, directly or through predecessors (linear time)."""
    successors: dict[str, list[str]] = {}
    for a in activities:
        for p in a.predecessors:
            successors.setdefault(p, []).append(a.activity_id)
    cause: dict[str, str] = {}
    for root in roots:
        stack = [root]
        while stack:
            for successor in successors.get(stack.pop(), ()):
                if successor not in cause:
                    cause[successor] = root
                    stack.append(successor)
    return cause
