"""The RCAN system wired together: smart components publish activities, the generation system turns
each into an RCAN node, executors drive the robots, the state manager closes the loop (thesis fig. 5.6).

Every hop goes through the broker (in-process or Redis) and the :class:`~bimrobot.rcan.broker.Router`
hands each message to its part. :meth:`RcanSystem.run` executes a whole plan of
:class:`~bimrobot.rcan.activities.RcanActivity` in precedence order, one activity per robot at a time,
and resumes from the state database when a previous run of the same plan was interrupted.
"""

from __future__ import annotations

import heapq
import time
import uuid
from typing import Callable, Iterable

from bimrobot.site.fleet import Fleet
from bimrobot.core.errors import InputError
from bimrobot.rcan.activities import ActivityKind, RcanActivity
from bimrobot.rcan.backends import DEFAULT_BACKEND
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.broker import (ACTIVITY_TOPIC, DEAD_LETTER_TOPIC, RESULT_TOPIC, STATE_TOPIC, Broker, Message, Router,
                                  robot_topic)
from bimrobot.rcan.generation import NodeGenerator, TaskAllocator
from bimrobot.rcan.node import RcanNode
from bimrobot.rcan.run_order import SimulatedOrder
from bimrobot.rcan.run_report import RunReport, activity_timing, dependents, plan_signature
from bimrobot.rcan.state_manager import DONE, ESCALATED, STARTED, EscalationReport, StateManager
from bimrobot.rcan.waiting import WaitingActivities



