"""The RCAN system wired together: smart components publish activities, the generation system turns
each into an RCAN node, executors drive the robots, the state manager closes the loop (thesis fig. 5.6).

Every hop goes through the broker (in-process or Redis) and the :class:`~bimrobot.rcan.broker.Router`
hands each message to its part. :meth:`RcanSystem.run` executes a whole plan of
:class:`~bimrobot.rcan.activities.RcanActivity` in precedence order, one activity per robot at a time,
and resumes from the state database when a previous run of the same plan was interrupted.
"""

from __future__ import annotations

import hashlib
import json
import time
import uuid
from dataclasses import dataclass, field
from typing import Callable, Iterable

from bimrobot.errors import InputError
from bimrobot.rcan.activities import ActivityKind, RcanActivity
from bimrobot.rcan.backends.interfaces import ActivityResult
from bimrobot.rcan.broker import ACTIVITY_TOPIC, RESULT_TOPIC, STATE_TOPIC, Broker, Message, Router, robot_topic
from bimrobot.rcan.generation import CapabilityTable, NodeGenerator, TaskAllocator
from bimrobot.rcan.node import RcanNode
from bimrobot.rcan.state_manager import DONE, ESCALATED, STARTED, EscalationReport, StateManager


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


def plan_signature(activities: list[RcanActivity]) -> str:
    """A hash of the plan, so a state database is never resumed with a different plan."""
    text = json.dumps([(a.activity_id, a.component_id, a.kind.value, a.target.as_tuple(), a.predecessors)
                       for a in activities])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class RcanSystem:
    """Generation system + state manager + message routing, over one broker.

    ``log``: called with each line of the interaction log (component publishes, node instantiated,
    robot executes, result, new state).
    """

    def __init__(self, broker: Broker, capabilities: CapabilityTable, state_manager: StateManager,
                 backend_name: str = "sim", log: Callable[[str], None] | None = None):
        self.broker = broker
        self.capabilities = capabilities
        self.state = state_manager
        self.allocator = TaskAllocator(capabilities)
        self.generator = NodeGenerator(self.allocator, backend_name)
        self.log = log or (lambda line: None)
        self.router = Router()
        self.router.route(ACTIVITY_TOPIC, self._on_activity)
        self.router.route(RESULT_TOPIC, self._on_result)

    # --- smart component API -----------------------------------------------------------------------
    def publish(self, activity: RcanActivity, attempt: int = 1) -> None:
        """A smart component publishes its next construction activity to the generation system."""
        t = activity.target
        self.log(f"[component {activity.component_id}] publishes {activity.activity_id} '{activity.kind.label}' "
                 f"target ({t.x:.2f}, {t.y:.2f}, {t.z:.2f})" + (f" attempt {attempt}" if attempt > 1 else ""))
        self._unreceived += 1
        self.broker.send(ACTIVITY_TOPIC, {"activity_id": activity.activity_id, "attempt": attempt, "run": self._run_token})

    # --- message handlers --------------------------------------------------------------------------
    def _on_activity(self, message: Message) -> None:
        if message.payload.get("run") != self._run_token:  # left on a shared Redis by an earlier, killed run
            self.broker.ack(message)
            return
        self._unreceived -= 1
        self._waiting.append((message.payload["activity_id"], int(message.payload["attempt"])))
        self.broker.ack(message)

    def _dispatch_waiting(self) -> None:
        """Instantiate RCAN nodes for waiting activities whose robot is free, and send them."""
        still_waiting = []
        for activity_id, attempt in self._waiting:
            activity = self._plan[activity_id]
            robot = self._free_robot_for(activity)
            if robot is None:
                still_waiting.append((activity_id, attempt))
                continue
            node = self.generator.instantiate(activity, robot)
            self.log(f"[generation] RCAN node {node.node_id} instantiated: component {activity.component_id}, "
                     f"activity '{activity.kind.label}', robot {robot}, backend {node.backend}")
            before = self.state.store.component_state(activity.component_id)
            state = self.state.started(node, attempt)
            if state.value != before:
                self.log(f"[component {activity.component_id}] state: {state.value}")
            self._send(node, attempt)
        self._waiting = still_waiting

    def _free_robot_for(self, activity: RcanActivity) -> str | None:
        holder = self.allocator.holder(activity.component_id)
        if holder is not None:
            if holder in self._in_flight or not self.allocator.continues(activity):
                return None
            return holder
        busy = set(self._in_flight) | self.allocator.committed_robots()
        if len(busy) >= len(self.capabilities.robots):
            return None  # every robot works or holds a component: no need to ask the allocator
        return self.allocator.choose(activity, exclude=busy)

    def _send(self, node: RcanNode, attempt: int) -> None:
        ready_at = max((self._finished_s.get(p, 0.0) for p in node.activity.predecessors), default=0.0)
        self._in_flight[node.robot] = (node, attempt)
        self._sent_at[(node.activity_id, attempt)] = time.perf_counter()
        self.log(f"[{node.node_id}] robot {node.robot} executes '{node.kind.label}' of {node.component_id}"
                 + (f" (attempt {attempt})" if attempt > 1 else ""))
        self.broker.send(robot_topic(node.robot),
                         {"node": node.to_message(), "attempt": attempt, "ready_at_s": ready_at})

    def _on_result(self, message: Message) -> None:
        result = ActivityResult.from_message(message.payload["result"])
        flight = self._in_flight.get(result.robot)
        if flight is None or flight[0].activity_id != result.activity_id or flight[1] != result.attempt:
            self.broker.ack(message)  # a duplicate from before a restart: already handled
            return
        node = flight[0]
        del self._in_flight[result.robot]
        sent = self._sent_at.pop((result.activity_id, result.attempt), None)
        if sent is not None:
            self._latencies.append(time.perf_counter() - sent)
        verdict = "success" if result.success else "failure"
        self.log(f"[{node.node_id}] result: {verdict}: {result.message} (t {result.started_s:.1f}-{result.finished_s:.1f} s)")
        decision = self.state.result(node, result)
        if decision.verdict == DONE:
            self._done.add(node.activity_id)
            self._finished_s[node.activity_id] = result.finished_s
            if node.activity.releases_robot:  # the component is placed: its robot is free again
                self.allocator.release(node.component_id)
        elif decision.verdict == "retry":
            self.publish(node.activity, decision.next_attempt)
        elif decision.verdict == ESCALATED:
            self._escalations.append(decision.report)
            self.log(f"[state manager] {decision.report}")
        self.log(f"[component {node.component_id}] state: {decision.component_state}")
        self.broker.send(STATE_TOPIC, {"component_id": node.component_id, "state": decision.component_state,
                                       "activity_id": node.activity_id, "verdict": decision.verdict})
        self.broker.ack(message)

    # --- the run -----------------------------------------------------------------------------------
    def run(self, activities: Iterable[RcanActivity], timeout_s: float | None = None,
            retry_escalated: bool = False) -> RunReport:
        """Execute ``activities`` to the end (or until blocked), resuming a journaled earlier run.

        ``timeout_s``: give up (TimeoutError) after this many real seconds; None waits as long as it takes.
        ``retry_escalated``: activities an earlier run escalated get a fresh retry budget (the technician
        has dealt with the cause).
        """
        activities = list(activities)
        self._plan = {a.activity_id: a for a in activities}
        self._check_plan(activities)
        store = self.state.store
        signature = plan_signature(activities)
        if store.meta("plan") not in (None, signature):
            raise InputError(f"state database {store.path} belongs to a different plan; use a new --state-db")
        store.set_meta("plan", signature)
        store.register([(a.activity_id, a.component_id, a.kind.value) for a in activities],
                       dict.fromkeys(a.component_id for a in activities))
        if retry_escalated:
            for activity_id in store.reopen_escalated():
                self.log(f"[state manager] {activity_id} was escalated: retrying it")
        self._run_token = uuid.uuid4().hex
        self._waiting, self._in_flight, self._sent_at, self._latencies = [], {}, {}, []
        self._done, self._escalations, self._finished_s, self._unreceived = set(), [], {}, 0
        resumed = self._restore(activities)
        published = set(self._done) | {a for a, _ in self._waiting} | {n.activity_id for n, _ in self._in_flight.values()}
        published |= {r.activity_id for r in self._escalations}
        # Which activities wait for which (done activities count as met), to publish in plan order,
        # without rescanning the whole plan on every turn of the loop.
        order = {a.activity_id: n for n, a in enumerate(activities)}
        unmet = {a.activity_id: len({p for p in a.predecessors if p not in self._done}) for a in activities}
        successors: dict[str, list[str]] = {}
        for a in activities:
            for p in set(a.predecessors):
                successors.setdefault(p, []).append(a.activity_id)
        ready = {i for i, n in unmet.items() if n == 0 and i not in published}
        counted = set(self._done)
        started = time.perf_counter()
        while True:
            for activity_id in sorted(ready, key=order.__getitem__):  # components publish what became ready
                published.add(activity_id)
                self.publish(self._plan[activity_id])
            ready.clear()
            waiting_messages = self._unreceived or self._in_flight
            for message in self.broker.receive(self.router.topics, timeout_s=0.05 if waiting_messages else 0.0):
                self.router.dispatch(message)
            for finished in self._done - counted:
                counted.add(finished)
                for successor in successors.get(finished, ()):
                    unmet[successor] -= 1
                    if unmet[successor] == 0 and successor not in published:
                        ready.add(successor)
            self._dispatch_waiting()
            if not self._unreceived and not self._in_flight and not ready:
                break  # finished, or blocked: waiting activities that no free robot will ever take
            if timeout_s is not None and time.perf_counter() - started > timeout_s:
                raise TimeoutError(f"RCAN run did not finish within {timeout_s:.0f} s; in flight: {sorted(self._in_flight)}")
        return self._report(activities, started, resumed)

    def _check_plan(self, activities: list[RcanActivity]) -> None:
        ids = set(self._plan)
        if len(ids) != len(activities):
            raise InputError("the RCAN plan has duplicate activity ids")
        refused: list[tuple[RcanActivity, InputError]] = []
        for a in activities:
            missing = [p for p in a.predecessors if p not in ids]
            if missing:
                raise InputError(f"activity {a.activity_id} names unknown predecessor {missing[0]}")
            try:
                self.allocator.capable(a)
            except InputError as exc:  # gathered: one message for every component no robot can take
                refused.append((a, exc))
        if refused:
            components = list(dict.fromkeys(a.component_id for a, _ in refused))
            message = str(refused[0][1])
            if len(components) > 1:
                weights = [a.weight_kg for a, _ in refused if a.weight_kg is not None]
                heaviest = f"; the heaviest weighs {max(weights):,.0f} kg" if weights else ""
                message += f"; {len(components) - 1} more component(s) cannot be taken either{heaviest}"
            raise InputError(message)
        if not self.state.installs:
            for a in activities:
                if a.kind is ActivityKind.INSTALL:
                    self.state.installs.setdefault(a.component_id, set()).add(a.activity_id)

    def _restore(self, activities: list[RcanActivity]) -> int:
        """Rebuild in-memory state from the journal; re-send started activities. Returns how many."""
        rows = self.state.store.activity_rows()
        resent = 0
        for activity in activities:
            row = rows[activity.activity_id]
            if row["robot"] and row["status"] in (DONE, STARTED) or (row["status"] == ESCALATED and row["robot"]):
                self.allocator.commit(activity.component_id, row["robot"], activity.activity_id)
            if row["status"] == DONE:
                self._done.add(activity.activity_id)
                self._finished_s[activity.activity_id] = row["finished_s"] or 0.0
                if activity.releases_robot:
                    self.allocator.release(activity.component_id)
            elif row["status"] == STARTED:
                node = RcanNode(f"rcan/{activity.activity_id}", activity, row["robot"], self.generator.backend)  # as journaled
                self.log(f"[state manager] resuming {node.node_id}: re-sending attempt {row['attempts']} to {row['robot']}")
                self._send(node, row["attempts"])
                resent += 1
            elif row["status"] == ESCALATED:
                self._escalations.append(EscalationReport(activity.component_id, activity.activity_id,
                                                          activity.kind.label, row["robot"] or "?",
                                                          row["attempts"], row["message"] or ""))
            elif row["attempts"]:  # failed, retry not yet sent
                self._waiting.append((activity.activity_id, row["attempts"] + 1))
        return resent

    def _report(self, activities, started: float, resumed: int) -> RunReport:
        escalated = {r.activity_id for r in self._escalations}
        blocked = [a.activity_id for a in activities if a.activity_id not in self._done and a.activity_id not in escalated]
        status = "completed" if not blocked and not escalated else ("escalated" if escalated else "blocked")
        return RunReport(
            status=status,
            done=[a.activity_id for a in activities if a.activity_id in self._done],
            escalations=list(self._escalations),
            component_states=self.state.store.component_states(),
            makespan_s=max(self._finished_s.values(), default=0.0),
            wall_s=time.perf_counter() - started,
            latencies_s=list(self._latencies),
            resumed=resumed,
            blocked=blocked,
        )


