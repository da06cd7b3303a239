"""The interface every executor backend implements (in compas_fab's style: one named feature each).

A backend drives robots. Its *features* are the six construction activities of thesis chapter 5; a
backend implements each one as a method with the same name (``move_to_component``, ...). Adding a
backend means adding one module in :mod:`bimrobot.rcan.backends` that implements the same features and
registering it in :data:`bimrobot.rcan.backends.BACKENDS`.

Idempotency contract: ``execute`` is keyed on ``(activity_id, attempt)``. A backend that already
completed that goal returns the recorded result instead of executing it again, so a resumed run can
re-send a goal whose result it never received without the robot doing the work twice.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Callable

from bimrobot.rcan.activities import ActivityKind
from bimrobot.rcan.node import RcanNode

#: Feedback callback: (progress 0..1, phase text).
FeedbackCallback = Callable[[float, str], None]


@dataclass(frozen=True)
class ActivityResult:
    """What a robot reports after an activity. Times are simulated/robot seconds since the build start."""

    activity_id: str
    attempt: int
    robot: str
    success: bool
    message: str
    started_s: float = 0.0
    finished_s: float = 0.0
    #: the robot stopped answering during the activity (its node died): RCAN takes it out of service and
    #: gives the activity to another capable robot, or escalates it when there is none
    robot_lost: bool = False

    @property
    def duration_s(self) -> float:
        return self.finished_s - self.started_s

    def to_message(self) -> dict:
        # the fields one by one: dataclasses.asdict deep-copies recursively, a cost on every result
        return {"activity_id": self.activity_id, "attempt": self.attempt, "robot": self.robot, "success": self.success,
                "message": self.message, "started_s": self.started_s, "finished_s": self.finished_s,
                "robot_lost": self.robot_lost}

    @classmethod
    def from_message(cls, message: dict) -> "ActivityResult":
        return cls(
            activity_id=str(message["activity_id"]),
            attempt=int(message["attempt"]),
            robot=str(message["robot"]),
            success=bool(message["success"]) if not isinstance(message["success"], str)
            else message["success"].lower() in ("1", "true"),
            message=str(message["message"]),
            started_s=float(message.get("started_s", 0.0)),
            finished_s=float(message.get("finished_s", 0.0)),
            robot_lost=bool(message.get("robot_lost", False)),
        )


class ExecutorBackend(abc.ABC):
    """Drives robots for RCAN nodes. Subclasses implement the six activity features."""

    name: str = "abstract"

    def execute(
        self, node: RcanNode, attempt: int = 1, ready_at_s: float = 0.0, feedback: FeedbackCallback | None = None
    ) -> ActivityResult:
        """Run ``node``'s activity on its robot, not before ``ready_at_s``; idempotent per (activity, attempt)."""
        feature = getattr(self, node.kind.value)
        return feature(node, attempt, ready_at_s, feedback)

    @abc.abstractmethod
    def move_to_component(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Drive the mobile base to the component (target: base pose next to it)."""

    @abc.abstractmethod
    def position_for_picking_up(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Bring the gripper to the grasp pose on the component with the manipulator."""

    @abc.abstractmethod
    def pick_up(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Close the gripper on the component and lift it."""

    @abc.abstractmethod
    def transport(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Drive the mobile base, carrying the component, to the installation stand pose."""

    @abc.abstractmethod
    def position_for_installing(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Bring the held component to its installed pose with the manipulator."""

    @abc.abstractmethod
    def install(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Fix the component in place, open the gripper and return the arm to its initial pose."""

    def stop(self) -> None:
        """The run is ending (finished or interrupted): give up waiting for robots, so that no thread
        outlives the run. The default waits for nothing."""

    def close(self) -> None:
        """Release connections; the default has none."""


class DispatchingBackend(ExecutorBackend):
    """A backend that executes all six features through one method, :meth:`_run`, which looks at
    ``node.kind`` itself (the kinematic site, the ROS 2 client and the MuJoCo site do)."""

    @abc.abstractmethod
    def _run(self, node: RcanNode, attempt: int, ready_at_s: float, feedback) -> ActivityResult:
        """Execute ``node``'s activity, whatever its kind."""

    def move_to_component(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)

    def position_for_picking_up(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)

    def pick_up(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)

    def transport(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)

    def position_for_installing(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)

    def install(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self._run(node, attempt, ready_at_s, feedback)


FEATURES = tuple(kind.value for kind in ActivityKind)