class RcanSystem(WaitingActivities, SimulatedOrder):
    """Generation system + state manager + message routing, over one broker.

    ``log``: called with each line of the interaction log (component publishes, node instantiated,
    robot executes, result, new state).
    """

    def __init__(self, broker: Broker, capabilities: Fleet, state_manager: StateManager,
                 backend_name: str = DEFAULT_BACKEND, log: Callable[[str], None] | None = None):
        self.broker = broker
        self.capabilities = capabilities
        self.state = state_manager
        self.allocator = TaskAllocator(capabilities)
        self.generator = NodeGenerator(self.allocator, backend_name)
        self._given_log = log
        self.log = log if log is not None else (lambda line: None)
        self.router = Router()
        # called after each turn of the run with (results handled in all, nodes in flight): a backend in
        # this process that executes one activity at a time uses it to choose the next deterministically
        self.on_settled: Callable[[int, int], None] | None = None
        self.simulated_time = False
        self._results_handled = 0
        self.router.route(RESULT_TOPIC, self._on_result)
        self.router.route(DEAD_LETTER_TOPIC, self._on_dead_letter)

    # --- smart component API -----------------------------------------------------------------------
    def publish(self, activity: RcanActivity, attempt: int = 1) -> None:
        """A smart component publishes its next construction activity to the generation system.

        The activity goes on the broker (``rcan.activity``, with this run's token) for whoever follows the
        build, as the component states do on ``rcan.state``; the generation system, which runs in this
        process, takes it from the component directly. Reading its own message back from Redis cost a
        round trip per activity on the dispatch path and bought nothing: a crashed run resumes from its
        journal, never from messages in Redis."""
        t = activity.target
        ready_s = max((self._finished_s.get(p, 0.0) for p in (*activity.predecessors, *activity.after)), default=0.0)
        self._log_at(max(ready_s, self._at_s), 0, activity.activity_id)
        self.log(f"[component {activity.component_id}] publishes {activity.activity_id} '{activity.kind.label}' "
                 f"target ({t.x:.2f}, {t.y:.2f}, {t.z:.2f})" + (f" attempt {attempt}" if attempt > 1 else ""))
        self.broker.post(ACTIVITY_TOPIC, {"activity_id": activity.activity_id, "attempt": attempt,
                                          "run": self._run_token})
        self._enqueue(activity.activity_id, attempt)

    def _republish(self) -> None:
        """After the broker reconnected (Redis restarted, maybe empty): send again every RCAN node whose
        result has not come. Duplicates are harmless: the robot refuses a goal id it completed, a late
        result is ignored."""
        self.log(f"[state manager] broker reconnected: re-sending {len(self._in_flight)} RCAN nodes")
        for node, attempt in list(self._in_flight.values()):
            self._send(node, attempt)

    def _instantiate(self, activity: RcanActivity, attempt: int, robot: str) -> None:
        node = self.generator.instantiate(activity, robot)
        self._idle.discard(robot)
        ready_s = max((self._finished_s.get(p, 0.0) for p in activity.predecessors), default=0.0)
        self._log_at(max(ready_s, self._free_s.get(robot, 0.0)), 1, activity.activity_id)
        self.log(f"[generation] RCAN node {node.node_id} instantiated: component {activity.component_id}, "
                 f"activity '{activity.kind.label}', robot {robot}, backend {node.backend}")
        before, state = self.state.start(node, attempt)
        if state is not before:
            self.log(f"[component {activity.component_id}] state: {state.value}")
        self._send(node, attempt)

    def _send(self, node: RcanNode, attempt: int) -> None:
        ready_at = max((self._finished_s.get(p, 0.0) for p in node.activity.predecessors), default=0.0)
        self._in_flight[node.robot] = (node, attempt)
        self._idle.discard(node.robot)
        self._sent_at[(node.activity_id, attempt)] = time.perf_counter()
        self._sent_s[node.robot] = max(ready_at, self._free_s.get(node.robot, 0.0))  # its lines come no earlier
        self._log_at(self._sent_s[node.robot], 1, node.activity_id)
        self.log(f"[{node.node_id}] robot {node.robot} executes '{node.kind.label}' of {node.component_id}"
                 + (f" (attempt {attempt})" if attempt > 1 else ""))
        self.broker.post(robot_topic(node.robot),
                         {"node": node.to_message(), "attempt": attempt, "ready_at_s": ready_at})

    def _on_result(self, message: Message) -> None:
        self._results_handled += 1
        result = ActivityResult.from_message(message.payload["result"])
        flight = self._in_flight.get(result.robot)
        if flight is None or flight[0].activity_id != result.activity_id or flight[1] != result.attempt:
            self.broker.ack(message)  # a duplicate from before a restart: already handled
            return
        node = flight[0]
        del self._in_flight[result.robot]
        self._recheck.add(node.component_id)
        sent = self._sent_at.pop((result.activity_id, result.attempt), None)
        if sent is not None:
            self._latencies.append(time.perf_counter() - sent)
        verdict = "success" if result.success else "failure"
        self._free_s[result.robot] = self._at_s = result.finished_s
        self._log_at(result.finished_s, 2, node.activity_id)
        self.log(f"[{node.node_id}] result: {verdict}: {result.message} (t {result.started_s:.1f}-{result.finished_s:.1f} s)")
        escalate = False
        if result.robot_lost and not result.success:
            escalate = not self._out_of_service(node, result.message)
        self._decide(node, self.state.result(node, result, escalate=escalate), result)
        self._at_s = 0.0  # a retry published by the decision is ready at the result; later ones at their own time
        self.broker.ack(message)

    def _out_of_service(self, node: RcanNode, why: str) -> bool:
        """Take ``node``'s robot out of this run (its node died) and free its component, so the retry goes
        to another capable robot. Returns whether one is left for the activity."""
        self._down.add(node.robot)
        self._idle.discard(node.robot)
        self.log(f"[state manager] robot {node.robot} is out of service for this run: {why}")
        self._released(node.component_id)
        for key, (capable, heap) in list(self._groups.items()):  # what waited for this robot alone
            if capable == {node.robot} and heap:
                del self._groups[key]
                for entry in heap:
                    heapq.heappush(self._open_heap(self._plan[entry[1]]), entry)
        return any(r.name not in self._down for r in self.allocator.capable(node.activity))

    def _on_dead_letter(self, message: Message) -> None:
        """A message the broker delivered too often without an acknowledgement: when it is the RCAN node
        of an activity in flight, that activity is escalated (its robot never answers for it)."""
        payload = message.payload
        node_message = payload.get("payload", {}).get("node") if str(payload.get("topic", "")).startswith("rcan.robot.") else None
        flight = self._in_flight.get(node_message["robot"]) if node_message else None
        attempt = int(payload["payload"].get("attempt", 0)) if node_message else 0
        if flight and flight[0].activity_id == node_message["activity_id"] and flight[1] == attempt:
            node = flight[0]
            del self._in_flight[node.robot]
            self._recheck.add(node.component_id)
            result = ActivityResult(node.activity_id, attempt, node.robot, False,
                                    f"its RCAN node was delivered {payload.get('deliveries')} times without a result "
                                    "(dead-letter stream)")
            self._decide(node, self.state.result(node, result, escalate=True), result)
        self.broker.ack(message)

    def _decide(self, node: RcanNode, decision, result: ActivityResult) -> None:
        """Act on the state manager's decision about ``node``'s result."""
        if decision.verdict == DONE:
            self._done.add(node.activity_id)
            self._newly_done.append(node.activity_id)
            self._finished_s[node.activity_id] = result.finished_s
            if node.activity.releases_robot:  # the component is placed: its robot is free again
                self._released(node.component_id)
        elif decision.verdict == "retry":
            self.publish(node.activity, decision.next_attempt)
        elif decision.verdict == ESCALATED:
            self._escalations.append(decision.report)
            self._newly_settled.append(node.activity_id)
            self.log(f"[state manager] {decision.report}")
            # isolate, never block: the robot is released for work that does not depend on this one
            self._released(node.component_id)
        if not self.allocator.is_committed(node.robot):
            self._set_idle(node.robot)
        self.log(f"[component {node.component_id}] state: {decision.component_state}")
        self.broker.post(STATE_TOPIC, {"component_id": node.component_id, "state": decision.component_state,
                                       "activity_id": node.activity_id, "verdict": decision.verdict})

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
        self._open_journal(activities, retry_escalated)
        self._begin(activities)
        reconnections = getattr(self.broker, "reconnections", 0)
        resumed, queued = self._restore(activities)
        published = set(self._done) | queued | {n.activity_id for n, _ in self._in_flight.values()}
        published |= {r.activity_id for r in self._escalations}
        unmet, successors = self._links(activities)
        ready = {i for i, n in unmet.items() if n == 0 and i not in published}
        self._newly_done.clear()  # done before this run: already counted in ``unmet``
        started = time.perf_counter()
        messages: list[Message] = []
        while True:
            reconnections = self._turn(messages, reconnections, unmet, successors, ready, published)
            self._flush_log()
            if self.on_settled is not None:
                self.on_settled(self._results_handled, len(self._in_flight))
            if not self._in_flight:
                break  # finished, or blocked: waiting activities that no free robot will ever take
            if timeout_s is not None and time.perf_counter() - started > timeout_s:
                self._flush_log(everything=True)
                raise TimeoutError(f"RCAN run did not finish within {timeout_s:.0f} s; in flight: {sorted(self._in_flight)}")
            wait_s = 0.0 if self._pending and self._releasable() else 0.05
            messages = self.broker.receive(self.router.topics, timeout_s=wait_s)
        self._flush_log(everything=True)
        return self._report(activities, started, resumed)

    def _open_journal(self, activities: list[RcanActivity], retry_escalated: bool) -> None:
        """Tie the state database to this plan (InputError for another plan's) and register its activities."""
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

    def _begin(self, activities: list[RcanActivity]) -> None:
        """The state of a new run: nothing in flight, done or waiting, every robot idle (then restored)."""
        self._run_token = uuid.uuid4().hex
        self._in_flight, self._sent_at, self._latencies = {}, {}, []
        self._sent_s, self._free_s, self._at_s = {}, {}, 0.0
        self._pending: list[tuple[float, int, int, Message]] = []  # results held back (simulated time)
        self._held_count = 0
        self._done, self._escalations, self._finished_s = set(), [], {}
        self._held, self._groups, self._recheck, self._newly_done, self._down = {}, {}, set(), [], set()
        self._order = {a.activity_id: n for n, a in enumerate(activities)}
        self._robot_order = {name: n for n, name in enumerate(self.capabilities.names)}
        self._idle = set(self.capabilities.names)
        self._idle_heap = [(0, n, name) for n, name in enumerate(self.capabilities.names)]  # (load, order, robot)

    def _links(self, activities: list[RcanActivity]) -> tuple[dict[str, int], dict[str, list[str]]]:
        """Which activities wait for which (done activities count as met), to publish in plan order,
        without rescanning the whole plan on every turn of the loop: (activity -> links unmet, activity ->
        its successors). ``after`` (a robot's schedule order) counts like a predecessor, but one that
        failed is met too (``_soft_successors``; ``_hard_successors`` cannot run once it failed)."""
        links = {a.activity_id: set(a.predecessors) | set(a.after) for a in activities}
        unmet = {i: len({p for p in ps if p not in self._done}) for i, ps in links.items()}
        successors: dict[str, list[str]] = {}
        for i, ps in links.items():
            for p in ps:
                successors.setdefault(p, []).append(i)
        self._soft_successors: dict[str, list[str]] = {}
        for a in activities:
            for p in set(a.after) - set(a.predecessors):
                self._soft_successors.setdefault(p, []).append(a.activity_id)
        self._hard_successors: dict[str, list[str]] = {}
        for a in activities:
            for p in set(a.predecessors):
                self._hard_successors.setdefault(p, []).append(a.activity_id)
        self._settled: set[str] = set()
        self._newly_settled = [r.activity_id for r in self._escalations]
        return unmet, successors

    def _turn(self, messages: list[Message], reconnections: int, unmet: dict[str, int],
              successors: dict[str, list[str]], ready: set[str], published: set[str]) -> int:
        """One turn: handle what came, publish what became ready, instantiate and post RCAN nodes; its
        journal writes are committed together before the next receive sends its posts. Returns the
        broker's reconnection count (a new one re-sends the nodes in flight)."""
        with self.state.store.batch():
            for message in self._in_simulated_order(messages):
                self.router.dispatch(message)
            if getattr(self.broker, "reconnections", 0) != reconnections:
                reconnections = self.broker.reconnections
                self._republish()
            for finished in self._newly_done:
                for successor in successors.get(finished, ()):
                    unmet[successor] -= 1
                    if unmet[successor] == 0 and successor not in published:
                        ready.add(successor)
            self._newly_done.clear()
            for soft in self._settle_failed():
                unmet[soft] -= 1
                if unmet[soft] == 0 and soft not in published:
                    ready.add(soft)
            for activity_id in sorted(ready, key=self._order.__getitem__):  # components publish what became ready
                published.add(activity_id)
                self.publish(self._plan[activity_id])
            ready.clear()
            self._dispatch_waiting()
        return reconnections

    # --- failed activities and the plan -----------------------------------------------------------
    def _settle_failed(self) -> list[str]:
        """The soft-order links (``after``) met by failure: an escalated activity and every activity that
        waits for it will not run, so the activities that merely follow them in their robot's order may
        go. Returns one successor id per link met (each link once)."""
        met = []
        stack = list(self._newly_settled)
        self._newly_settled.clear()
        while stack:
            activity_id = stack.pop()
            if activity_id in self._settled or activity_id in self._done:
                continue
            self._settled.add(activity_id)
            met += self._soft_successors.get(activity_id, ())
            # what lists it as a predecessor cannot run once it failed
            stack += [s for s in self._hard_successors.get(activity_id, ()) if s not in self._settled]
        return met

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

    def _restore(self, activities: list[RcanActivity]) -> tuple[int, set[str]]:
        """Rebuild in-memory state from the journal; re-send started activities. Returns how many,
        and the failed activities queued for their next attempt."""
        rows = self.state.store.activity_rows()
        resent, retries = 0, []
        escalated_components = set()
        for activity in activities:
            row = rows[activity.activity_id]
            if row["robot"] and row["status"] in (DONE, STARTED):
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
                escalated_components.add(activity.component_id)
            elif row["attempts"]:  # failed, retry not yet sent
                retries.append((activity.activity_id, row["attempts"] + 1))
        in_flight = {node.component_id for node, _ in self._in_flight.values()}
        for component in escalated_components - in_flight:  # escalation released their robots
            self.allocator.release(component)
        self._idle -= self.allocator.committed_robots()
        self._idle_heap = [(self.allocator.load(r), self._robot_order[r], r) for r in self._idle]
        heapq.heapify(self._idle_heap)
        for activity_id, attempt in retries:
            self._enqueue(activity_id, attempt)
        return resent, {a for a, _ in retries}

    def _report(self, activities, started: float, resumed: int) -> RunReport:
        escalated = {r.activity_id for r in self._escalations}
        blocked = [a.activity_id for a in activities if a.activity_id not in self._done and a.activity_id not in escalated]
        blocked_by = dependents(activities, [r.activity_id for r in self._escalations])
        status = "completed" if not blocked and not escalated else ("escalated" if escalated else "blocked")
        rows = self.state.store.activity_rows()
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
            blocked_by={a: blocked_by[a] for a in blocked if a in blocked_by},
            robots={a: row["robot"] for a, row in rows.items() if row["robot"]},
            activities={a.activity_id: activity_timing(rows.get(a.activity_id)) for a in activities},
        )


