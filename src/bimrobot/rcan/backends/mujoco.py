"""The ``mujoco`` backend: the six activities executed physically in MuJoCo (bimrobot.physics).

Each robot of the capability table becomes a mobile manipulator of the family of
:mod:`bimrobot.physics.robot` (``ur5`` for payload <= 5 kg and reach <= 0.85 m, else ``heavy``) at its
home. A component enters the scene when an activity first names it: a box of its size (``shapes`` or
:func:`experiment_shapes` when they name it, else the RCAN node's planned ``size_m``: section, length),
centred on the activity's target (the gripper's goal: the component's centre), upright. Under a
target above the ground stands a support (a pedestal: the pick-up stand on the yard, the structure it
is installed on); a target whose bottom is below the ground gets a pit with a support at its floor,
so that a component released at its pose rests there. When the base stands where such a support
would go, or too close to reach, it first drives to the nearest free stand pose around the target.

- *move to component*, *transport*: the base drives along a collision-free path on an occupancy grid
  of the scene (supports and components on the ground, grown by half the base width and a clearance;
  pyastar2d's A*), turning and driving straight per leg; with a component held, in the carry posture.
- *position for picking up*: the base turns to face the component (backing away first when its
  corners would sweep into something), the arm moves through a pre-grasp 0.10 m above to the grasp
  pose (mink inverse kinematics, quintic joint-space interpolation, torque-limited servos).
- *pick up*: the gripper closes and a weld holds the component when the tool centre point is within
  5 mm and 2 degrees of the grasp pose; then it lifts 0.10 m. A component heavier than the arm's
  torque limits allow makes the lift fail (the arm sags): the activity fails naming its weight and
  the robot's rated payload, and the gripper lets go.
- *position for installing*: the held component goes through a point 0.10 m above its target to the
  target itself (its pose in the gripper, as gripped, taken into account).
- *install*: the gripper opens, the arm retracts; after 2 s the component's position error (mm) and
  angle error (degrees) to its target are measured, and it must not move more than 1 mm in 2 s more.
  Over :data:`POSITION_TOLERANCE_M` / :data:`ANGLE_TOLERANCE_DEG` the activity fails.

Times in results are simulated seconds. Every body's pose is recorded at 20 Hz (simulated time) and
written on close to ``<state db>.trajectory.csv`` beside the run's state database (or
``trajectory_path``): ``time_s, body, x, y, z, qw, qx, qy, qz``. The physical world is not persisted:
a resumed run starts the scene anew (completed goals are still answered from memory within a run).
"""

from __future__ import annotations

import csv
import math
import threading
from pathlib import Path

import numpy as np

from bimrobot.rcan.activities import ActivityKind
from bimrobot.rcan.backends.interfaces import ActivityResult, DispatchingBackend
from bimrobot.rcan.generation import CapabilityTable
from bimrobot.rcan.node import RcanNode

POSITION_TOLERANCE_M = 0.010
ANGLE_TOLERANCE_DEG = 1.0
SETTLE_S = 2.0
LIFT_M = 0.10
SUPPORT_MIN_Z_M = 0.01

def experiment_shapes() -> dict[str, tuple[float, float, float]]:
    """Shapes of the components of the thesis' experiments (the RCAN plan gives weight and section
    only): GlobalId -> (width, depth, length) m, from their IFC models (bimrobot.bim.examples)."""
    from bimrobot.bim.examples import RCAN_EXPERIMENTS

    return {entry[1]: (entry[3][0], entry[3][1], entry[4]) for entry in RCAN_EXPERIMENTS.values()}


