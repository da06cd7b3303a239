"""Contacts in the MuJoCo site: what a robot touches, would touch at other joints or another stand,
and what it has pushed.

Checks of positions run on a scratch copy of the state (:meth:`~WorldSkill.scratch_state`), never
on the simulation; the planners' thousands of checks run on a probe copy of the model in which only
the robot's geoms collide (:meth:`ContactSkill._probe_model`).

Public: :meth:`~ContactSkill.robot_contacts`, :meth:`~ContactSkill.arm_contacts_at`,
:meth:`~ContactSkill.seated`, :meth:`~ContactSkill.component_poses`, :meth:`~ContactSkill.shoved`,
:meth:`~ContactSkill.arm_within`, :meth:`~ContactSkill.robot_extent`.
"""

from __future__ import annotations

import numpy as np

from bimrobot.physics import motion
from bimrobot.physics.site.common import CLEARANCE_M, SHOVE_TOLERANCE_M


class ContactSkill:
    """What robots touch (see the module docstring)."""

    def robot_contacts(self, robot: str, data=None, besides=()) -> list[str]:
        """What the robot's arm, gripper or chassis touches other than the component it holds (in
        ``data``, default the simulation's), leaving out the contacts ``besides`` (those it had
        already: a robot may move away from what it touches)."""
        data = self.data if data is None else data
        m = self.model
        found = []
        for own, other, geom in self._contact_pairs(robot, data):
            # a static geom (body 0, "world") by its own name: a support, a stand, the ground slab
            other_name = (m.geom(geom).name or "the ground") if other == 0 else m.body(other).name
            found.append(f"{m.body(own).name} touches {other_name}")
        return sorted(set(found) - set(besides))

    def _contact_pairs(self, robot: str, data):
        """(own body, other body, other geom) of each contact of the robot in ``data`` with anything but
        itself and the component it holds."""
        m, idx = self.model, self.idx[robot]
        held = m.body(self.robots[robot].holding).id if self.robots[robot].holding else -1
        for contact in data.contact[: data.ncon]:
            bodies = (m.geom_bodyid[contact.geom1], m.geom_bodyid[contact.geom2])
            mine = [b in idx["robot_bodies"] for b in bodies]
            if mine[0] == mine[1]:
                continue
            other = bodies[1] if mine[0] else bodies[0]
            if other != held:
                yield (bodies[0] if mine[0] else bodies[1]), other, (contact.geom2 if mine[0] else contact.geom1)

    def arm_contacts_at(self, robot: str, q: np.ndarray, scratch=None, besides=(), stand=None) -> list[str]:
        """What the robot would touch with its arm at joints ``q``, everything else where it is now
        (a check of positions only, on a scratch copy of the state: :meth:`scratch_state`);
        ``stand``: (xy, yaw) of its base instead of where it stands (m, rad)."""
        scratch = self.scratch_state() if scratch is None else scratch
        if stand is None:
            return self._contacts_at(robot, scratch, self.idx[robot]["q"], q, besides)
        where = np.concatenate([self.idx[robot]["base_q"], self.idx[robot]["q"]])
        return self._contacts_at(robot, scratch, where, np.concatenate([stand[0][:2], [stand[1]], q]), besides)

    def _contacts_at(self, robot: str, scratch, addresses, values, besides=()) -> list[str]:
        """The robot's contacts in ``scratch`` with its coordinates ``addresses`` (qpos) set to ``values``."""
        scratch.qpos[addresses] = values
        self.mj.mj_fwdPosition(self.model, scratch)
        return self.robot_contacts(robot, scratch, besides)

    def seated(self, robot: str) -> bool:
        """Whether the component the robot holds rests on something: it touches a support or the
        ground (components do not collide with each other or, held, with robots)."""
        held = self.robots[robot].holding
        if held is None:
            return False
        box = self.model.geom(f"{held}/box").id
        m = self.model
        for contact in self.data.contact[: self.data.ncon]:
            if box in (contact.geom1, contact.geom2):
                other = contact.geom2 if contact.geom1 == box else contact.geom1
                if m.geom_bodyid[other] == 0:  # a static geom: a support, the ground slab
                    return True
        return False

    def component_poses(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """Body id -> (centre of mass, m, world; rotation matrix) of every component's body now."""
        ids = [self.model.body(gid).id for gid in self.components]
        return {b: (self.data.xipos[b].copy(), self.data.xmat[b].reshape(3, 3).copy()) for b in ids}

    def shoved(self, robot: str, before: dict) -> list[str]:
        """The components the robot touches now that have moved more than SHOVE_TOLERANCE_M since
        ``before`` (:meth:`component_poses`), with how far: their farthest corner's displacement
        bound, so that a tall column tilting about its foot counts by its top (the robot pushes what
        it touched already, which the contact check lets it move away from)."""
        out = []
        m = self.model
        for other in {other for _, other, _ in self._contact_pairs(robot, self.data)}:
            if other not in before:
                continue
            centre, rotation = before[other]
            turned = motion.angle_between(rotation, self.data.xmat[other].reshape(3, 3))
            reach = float(np.linalg.norm(self.components[m.body(other).name].size))  # > centre to corner
            moved = float(np.linalg.norm(self.data.xipos[other] - centre)) + turned * reach
            if moved > SHOVE_TOLERANCE_M:
                out.append(f"{m.body(other).name} by {moved * 1000:.0f} mm")
        return sorted(out)

    def _probe_model(self, robot: str, margin: float):
        """A copy of the model for checking the robot's poses quickly: only the robot's geoms collide
        (with what they would touch in the simulation, not other robots; what lies on the ground is
        not checked against the ground on every try), and they touch what comes within ``margin`` (m)."""
        import copy

        probe = copy.copy(self.model)
        mine = self.idx[robot]["geoms"]
        kind, affinity = probe.geom_contype, probe.geom_conaffinity
        solid = mine[(kind[mine] | affinity[mine]) != 0]
        # MuJoCo's rule: two geoms collide when either's type matches the other's affinity
        meets_robot = ((kind & np.bitwise_or.reduce(affinity[solid])) != 0) | \
                      ((affinity & np.bitwise_or.reduce(kind[solid])) != 0)
        meets_robot[mine] = False
        only = 1 << 30  # a bit nothing else uses
        kind[:], affinity[:] = 0, np.where(meets_robot, only, 0)
        kind[solid] = only
        probe.geom_margin[mine] = margin
        return probe

    def _contacts_within(self, robot: str, probe, scratch, addresses, values) -> dict[int, float]:
        """What the robot would touch or come within the probe model's margin of, in ``scratch``
        with its coordinates ``addresses`` (qpos) set to ``values`` (positions only): a body's id (or
        minus one minus a static geom's id; a planner asks thousands of times: no names) -> the
        least distance (m, negative: overlap)."""
        scratch.qpos[addresses] = values
        self.mj.mj_kinematics(probe, scratch)
        self.mj.mj_collision(probe, scratch)
        if not scratch.ncon:
            return {}
        contacts = scratch.contact
        geoms = contacts.geom[: scratch.ncon]
        own = np.isin(probe.geom_bodyid[geoms[:, 0]], self.idx[robot]["geom_bodies"])
        other = np.where(own, geoms[:, 1], geoms[:, 0])
        body = probe.geom_bodyid[other]
        found: dict[int, float] = {}
        for key, distance in zip(np.where(body == 0, -1 - other, body).tolist(), contacts.dist[: scratch.ncon].tolist()):
            found[key] = min(distance, found.get(key, distance))
        return found

    @staticmethod
    def _no_nearer(found: dict[int, float], already: dict[int, float]) -> bool:
        """Whether every contact of ``found`` is one of ``already`` and no nearer (1 mm) than there:
        a robot may move away from, or along, what it stood close to."""
        return all(key in already and distance >= already[key] - 0.001 for key, distance in found.items())

    def arm_within(self, robot: str, centre_xy, half_xy, top_z: float, clearance: float = CLEARANCE_M) -> bool:
        """Whether the robot's arm or gripper (the world box around each geom, the chassis and
        wheels left out) comes within ``clearance`` (m) of the box standing on the ground under
        ``top_z`` (m) around ``centre_xy`` (half size ``half_xy``): something put there would meet it."""
        m, data = self.model, self.data
        base = m.body(f"{robot}/base").id
        bodies = [b for b in self.idx[robot]["robot_bodies"] if b != base]
        for g in np.flatnonzero(np.isin(m.geom_bodyid, bodies)):
            rotation = data.geom_xmat[g].reshape(3, 3)
            centre = data.geom_xpos[g] + rotation @ m.geom_aabb[g, :3]
            half = np.abs(rotation) @ m.geom_aabb[g, 3:] + clearance
            if np.all(np.abs(centre[:2] - np.asarray(centre_xy, float)) < half[:2] + np.asarray(half_xy, float)) \
                    and centre[2] - half[2] < top_z:
                return True
        return False

    def robot_extent(self, robot: str) -> tuple[np.ndarray, np.ndarray]:
        """(centre xy, half size xy), m: the box around everything of the robot as it stands now
        (chassis, arm, gripper; each geom's bounding sphere)."""
        return self._box_around(np.isin(self.model.geom_bodyid, list(self.idx[robot]["robot_bodies"])))

    def _box_around(self, geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(centre xy, half size xy), m: the box around the geoms selected by the mask ``geoms`` as
        they are now (each geom's bounding sphere)."""
        xy, radius = self.data.geom_xpos[geoms, :2], self.model.geom_rbound[geoms][:, None]
        lower, upper = (xy - radius).min(axis=0), (xy + radius).max(axis=0)
        return (lower + upper) / 2, (upper - lower) / 2