def run_plan(
    activities: Iterable[RcanActivity],
    capabilities: Fleet,
    backend: str = DEFAULT_BACKEND,
    state_db: str = ":memory:",
    redis_url: str | None = None,
    spawn_executors: bool = True,
    max_attempts: int = 3,
    observers: Iterable = (),
    log: Callable[[str], None] | None = None,
    backend_options: dict | None = None,
    timeout_s: float | None = None,
    retry_escalated: bool = False,
    redis_options: dict | None = None,
    reallocate: bool = False,
) -> RunReport:
    """Run a plan end to end: broker (in-process, or Redis at ``redis_url``), executors, state manager.

    ``state_db``: SQLite file for the journal (and for the ``sim`` backend's world, so a resumed run
    finds the robots where they were). ``spawn_executors=False`` expects executors in other processes
    (``bimrobot rcan executor``) on the same Redis. ``backend_options`` go to the backend (``sim``:
    ``time_scale``, ``failure_probability``, ``seed``). ``retry_escalated``: see :meth:`RcanSystem.run`.
    ``redis_options`` go to every :class:`~bimrobot.rcan.broker.RedisBroker` (``reconnect_s``,
    ``claim_idle_s``, ``max_deliveries``). ``reallocate``: give each activity to any capable robot
    instead of the robot the schedule assigned (:class:`~bimrobot.rcan.generation.TaskAllocator`).
    """
    from bimrobot.rcan.state_db import removed_unless_used

    with removed_unless_used(state_db):  # a run that fails before its first activity leaves no state file
        return _run_plan(activities, capabilities, backend, state_db, redis_url, spawn_executors, max_attempts,
                         observers, log, backend_options, timeout_s, retry_escalated, redis_options or {}, reallocate)


