"""Control of the MuJoCo site: time advances with every robot's controllers running.

Each robot's arm is torque controlled by a joint-space PD law plus gravity compensation of its links
and of the component it holds (the robot knows the component's BIM weight, J^T m g), every torque
clipped to the joint's limit: an arm asked to lift more than its limits allow sags, and the motion
fails. The base follows its commanded velocity (world x, y in m/s, yaw rate in rad/s). Every body's
pose is recorded at :data:`RECORD_HZ` of simulated time.

Public: :meth:`~ControlSkill.step`, :meth:`~ControlSkill.saturated`.
"""

from __future__ import annotations

import numpy as np

from bimrobot.physics.robot import JOINT_NAMES
from bimrobot.physics.site.common import RECORD_HZ


class ControlSkill:
    """Simulated time with the robots' controllers running (see the module docstring)."""

    def step(self, seconds: float) -> None:
        """Advance ``seconds`` with every robot's controllers running."""
        for _ in range(max(1, int(round(seconds / self.model.opt.timestep)))):
            self._control()
            self.mj.mj_step(self.model, self.data)
            self.time_s += self.model.opt.timestep
            if self.time_s >= self._next_frame:
                self._record()

    def _control(self) -> None:
        """Each robot's arm torques (Nm: PD to ``q_ref`` + gravity and payload compensation, clipped at
        the joints' limits) and its base velocity command, for the next step."""
        data = self.data
        for name, robot in self.robots.items():
            idx = self.idx[name]
            kp, kd = robot.held_gains if robot.holding and robot.held_gains is not None else robot.gains
            q, v = data.qpos[idx["q"]], data.qvel[idx["v"]]
            torque = kp * (robot.q_ref - q) - kd * v + data.qfrc_bias[idx["v"]]
            if robot.holding:
                torque += self._payload_torque(name, robot.holding)
            data.ctrl[idx["arm_act"]] = np.clip(torque, -idx["limits"], idx["limits"])
            data.ctrl[idx["base_act"]] = robot.base_velocity  # world-frame x, y speeds and yaw rate

    def _payload_torque(self, robot: str, component: str) -> np.ndarray:
        """Joint torques that hold the held component's weight (J^T m g at its centre of mass)."""
        body = self.data.body(component)
        jacp = np.zeros((3, self.model.nv))
        self.mj.mj_jac(self.model, self.data, jacp, None, body.xipos, self.idx[robot]["gripper"])
        mass = self.components[component].mass
        return jacp[:, self.idx[robot]["v"]].T @ np.array([0.0, 0.0, mass * 9.81])

    def saturated(self, robot: str) -> list[str]:
        """Arm joints whose motor is at its torque limit now."""
        idx = self.idx[robot]
        at_limit = np.abs(self.data.ctrl[idx["arm_act"]]) >= idx["limits"] * 0.999
        return [j for j, hit in zip(JOINT_NAMES, at_limit) if hit]

    def _record(self) -> None:
        """Append a frame: (time s, body names, every body's position m and quaternion wxyz, world)."""
        self.frames.append((round(self.time_s, 6), self._names,
                            np.concatenate([self.data.xpos[1:], self.data.xquat[1:]], axis=1).copy()))
        self._next_frame += 1.0 / RECORD_HZ
