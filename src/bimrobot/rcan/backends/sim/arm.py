"""The ``sim`` backend's arm features, *position for picking up* and *position for installing*: the
gripper moves in a straight line from its last pose (or its stowed pose :data:`ARM_STOW_HEIGHT_M` above
the base) to the target at the arm's speed; a target beyond the arm's reach from the base is refused."""

from __future__ import annotations

from bimrobot.rcan.activities import Pose
from bimrobot.rcan.backends import features
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.sco import timing
from bimrobot.core.tasks import Task

#: height of the stowed gripper above the base, m
ARM_STOW_HEIGHT_M = 0.5


def reach(site, spec, state: dict, node) -> tuple[float, str | None, dict]:
    """The gripper to ``node``'s target: arm time (s), or the error of a target out of reach; a held
    component comes along."""
    target, base = node.target, state["base"]
    distance = base.distance_xy(target)
    if distance > spec.reach_m + 1e-9:
        return 0.0, (
            f"target ({target.x:.2f}, {target.y:.2f}, {target.z:.2f}) is {distance:.2f} m from the base of "
            f"{spec.name}, beyond its {spec.reach_m:.2f} m reach: transport the component first"
        ), {}
    arm_from = state["arm"] or Pose(base.x, base.y, base.z + ARM_STOW_HEIGHT_M)
    effect = {"arm": target}
    if state["holding"] == node.component_id:
        effect["component"] = (target, spec.name)
    return timing.arm_s(spec.times, arm_from.distance(target)), None, effect


def place(site, spec, state: dict, node) -> tuple[float, str | None, dict]:
    """:func:`reach` with the component to its installed pose, unless another robot holds it; a
    positioning that frees the robot leaves it fixed there, and a positioning row adds the time per
    connection node (s)."""
    duration, error, effect = reach(site, spec, state, node)
    if error is not None:
        return duration, error, effect
    if site.held_by_other(node.component_id, spec.name):
        return 0.0, f"{node.component_id} is held by another robot", {}
    if state["holding"] == node.component_id and node.activity.releases_robot:
        effect.update(component=(node.target, None), holding=None)
    if node.activity.task is Task.POSITION:
        duration += timing.position_s(spec.times, node.activity.nodes or 1)
    return duration, None, effect


class PositionForPickingUp(features.PositionForPickingUp):
    """*Position for picking up*: :func:`reach`."""

    def position_for_picking_up(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self.site.execute(node, attempt, ready_at_s, feedback, reach)


class PositionForInstalling(features.PositionForInstalling):
    """*Position for installing*: :func:`place`."""

    def position_for_installing(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self.site.execute(node, attempt, ready_at_s, feedback, place)