def _run_plan(activities, capabilities, backend, state_db, redis_url, spawn_executors, max_attempts, observers,
              log, backend_options, timeout_s, retry_escalated, redis_options, reallocate=False) -> RunReport:
    from bimrobot.rcan.backends import backend_class
    from bimrobot.rcan.backends.info import RunContext
    from bimrobot.rcan.broker import InProcessBroker, RedisBroker
    from bimrobot.rcan.executor import RobotExecutor
    from bimrobot.rcan.state_manager import RetryPolicy

    activities = list(activities)
    backend_type = backend_class(backend)
    _check_features(backend, backend_type, activities)
    info = backend_type.backend_info()
    store = _locked_store(state_db, activities)
    manager = StateManager(store, RetryPolicy(max_attempts), observers)
    try:
        broker = (RedisBroker(redis_url, group="rcan", consumer="coordinator", **redis_options) if redis_url
                  else InProcessBroker())
    except BaseException:
        store.close()
        raise
    executors, threads, backend_instance, in_turns = [], [], None, False
    try:
        if spawn_executors:
            # what it needs from the run (the state database, the plan, where its trajectory goes), then its options
            backend_instance = backend_type.create(capabilities, RunContext.of_run(state_db, activities),
                                                   **dict(backend_options or {}))
            # one executor for every robot, on a bounded pool of threads: robots work in parallel
            executor_broker = (RedisBroker(redis_url, group="executor", consumer="executor-local", **redis_options)
                               if redis_url else broker)
            # a backend that acts in turns needs every robot's node at hand: a thread per robot
            in_turns = info.acts_in_turns
            executor = RobotExecutor(executor_broker, backend_instance, capabilities.names,
                                     workers=len(capabilities.names) if in_turns else None)
            executors.append(executor)
            threads.append(executor.start_thread())
        system = RcanSystem(broker, capabilities, manager, backend, log)
        if in_turns:
            backend_instance.attach_coordinator()
            system.on_settled = backend_instance.coordinator_settled
        system.allocator.reallocate = reallocate
        # times are simulated (not a robot's clock) and no turn coordinator orders them: handle results by them
        # (BackendInfo.simulated_time; issue 35: the allocation does not depend on thread timing)
        system.simulated_time = info.simulated_time and not in_turns
        report = system.run(activities, timeout_s=timeout_s, retry_escalated=retry_escalated)
        if backend_instance is not None:  # what the backend measured, if it says (e.g. placement errors)
            report.backend_summary = backend_instance.summary()
        return report
    finally:
        _shut_down(executors, threads, backend_instance, broker, store)


