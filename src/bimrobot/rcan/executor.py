"""The robot executor service: takes RCAN nodes for its robots off the broker, drives them through an
executor backend and sends each result back (thesis 5.2.1, "Robot executor").

One executor serves any number of robots with a bounded pool of worker threads (``workers``, default
up to 16): robots work in parallel, but 20,000 robots in a capability table do not make 20,000
threads. Each robot executes one node at a time (a per-robot lock), in the order they arrive.

Run it in a thread next to the rest of RCAN (in-process broker) or in its own process against Redis
(``bimrobot rcan executor --redis URL --robot NAME``).
"""

from __future__ import annotations

import logging
import threading
from typing import Iterable

from bimrobot.core.errors import InputError
from bimrobot.rcan.backends.info import ActivityResult
from bimrobot.rcan.backends.interfaces import ExecutorBackend
from bimrobot.rcan.broker import RESULT_TOPIC, Broker, Message, robot_topic
from bimrobot.rcan.node import RcanNode

log = logging.getLogger(__name__)

#: Worker threads of one executor when not given: enough for the robots of a site to work in parallel
#: on a backend that waits (ROS 2 actions, ``--time-scale``), bounded whatever the number of robots.
DEFAULT_WORKERS = 16


class RobotExecutor:
    """Executes the RCAN nodes sent to ``robots`` with ``backend`` until ``stop`` is set, on at most
    ``workers`` threads."""

    def __init__(self, broker: Broker, backend: ExecutorBackend, robots: Iterable[str], workers: int | None = None):
        self.broker = broker
        self.backend = backend
        self.robots = list(robots)
        self.topics = frozenset(robot_topic(r) for r in self.robots)
        self.workers = max(1, min(workers or DEFAULT_WORKERS, len(self.robots) or 1))
        self.stop = threading.Event()
        #: Why the executor stopped serving by itself: the broker gave up (e.g. Redis was not back within
        #: ``--redis-reconnect`` seconds); :meth:`serve` raises it.
        self.error: InputError | None = None
        self._robot_locks: dict[str, threading.Lock] = {}
        self._locks_guard = threading.Lock()

    def _robot_lock(self, robot: str) -> threading.Lock:
        with self._locks_guard:
            return self._robot_locks.setdefault(robot, threading.Lock())

    def handle(self, message: Message) -> ActivityResult:
        """Execute one node message and send its result; the message is acknowledged after sending."""
        payload = message.payload
        node = RcanNode.from_message(payload["node"])
        with self._robot_lock(node.robot):  # a robot does one thing at a time
            try:
                result = self.backend.execute(node, int(payload["attempt"]), float(payload.get("ready_at_s", 0.0)))
            except Exception as exc:  # a backend fault is a failed attempt, not a dead executor
                log.exception("backend %s failed on %s", self.backend.name, node.node_id)
                result = ActivityResult(node.activity_id, int(payload["attempt"]), node.robot, False,
                                        f"{self.backend.name} backend error: {exc}")
        # posted: on Redis the result and the acknowledgement go with this worker's next receive, in
        # one round trip
        self.broker.post(RESULT_TOPIC, {"node": payload["node"], "result": result.to_message()})
        self.broker.ack(message)
        return result

    def _work(self, poll_s: float) -> None:
        """One worker: receive one node, execute it, send its result, until :attr:`stop` is set. Each
        worker receives for itself: a node goes from the broker to the thread that executes it with no
        hand-over between threads (one thread wake-up less per activity). The broker itself rides out a
        lost connection for its reconnection time (``--redis-reconnect``); when it gives up (an
        InputError) the executor stops, every worker with it, and :meth:`serve` raises that one
        sentence. Any other broker error is logged in one line, once until a receive works again, and
        retried: unacknowledged messages are delivered again once the broker is back."""
        failing = False
        while not self.stop.is_set():
            try:
                messages = self.broker.receive(self.topics, timeout_s=poll_s, count=1)
            except InputError as exc:  # the broker gave up: no point in serving on
                with self._locks_guard:
                    self.error = self.error or exc
                self.stop.set()
                return
            except Exception as exc:  # noqa: BLE001 - keep serving; the coordinator is waiting for results
                if not failing:
                    log.warning("robot executor: broker error (%s: %s), retrying every second", type(exc).__name__, exc)
                failing = True
                self.stop.wait(1.0)
                continue
            failing = False
            for message in messages:
                try:
                    self.handle(message)
                except InputError as exc:  # the broker gave up while the result was sent
                    with self._locks_guard:
                        self.error = self.error or exc
                    self.stop.set()
                    return
                except Exception as exc:  # noqa: BLE001 - the result could not be sent: unacknowledged, so redelivered
                    log.warning("robot executor: could not send the result of message %s (%s: %s)",
                                message.message_id, type(exc).__name__, exc)

    def serve(self, poll_s: float = 0.2) -> None:
        """Serve on :attr:`workers` threads until :attr:`stop` is set (``poll_s``: how often each checks);
        raises :attr:`error` when the broker gave up (one sentence, no traceback at the command line)."""
        threads = [threading.Thread(target=self._work, args=(poll_s,), name=f"rcan-executor_{n}", daemon=True)
                   for n in range(self.workers)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        if self.error is not None:
            raise self.error

    def _serve_in_thread(self) -> None:
        try:
            self.serve()
        except InputError as exc:  # in a thread of the run: said once; the coordinator's broker gives up too
            log.error("robot executor stopped: %s", exc)

    def start_thread(self) -> threading.Thread:
        thread = threading.Thread(target=self._serve_in_thread, name="rcan-executor", daemon=True)
        thread.start()
        return thread