def run_plan(
    activities: Iterable[RcanActivity],
    capabilities: CapabilityTable,
    backend: str = "sim",
    state_db: str = ":memory:",
    redis_url: str | None = None,
    spawn_executors: bool = True,
    max_attempts: int = 3,
    observers: Iterable = (),
    log: Callable[[str], None] | None = None,
    backend_options: dict | None = None,
    timeout_s: float | None = None,
    retry_escalated: bool = False,
) -> RunReport:
    """Run a plan end to end: broker (in-process, or Redis at ``redis_url``), executors, state manager.

    ``state_db``: SQLite file for the journal (and for the ``sim`` backend's world, so a resumed run
    finds the robots where they were). ``spawn_executors=False`` expects executors in other processes
    (``bimrobot rcan executor``) on the same Redis. ``backend_options`` go to the backend (``sim``:
    ``time_scale``, ``failure_probability``, ``seed``). ``retry_escalated``: see :meth:`RcanSystem.run`.
    """
    from bimrobot.rcan.state_manager import removed_unless_used

    with removed_unless_used(state_db):  # a run that fails before its first activity leaves no state file
        return _run_plan(activities, capabilities, backend, state_db, redis_url, spawn_executors, max_attempts,
                         observers, log, backend_options, timeout_s, retry_escalated)