def _locked_store(state_db: str, activities: list[RcanActivity]):
    """The run's state database, locked (one run per database); another plan's database is refused unwritten."""
    from bimrobot.rcan.state_manager import StateStore

    store = StateStore(state_db, plan=plan_signature(activities))
    try:
        store.lock()
    except BaseException:
        store.db.close()
        raise
    return store


def _shut_down(executors: list, threads: list, backend_instance, broker, store) -> None:
    """Stop the executors and the backend, wait for their threads (5 s each at most), close what the run opened."""
    for executor in executors:
        executor.stop.set()
    if backend_instance is not None:
        backend_instance.stop()
    for thread in threads:
        thread.join(timeout=5)
    for executor in executors:
        if executor.broker is not broker:
            executor.broker.close()
    if backend_instance is not None:
        backend_instance.close()
    broker.close()
    store.close()


def _check_features(name: str, backend_type, activities: list[RcanActivity]) -> None:
    """InputError when the plan has an activity the backend does not implement (its features), naming
    the first such activity and what the backend implements."""
    missing = next((a for a in activities if a.kind not in backend_type.features), None)
    if missing is not None:
        kinds = [kind.label for kind in ActivityKind if kind in backend_type.features]
        raise InputError(f"the {name} backend does not implement '{missing.kind.label}' (activity "
                         f"{missing.activity_id}); it implements: {', '.join(kinds) or 'nothing'}")
