"""The RCAN node: one-to-one link between one construction activity of a component and one robot."""

from __future__ import annotations

from dataclasses import dataclass

from bimrobot.rcan.activities import ActivityKind, Pose, RcanActivity
from bimrobot.core.tasks import Task


@dataclass(frozen=True)
class RcanNode:
    """An instantiated RCAN node (thesis 5.2.2): component, activity, robot, target pose and backend.

    ``node_id`` is ``rcan/<activity id>``; the backend is the name of the executor backend that drives
    the robot (``sim`` or ``ros2``).
    """

    node_id: str
    activity: RcanActivity
    robot: str
    backend: str

    @property
    def activity_id(self) -> str:
        return self.activity.activity_id

    @property
    def component_id(self) -> str:
        return self.activity.component_id

    @property
    def kind(self) -> ActivityKind:
        return self.activity.kind

    @property
    def target(self) -> Pose:
        return self.activity.target

    def to_message(self) -> dict:
        """Plain JSON-able dict carried by the broker."""
        a = self.activity
        return {
            "node_id": self.node_id,
            "activity_id": a.activity_id,
            "component_id": a.component_id,
            "activity": a.kind.value,
            "target": [a.target.x, a.target.y, a.target.z, a.target.yaw],
            "weight_kg": a.weight_kg,
            "section_m": list(a.section_m) if a.section_m else None,
            "size_m": list(a.size_m) if a.size_m else None,
            "releases_robot": a.releases_robot,
            "lifts": a.lifts,
            "task": a.task.value if a.task else None,
            "nodes": a.nodes,
            "points": a.points,
            "work_point": [a.work_point.x, a.work_point.y, a.work_point.z] if a.work_point else None,
            "loads": a.loads,
            "robot": self.robot,
            "backend": self.backend,
        }

    @classmethod
    def from_message(cls, message: dict) -> "RcanNode":
        kind = ActivityKind(message["activity"])
        frees = message.get("releases_robot")
        activity = RcanActivity(
            activity_id=message["activity_id"],
            component_id=message["component_id"],
            kind=kind,
            target=Pose(*message["target"]),
            weight_kg=None if message.get("weight_kg") is None else float(message["weight_kg"]),
            section_m=tuple(message["section_m"]) if message.get("section_m") else None,
            size_m=tuple(message["size_m"]) if message.get("size_m") else None,
            frees_robot=None if frees is None or bool(frees) == (kind is ActivityKind.INSTALL) else bool(frees),
            lifts=bool(message.get("lifts", True)),
            task=Task(message["task"]) if message.get("task") else None,
            nodes=None if message.get("nodes") is None else int(message["nodes"]),
            points=None if message.get("points") is None else int(message["points"]),
            work_point=Pose(*message["work_point"]) if message.get("work_point") else None,
            loads=bool(message.get("loads", True)),
        )
        return cls(message["node_id"], activity, message["robot"], message["backend"])