class MujocoBackend(DispatchingBackend):
    """Executor backend on a MuJoCo scene (see the module docstring)."""

    name = "mujoco"

    def __init__(self, capabilities: CapabilityTable, db_path: str | Path = ":memory:",
                 trajectory_path: str | Path | None = None, shapes: dict | None = None, **_options):
        from bimrobot.physics.robot import robot_model
        from bimrobot.physics.site import MujocoSite

        self.capabilities = capabilities
        self.shapes = {**experiment_shapes(), **(shapes or {})}
        robots = {}
        for spec in capabilities.robots.values():
            opening = spec.gripper_opening_m[1] if spec.gripper_opening_m else None
            model = robot_model(spec.name, spec.payload_kg, spec.reach_m, opening)
            robots[spec.name] = (model, spec.speed_m_s, spec.arm_speed_m_s, (spec.home.x, spec.home.y))
        self.site = MujocoSite(robots)
        self.families = {name: value[0] for name, value in robots.items()}
        if trajectory_path is None and str(db_path) != ":memory:":
            trajectory_path = Path(db_path).with_name(Path(db_path).name + ".trajectory.csv")
        self.trajectory_path = None if trajectory_path is None else Path(trajectory_path)
        self.placements: dict[str, tuple[float, float]] = {}  # GlobalId -> (position error m, angle error deg)
        self._results: dict[tuple[str, int], ActivityResult] = {}
        self._lock = threading.Lock()

    # --- the interface -----------------------------------------------------------------------------
    def execute(self, node: RcanNode, attempt: int = 1, ready_at_s: float = 0.0, feedback=None) -> ActivityResult:
        with self._lock:  # one physical world: robots act one after the other in simulated time
            done = self._results.get((node.activity_id, attempt)) or next(
                (r for (a, _), r in self._results.items() if a == node.activity_id and r.success), None)
            if done:
                return done
            from bimrobot.physics.site import MotionFailed

            if ready_at_s > self.site.time_s:
                self.site.step(ready_at_s - self.site.time_s)
            started = self.site.time_s
            if feedback:
                feedback(0.0, f"{node.kind.label}: started")
            try:
                message = getattr(self, "_" + node.kind.value)(node)
                success = True
            except MotionFailed as failure:
                message, success = str(failure), False
            if feedback:
                feedback(1.0, f"{node.kind.label}: finished")
            result = ActivityResult(node.activity_id, attempt, node.robot, success, message, started, self.site.time_s)
            self._results[(node.activity_id, attempt)] = result
            return result

    def _run(self, node, attempt, ready_at_s, feedback) -> ActivityResult:
        return self.execute(node, attempt, ready_at_s, feedback)


    def close(self) -> None:
        if self.trajectory_path is not None and self.site.frames:
            self.write_trajectory(self.trajectory_path)

    # --- activities --------------------------------------------------------------------------------
    def _move_to_component(self, node: RcanNode) -> str:
        distance = self.site.drive(node.robot, (node.target.x, node.target.y))
        return f"{node.kind.label} {node.component_id}: drove {distance:.2f} m"

    def _position_for_picking_up(self, node: RcanNode) -> str:
        from bimrobot.physics.motion import planar

        site = self.site
        gid = node.component_id
        if gid not in site.components:
            shape = self._shape(node)
            site.make_room(node.robot, (node.target.x, node.target.y), self._support_half(shape))
            self._spawn(node, self._placement(node, shape), "stand")
        placement = site.body_pose(gid)
        site.face(node.robot, placement[:2, 3])
        grasp = site.grasp_pose(gid)
        above = grasp.copy()
        above[2, 3] += LIFT_M
        site.move_arm(node.robot, site.solve(node.robot, above))
        site.move_arm(node.robot, site.solve(node.robot, grasp))
        return f"{node.kind.label} {gid}: gripper at the grasp pose"

    def _pick_up(self, node: RcanNode) -> str:
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if gid not in site.components:
            raise MotionFailed(f"{gid} is not in the scene: position for picking up comes first")
        site.close_gripper(robot, gid)
        above = site.tcp_pose(robot)
        above[2, 3] += LIFT_M
        try:
            site.move_arm(robot, site.solve(robot, above))
        except MotionFailed as failure:
            site.open_gripper(robot)
            site.step(1.0)
            mass = site.components[gid].mass
            payload = self.capabilities.robots[robot].payload_kg
            raise MotionFailed(f"{gid} weighs {mass:.1f} kg: the arm of {robot} (rated payload {payload:.1f} kg, "
                               f"{self.families[robot].family} model) cannot lift it: {failure}") from None
        return f"{node.kind.label} {gid}: held and lifted {LIFT_M:.2f} m"

    def _transport(self, node: RcanNode) -> str:
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if site.robots[robot].holding != gid:
            raise MotionFailed(f"robot {robot} does not hold {gid} to transport it")
        site.move_arm(robot, site._ready_posture_cached(robot))  # carry posture: over the base
        distance = site.drive(robot, (node.target.x, node.target.y))
        if node.activity.releases_robot:  # set it down in front of the base and let go
            self._set_down(robot, gid)
        return f"{node.kind.label} {gid}: carried {distance:.2f} m"

    def _set_down(self, robot: str, gid: str) -> None:
        site = self.site
        tcp = site.tcp_pose(robot)
        below = tcp.copy()
        grip = np.linalg.inv(tcp) @ site.body_pose(gid)
        below[2, 3] += site.ground_z + 0.002 - (tcp @ grip)[2, 3]
        site.move_arm(robot, site.solve(robot, below), check_contacts=False)
        site.open_gripper(robot)
        site.move_arm(robot, site._ready_posture_cached(robot))

    def _position_for_installing(self, node: RcanNode) -> str:
        from bimrobot.physics.motion import planar
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if gid not in site.components:
            raise MotionFailed(f"{gid} is not in the scene: it was never picked up")
        shape = site.components[gid].size
        target = self._placement(node, shape)
        site.make_room(robot, target[:2, 3], self._support_half(shape))
        if abs(target[2, 3] - site.ground_z) > SUPPORT_MIN_Z_M and not self._support_at(target):
            if target[2, 3] < site.ground_z:
                site.add_pit(target[:2, 3], self._support_half(shape))
            self._add_support(gid, target, "support")
        site.face(robot, target[:2, 3])
        holding = site.robots[robot].holding == gid
        if holding:  # the tcp goes where the component's origin lands on the target, as gripped
            grip = np.linalg.inv(site.tcp_pose(robot)) @ site.body_pose(gid)
            goal = target @ np.linalg.inv(grip)
            goal[2, 3] += 0.001  # released 1 mm above its seat
        else:  # work on a component in place (a further connection): reach its grasp pose
            goal = site.grasp_pose(gid)
        above = goal.copy()
        above[2, 3] += LIFT_M
        site.move_arm(robot, site.solve(robot, above))
        site.move_arm(robot, site.solve(robot, goal))
        if holding and node.activity.releases_robot:  # PositionFixed: let go, the assembly robots fix it
            self._release(robot)
        return f"{node.kind.label} {gid}: at its target"

    def _install(self, node: RcanNode) -> str:
        from bimrobot.physics.motion import angle_between, planar
        from bimrobot.physics.site import MotionFailed

        site, robot, gid = self.site, node.robot, node.component_id
        if gid not in site.components:
            raise MotionFailed(f"{gid} is not in the scene: it was never picked up")
        if site.robots[robot].holding == gid:
            self._release(robot)
        site.step(SETTLE_S)
        before = site.body_pose(gid)
        site.step(SETTLE_S)
        after = site.body_pose(gid)
        target = self._placement(node, site.components[gid].size)
        error_m = float(np.linalg.norm(after[:3, 3] - target[:3, 3]))
        error_deg = math.degrees(angle_between(after[:3, :3], target[:3, :3]))
        drift_m = float(np.linalg.norm(after[:3, 3] - before[:3, 3]))
        self.placements[gid] = (error_m, error_deg)
        measured = f"placement error {error_m * 1000:.1f} mm, {error_deg:.2f} degrees; moved {drift_m * 1000:.2f} mm in {SETTLE_S:g} s"
        if error_m > POSITION_TOLERANCE_M or error_deg > ANGLE_TOLERANCE_DEG or drift_m > 1e-3:
            raise MotionFailed(f"{gid} does not rest at its BIM pose: {measured} (tolerance "
                               f"{POSITION_TOLERANCE_M * 1000:.0f} mm, {ANGLE_TOLERANCE_DEG:g} degree, 1 mm)")
        return f"{node.kind.label} {gid}: {measured}"

    # --- helpers -----------------------------------------------------------------------------------
    def _release(self, robot: str) -> None:
        site = self.site
        site.open_gripper(robot)
        away = site.tcp_pose(robot)
        away[2, 3] += LIFT_M
        site.move_arm(robot, site.solve(robot, away), check_contacts=False)
        site.move_arm(robot, site._ready_posture_cached(robot))

    def _shape(self, node: RcanNode) -> tuple[float, float, float]:
        from bimrobot.physics.site import MotionFailed

        shape = self.shapes.get(node.component_id) or node.activity.size_m  # (w, d, length), as planned
        if shape is None:
            raise MotionFailed(f"the shape of {node.component_id} is unknown to the mujoco backend (it knows "
                               f"{', '.join(self.shapes)}): give it with shapes={{GlobalId: (w, d, h)}}")
        return shape

    def _placement(self, node: RcanNode, shape) -> np.ndarray:
        """The component's origin (bottom face centre) when its centre is at the node's target (4x4)."""
        from bimrobot.physics.motion import planar

        return planar(node.target.x, node.target.y, node.target.yaw, node.target.z - shape[2] / 2)

    @staticmethod
    def _support_half(shape) -> tuple[float, float]:
        return (max(shape[0], shape[1]) / 2 + 0.01,) * 2

    def _spawn(self, node: RcanNode, placement: np.ndarray, support: str) -> None:
        from bimrobot.physics.site import Component, MotionFailed

        if node.activity.weight_kg is None:
            raise MotionFailed(f"the weight of {node.component_id} is unknown: the scene cannot simulate it")
        shape = self._shape(node)
        if abs(placement[2, 3] - self.site.ground_z) > SUPPORT_MIN_Z_M:
            if placement[2, 3] < self.site.ground_z:
                self.site.add_pit(placement[:2, 3], self._support_half(shape))
            self._add_support(node.component_id, placement, support, shape)
        self.site.add_component(Component(node.component_id, shape, float(node.activity.weight_kg)), placement)

    def _add_support(self, gid: str, placement: np.ndarray, kind: str, shape=None) -> None:
        half = self._support_half(shape or self.site.components[gid].size)
        self.site.add_support(f"{kind}/{gid}/{len(self.site.supports)}", placement[:2, 3], placement[2, 3], half)

    def _support_at(self, placement: np.ndarray) -> bool:
        return any(np.all(np.abs(placement[:2, 3] - c[:2]) <= h[:2]) and abs(c[2] + h[2] - placement[2, 3]) < 1e-3
                   for c, h in self.site.supports)

    def write_trajectory(self, path: Path) -> Path:
        """Every recorded body pose as CSV (time_s, body, x, y, z, qw, qx, qy, qz), through bimrobot.io."""
        from bimrobot import io

        with io.atomic_output_file(path, option="trajectory") as tmp:
            with open(tmp, "w", newline="", encoding="utf-8") as handle:
                handle.write(f"# {io.signature('rcan mujoco trajectory')}\n")
                writer = csv.writer(handle)
                writer.writerow(["time_s", "body", "x", "y", "z", "qw", "qx", "qy", "qz"])
                for time_s, names, poses in self.site.frames:
                    for name, row in zip(names, poses):
                        writer.writerow([f"{time_s:.3f}", name, *(f"{v:.6f}" for v in row)])
        return path
