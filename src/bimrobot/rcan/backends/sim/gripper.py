"""The ``sim`` backend's gripper features, *pick up* and *install*: the gripper must be at the activity's
pose (within :data:`GRASP_TOLERANCE_M`); a pick-up refuses a component another robot holds, one whose
section does not fit the gripper and one over the payload, and takes the load time from the yard; an
install places the held component (or fixes one already in place) and takes the assembly time."""

from __future__ import annotations

from bimrobot.rcan.backends import features
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.sco import timing
from bimrobot.core.tasks import Task

#: how far the gripper may be from the activity's pose, m
GRASP_TOLERANCE_M = 0.05


def _not_at_pose(spec, state: dict, node) -> str | None:
    arm = state["arm"]
    if arm is None or arm.distance(node.target) > GRASP_TOLERANCE_M:
        return f"gripper of {spec.name} is not at the {node.kind.label.lower()} pose of {node.component_id}"
    return None


def grip(site, spec, state: dict, node) -> tuple[float, str | None, dict]:
    """Close the gripper on the component: load time (s; none for a re-grip at the drop-off point, which
    the positioning includes), or why the robot refuses."""
    activity, gid = node.activity, node.component_id
    error = _not_at_pose(spec, state, node)
    if error is None and state["holding"]:
        error = f"robot {spec.name} already holds {state['holding']}"
    if error is None and site.held_by_other(gid, spec.name):
        error = f"{gid} is held by another robot"
    if error is None and not spec.can_grip(activity.section_m):
        w, d = activity.section_m
        error = f"the {w:.3f} x {d:.3f} m section of {gid} does not fit the gripper of {spec.name}"
    if error is None and activity.weight_kg is not None and activity.weight_kg > spec.payload_kg:
        error = f"{gid} weighs {activity.weight_kg:.1f} kg, over the {spec.payload_kg:.1f} kg payload of {spec.name}"
    if error is not None:
        return 0.0, error, {}
    handling = spec.times.load_s if activity.loads else 0.0
    return handling, None, {"holding": gid, "component": (node.target, spec.name)}


def fix(site, spec, state: dict, node) -> tuple[float, str | None, dict]:
    """Place the held component, or fix one already in place (a further connection), and stow the arm:
    the assembly time (s; none for the install of a positioning row, whose positioning took it)."""
    error = _not_at_pose(spec, state, node)
    if error is None and state["holding"] != node.component_id and site.held_by_other(node.component_id, spec.name):
        error = f"{node.component_id} is held by another robot"
    if error is not None:
        return 0.0, error, {}
    effect = {"arm": None, "component": (node.target, None)}
    if state["holding"] == node.component_id:
        effect["holding"] = None
    activity = node.activity
    return 0.0 if activity.task is Task.POSITION else timing.assemble_s(spec.times, activity.points), None, effect


class PickUp(features.PickUp):
    """*Pick up*: :func:`grip`."""

    def pick_up(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self.site.execute(node, attempt, ready_at_s, feedback, grip)


class Install(features.Install):
    """*Install*: :func:`fix`."""

    def install(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self.site.execute(node, attempt, ready_at_s, feedback, fix)