def _run_plan(activities, capabilities, backend, state_db, redis_url, spawn_executors, max_attempts, observers,
              log, backend_options, timeout_s, retry_escalated) -> RunReport:
    from bimrobot.rcan.backends import create_backend
    from bimrobot.rcan.broker import InProcessBroker, RedisBroker
    from bimrobot.rcan.executor import RobotExecutor
    from bimrobot.rcan.state_manager import RetryPolicy, StateStore

    options = dict(backend_options or {})
    if backend == "sim":
        options.setdefault("db_path", state_db)
    store = StateStore(state_db)
    manager = StateManager(store, RetryPolicy(max_attempts), observers)
    broker = RedisBroker(redis_url, group="rcan", consumer="coordinator") if redis_url else InProcessBroker()
    executors, threads, backend_instance = [], [], None
    try:
        if spawn_executors:
            backend_instance = create_backend(backend, capabilities, **options)
            for robot in capabilities.robots:  # one executor per robot: robots work in parallel
                executor_broker = (RedisBroker(redis_url, group="executor", consumer=f"executor-{robot}")
                                   if redis_url else broker)
                executor = RobotExecutor(executor_broker, backend_instance, [robot])
                executors.append(executor)
                threads.append(executor.start_thread())
        system = RcanSystem(broker, capabilities, manager, backend, log)
        return system.run(activities, timeout_s=timeout_s, retry_escalated=retry_escalated)
    finally:
        for executor in executors:
            executor.stop.set()
        for thread in threads:
            thread.join(timeout=5)
        for executor in executors:
            if executor.broker is not broker:
                executor.broker.close()
        if backend_instance is not None:
            backend_instance.close()
        broker.close()
        store.close()
