"""The ``sim`` backend's drive features, *move to component* and *transport*: the base drives in a straight
line to the target (the stand pose), taking the one time model's travel time between the points the
robot works at (:func:`bimrobot.sco.timing.travel_s`); the arm is stowed on the way."""

from __future__ import annotations

from bimrobot.rcan.activities import Pose
from bimrobot.rcan.backends import features
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.sco import timing
from bimrobot.core.tasks import Task


def drive(site, spec, state: dict, node) -> tuple[float, str | None, dict]:
    """The base to ``node``'s target: travel time (s) from the robot's last work point to the
    activity's, no error, the new base pose, stowed arm and work point."""
    target, activity = node.target, node.activity
    work_point = activity.work_point or target
    effect = {"base": Pose(target.x, target.y, state["base"].z), "arm": None, "work_point": work_point}
    return timing.travel_s(spec.times, state["work_point"].distance_xy(work_point)), None, effect


def carry(site, spec, state: dict, node) -> tuple[float, str | None, dict]:
    """A drive with the component held; a transport that frees the robot sets the component down at the
    drop-off point (its target) and lets go (a transport row adds the unload time, s)."""
    if state["holding"] != node.component_id:
        return 0.0, f"robot {spec.name} does not hold {node.component_id} to transport it", {}
    duration, error, effect = drive(site, spec, state, node)
    if node.activity.releases_robot:
        effect.update(holding=None, component=(node.target, None))
        if node.activity.task is Task.TRANSPORT:
            duration += spec.times.unload_s
    return duration, error, effect


class MoveToComponent(features.MoveToComponent):
    """*Move to component*: :func:`drive`."""

    def move_to_component(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self.site.execute(node, attempt, ready_at_s, feedback, drive)


class Transport(features.Transport):
    """*Transport*: :func:`carry`."""

    def transport(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self.site.execute(node, attempt, ready_at_s, feedback, carry)
