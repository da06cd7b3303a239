"""The robots' work in a simulated build: drive, carry, position, assemble, finish, break down, abort.

:class:`RobotWork` is a part of :class:`~bimrobot.coordination.simulation.ConstructionSimulation` (it reads
the simulation's ``smart`` model, ``site`` and ``build`` state): SimPy processes that move a robot in
straight lines at its speed (site frame x, y, metres), spend the fleet's handling times (seconds), then
update the smart components and record the schedule rows.
"""

from __future__ import annotations

import heapq

import numpy as np
import simpy

from bimrobot.coordination.run_state import SiteRobot
from bimrobot.coordination.market import TaskRequest
from bimrobot.core.tasks import Activity, Task
from bimrobot.sco import timing
from bimrobot.sco.component import Component
from bimrobot.sco.states import Event, State
from bimrobot.site.fleet import ACTIVITIES


class RobotWork:
    """The robots' SimPy processes of :class:`~bimrobot.coordination.simulation.ConstructionSimulation`."""

    def _send_idle_robots_to_yard(self) -> None:
        """Robots left without a task after working drive to the nearest yard position (thesis 4.5.3)."""
        yard = np.array(self.site.yard, dtype=float)
        for robot in self.build.robots.values():
            if robot.task is not None or robot.broken or robot.returning is not None or robot.stats.steps == 0:
                continue
            target = yard[int(np.argmin(np.hypot(*(yard - robot.position).T)))]
            if np.hypot(*(target - robot.position)) > 1e-6:
                robot.returning = self.build.env.process(self._return_to_yard(robot, target))

    def _return_to_yard(self, robot: SiteRobot, target: np.ndarray):
        self._say(f"{robot.spec.name} has no task and returns to the yard at ({target[0]:.2f}, {target[1]:.2f})")
        try:
            yield from self._drive(robot, target)
        except simpy.Interrupt:
            return  # called away: _stop_return already took the position where it was
        robot.returning = None

    def _stop_return(self, robot: SiteRobot) -> None:
        """Stop a robot on its way back to the yard, where it is now (travel so far counted)."""
        if robot.returning is None:
            return
        if robot.returning.is_alive:
            t0 = robot.leg[0] if robot.leg else self.build.env.now
            robot.position = self._position_now(robot)
            robot.stats.travel_time += self.build.env.now - t0
            robot.leg = None
            robot.returning.interrupt("new task")
            self._event("return_stopped", robot=robot.spec.name, x=round(float(robot.position[0]), 3), y=round(float(robot.position[1]), 3))
        robot.returning = None

    def _drive(self, robot: SiteRobot, target: np.ndarray):
        distance = float(np.hypot(*(target - robot.position)))
        duration = timing.travel_s(robot.times, distance)
        robot.leg = (self.build.env.now, robot.position.copy(), self.build.env.now + duration, np.array(target, dtype=float))
        yield self.build.env.timeout(duration)
        robot.position = np.array(target, dtype=float)
        robot.leg = None
        robot.stats.travel_time += duration

    def _position_now(self, robot: SiteRobot) -> np.ndarray:
        if robot.leg is None:
            return robot.position.copy()
        t0, p0, t1, p1 = robot.leg
        fraction = 1.0 if t1 <= t0 else min(1.0, max(0.0, (self.build.env.now - t0) / (t1 - t0)))
        return p0 + fraction * (p1 - p0)

    def _execute(self, robot: SiteRobot, request: TaskRequest):
        started = self.build.env.now
        component = self.smart.components[request.component_id]
        spec = robot.spec
        node_windows = None
        try:
            yield from self._drive(robot, request.start)
            if request.activity == Task.TRANSPORT:
                component.update_state(Event.START_TRANSPORT)
                self._note_state(component)
                self.build.lines.append(f"[{self.build.env.now:9.2f} s] Current progress: {spec.name} is loading {component.id}")
                yield self.build.env.timeout(spec.load_s)
                yield from self._drive(robot, request.end)
                yield self.build.env.timeout(spec.unload_s)
                component.position = np.array([*request.end, component.target_position[2]])
                robot.stats.handling_time += spec.load_s + spec.unload_s
            elif request.activity == Task.POSITION:
                if request.node_ids:  # per node
                    self._node_step(self.smart.nodes[request.node_ids[0]], Event.START_POSITIONING)
                else:
                    component.start_positioning()
                self._note_state(component)
                duration = timing.position_s(robot.times, request.nodes)
                yield self.build.env.timeout(duration)
                robot.stats.handling_time += duration
            else:
                nodes = [self.smart.nodes[n] for n in request.node_ids]
                for node in nodes:
                    self._node_step(node, Event.START_ASSEMBLY)
                node_windows = []
                for node in nodes:
                    begin = self.build.env.now
                    duration = timing.assemble_s(robot.times, node.assembly_point_number)
                    yield self.build.env.timeout(duration)
                    robot.stats.handling_time += duration
                    node_windows.append((node, begin, self.build.env.now))
        except simpy.Interrupt:
            self._abort(robot, request, started)
            return
        robot.stats.steps += 1
        robot.stats.busy_time += self.build.env.now - started
        self._finish(robot, request, started, node_windows)

    def _finish(self, robot: SiteRobot, request: TaskRequest, started: float, node_windows) -> None:
        """The task is done: update the smart objects, record the activity, free the robot."""
        if request.activity == Task.TRANSPORT:
            self._finish_transport(robot, request, started)
        elif request.activity == Task.POSITION:
            self._finish_positioning(robot, request, started)
        else:
            self._finish_assembly(robot, request, started, node_windows)
        name = robot.spec.name
        robot.task = None
        for activity_name in robot.spec.activities:
            self.build.idle[activity_name].add(name)
        self._event("finish", request=request.id, activity=request.activity, component=request.component_id, robot=name)
        self._maybe_close_floor()
        self._request_dispatch()

    def _finish_transport(self, robot: SiteRobot, request: TaskRequest, started: float) -> None:
        component, name = self.smart.components[request.component_id], robot.spec.name
        component.update_state(Event.FINISH_TRANSPORT)
        self._note_state(component)
        self._say(f"Component: {component.id} is arrived, {name} is free for next work")
        activity = self._record(Task.TRANSPORT, component, f"{Task.TRANSPORT.title} {component.id}", name, started,
                                request.predecessors, work=self._work(request, 0.0, end_z=component.target_position[2]))
        component.publish_positioning()
        self._note_state(component)
        if self.per_node and component.connection_nodes:
            self.build.transport_activity[component.id] = activity.id
            for joint in self.smart.joints_of(component.id):
                for node_id in joint.node_ids:
                    self._maybe_publish_node_positioning(self.smart.nodes[node_id])
            return
        self._publish(Task.POSITION, component, predecessors=[activity.id])

    def _finish_positioning(self, robot: SiteRobot, request: TaskRequest, started: float) -> None:
        component, name = self.smart.components[request.component_id], robot.spec.name
        if request.node_ids:
            self._finish_node_positioning(robot, request, started)
            return
        component.finish_positioning()
        self._note_state(component)
        self._say(f"Component: {component.id} position is fixed, {name} is free for next work")
        activity = self._record(Task.POSITION, component, f"{Task.POSITION.title} {component.id}", name, started,
                                request.predecessors, work=self._work(request, component.target_position[2], nodes=request.nodes))
        self.build.position_activity[component.id] = (activity.id,)
        if component.state == State.ASSEMBLED:  # no nodes to fasten
            self.build.open_on_floor[component.floor] -= 1
        self._position_fixed(component)

    def _position_fixed(self, component: Component, joints: bool = True) -> None:
        """``component`` stands in place: release what it carries and (``joints``) the joints it completes."""
        for dependant in self.build.dependants.get(component.id, []):  # components it carries
            if dependant not in self.build.missing_supporters:
                continue  # prebuilt and on site from the start
            self.build.missing_supporters[dependant] -= 1
            if self.build.missing_supporters[dependant] == 0:
                carried = self.smart.components[dependant]
                if carried.prebuilt:
                    self._prebuilt_in_place(carried)
                    continue
                if carried.floor <= self.build.current_floor:
                    self._publish_transport(dependant)
                else:
                    self.build.ready_by_floor.setdefault(carried.floor, []).append(dependant)
        for node in component.connection_nodes if joints and not self.per_node else ():
            self._maybe_publish_assembly(self.smart.joints[node.joint_id])

    def _prebuilt_in_place(self, component: Component) -> None:
        """A prebuilt component resting on robot-built ones is made by others now, in no robot time."""
        component.state = State.POSITION_FIXED
        for node in component.connection_nodes:
            if node.state != State.ASSEMBLED:
                done = self.per_node and node.id not in self.build.attached_to  # per node: no robot node assembles it
                node.state = State.ASSEMBLED if done else State.POSITION_FIXED
        if all(node.state == State.ASSEMBLED for node in component.connection_nodes):
            component.state = State.ASSEMBLED
        self._note_state(component)
        supporters = self.smart.supporters[component.id]
        # what put it in place, known before the work that waited for it is published (its predecessors)
        self.build.position_activity[component.id] = tuple(
            dict.fromkeys(a for s in supporters for a in self.build.position_activity.get(s, ()))
        )
        for node in component.connection_nodes:  # per node: the robot-built node it waited for
            if node.id in self.build.attached_to:
                self._maybe_publish_node_assembly(self.smart.nodes[self.build.attached_to[node.id]])
        self._say(
            f"Component: {component.id} (prebuilt, work of others) is in place: what it rests on "
            f"({', '.join(supporters)}) has its position fixed"
        )
        self._event("prebuilt_in_place", component=component.id, supporters=list(supporters))
        self._position_fixed(component)

    def _finish_assembly(self, robot: SiteRobot, request: TaskRequest, started: float, node_windows) -> None:
        """One schedule row per node: the first includes the drive to the joint."""
        joint, name = self.smart.joints[request.joint_id], robot.spec.name
        previous = None
        for node, begin, end in node_windows:
            owner = self.smart.components[node.component_id]
            self._node_step(node, Event.FINISH_ASSEMBLY)
            if self.per_node:
                self.build.open_on_floor[node.level] -= 1
            row_start = started if previous is None else begin
            predecessors = tuple(request.predecessors) + ((previous,) if previous else ())
            work = self._work(request, node.position[2], points=node.assembly_point_number)
            activity = self._record(Task.ASSEMBLE, owner, f"{Task.ASSEMBLE.title} {node.id}", name, row_start, predecessors,
                                    finish=end, work=work)
            previous = activity.id
        self._say(f"Nodes: {' and '.join(request.node_ids)} are assembled, {name} is free for next work")
        if not self.per_node:
            self.build.open_on_floor[joint.floor] -= 1

    def _work(self, request: TaskRequest, z: float, nodes: int | None = None, points: int | None = None,
              end_z: float | None = None) -> dict:
        """The work columns of a schedule row: where the robot began and ended (``request.start`` and
        ``request.end`` taken back into the model frame, at heights ``z`` and ``end_z`` m) and the nodes or
        points it did (:mod:`bimrobot.sco.timing`)."""
        def model_point(site_xy, height):
            x, y = self.site.to_model(site_xy, self.offset)
            return (round(float(x), 4), round(float(y), 4), round(float(height), 4))

        return {"work_from": model_point(request.start, z), "work_to": model_point(request.end, z if end_z is None else end_z),
                "nodes": nodes, "points": points}

    def _record(self, activity, component, name, robot, start, predecessors, finish=None, aborted=False,
                work: dict | None = None) -> Activity:
        self.build.activity_counter += 1
        origin = self.smart_origin(component)
        row = Activity(
            id=f"A{self.build.activity_counter:04d}",
            activity=activity,
            global_id=component.id,
            name=name,
            robot=robot,
            start=start,
            finish=self.build.env.now if finish is None else finish,
            target=origin,
            storey=component.storey_id or "",
            predecessors=tuple(p for p in predecessors if p),
            aborted=aborted,
            **(work or {}),
        )
        self.build.activities.append(row)
        return row

    @staticmethod
    def smart_origin(component: Component) -> tuple[float, float, float]:
        """Installed position of the component's origin (placement), model frame, metres."""
        point = component.target_position if component.origin is None else component.origin
        return (float(point[0]), float(point[1]), float(point[2]))

    def _breakdown(self, name: str, when: float, repair: float | None):
        yield self.build.env.timeout(when)
        robot = self.build.robots[name]
        self._stop_return(robot)
        robot.broken = True
        robot.stats.broken_at = self.build.env.now
        for activity in ACTIVITIES:
            self.build.idle[activity].discard(name)
        self._say(f"{name} broke down")
        self._event("breakdown", robot=name, request=robot.task.id if robot.task else None)
        if robot.task is not None and robot.process is not None and robot.process.is_alive:
            robot.process.interrupt("breakdown")
        if repair is None:
            return
        yield self.build.env.timeout(repair)
        robot.broken = False
        for activity in robot.spec.activities:
            self.build.idle[activity].add(name)
        self._say(f"{name} is repaired after {repair:g} s and back in the market")
        self._event("repaired", robot=name)
        self._request_dispatch()

    def _abort(self, robot: SiteRobot, request: TaskRequest, started: float) -> None:
        """Roll the interrupted task back and auction it again; nothing is lost."""
        component = self.smart.components[request.component_id]
        if robot.leg is not None:  # stopped while driving: count the part of the drive it made
            robot.stats.travel_time += self.build.env.now - robot.leg[0]
        robot.position = self._position_now(robot)
        robot.leg = None
        robot.stats.busy_time += self.build.env.now - started
        robot.task = None
        if request.activity == Task.TRANSPORT and component.state == State.IN_TRANSIT:
            component.update_state(Event.ABORT)
            component.position = np.array([robot.position[0], robot.position[1], 0.0])
            self.yard_of[component.id] = robot.position.copy()  # picked up again where it was dropped
        elif request.activity == Task.POSITION and request.node_ids:
            node = self.smart.nodes[request.node_ids[0]]
            if node.state == State.WORKING_IN_POSITIONING:
                self._node_step(node, Event.ABORT)
        elif request.activity == Task.POSITION and component.state == State.WORKING_IN_POSITIONING:
            component.abort_positioning()
        elif request.activity == Task.ASSEMBLE:
            for node_id in request.node_ids:
                node = self.smart.nodes[node_id]
                if node.state == State.WORKING_IN_ASSEMBLY:
                    self._node_step(node, Event.ABORT)
                elif node.state == State.ASSEMBLED:
                    continue
        self._note_state(component)
        self._record(request.activity, component, f"{request.activity.capitalize()} {component.id} (aborted)", robot.spec.name, started, (), aborted=True)
        # Only the nodes not yet assembled remain to be done.
        if request.activity == Task.ASSEMBLE:
            remaining = tuple(n for n in request.node_ids if self.smart.nodes[n].state != State.ASSEMBLED)
            request.node_ids = remaining
            request.points = sum(self.smart.nodes[n].assembly_point_number for n in remaining)
        else:
            request.start = self.yard_of[component.id] if request.activity == Task.TRANSPORT else request.start
        request.attempts += 1
        heapq.heappush(self.build.pending[request.activity], request)
        where = f"({robot.position[0]:.2f}, {robot.position[1]:.2f})"
        if request.activity == Task.ASSEMBLE:
            what = f"assembly of nodes {' and '.join(request.node_ids)}: nodes are {State.WAIT_FOR_ASSEMBLY}"
        else:
            what = f"{request.activity} of {component.id}: {component.id} is {component.state}"
            if request.activity == Task.TRANSPORT:
                what += f" at {where}"
        self._say(f"{robot.spec.name} broke down at {where} during {what}; task {request.id} auctioned again")
        self._event("reauction", request=request.id, activity=request.activity, component=component.id, robot=robot.spec.name, state=str(component.state))
        self._request_dispatch()
