"""The robot executor service: takes RCAN nodes for its robots off the broker, drives them through an
executor backend and sends each result back (thesis 5.2.1, "Robot executor").

Run it in a thread next to the rest of RCAN (in-process broker) or in its own process against Redis
(``bimrobot rcan executor --redis URL --robot NAME``).
"""

from __future__ import annotations

import logging
import threading
from typing import Iterable

from bimrobot.rcan.backends.interfaces import ActivityResult, ExecutorBackend
from bimrobot.rcan.broker import RESULT_TOPIC, Broker, Message, robot_topic
from bimrobot.rcan.node import RcanNode

log = logging.getLogger(__name__)


class RobotExecutor:
    """Executes the RCAN nodes sent to ``robots`` with ``backend`` until ``stop`` is set."""

    def __init__(self, broker: Broker, backend: ExecutorBackend, robots: Iterable[str]):
        self.broker = broker
        self.backend = backend
        self.topics = [robot_topic(r) for r in robots]
        self.stop = threading.Event()

    def handle(self, message: Message) -> ActivityResult:
        """Execute one node message and send its result; the message is acknowledged after sending."""
        payload = message.payload
        node = RcanNode.from_message(payload["node"])
        try:
            result = self.backend.execute(node, int(payload["attempt"]), float(payload.get("ready_at_s", 0.0)))
        except Exception as exc:  # a backend fault is a failed attempt, not a dead executor
            log.exception("backend %s failed on %s", self.backend.name, node.node_id)
            result = ActivityResult(node.activity_id, int(payload["attempt"]), node.robot, False,
                                    f"{self.backend.name} backend error: {exc}")
        self.broker.send(RESULT_TOPIC, {"node": payload["node"], "result": result.to_message()})
        self.broker.ack(message)
        return result

    def serve(self, poll_s: float = 0.2) -> None:
        """Loop until :attr:`stop` is set. A broker error (e.g. Redis restarting) is logged and retried:
        unacknowledged messages are delivered again once the broker is back."""
        while not self.stop.is_set():
            try:
                for message in self.broker.receive(self.topics, timeout_s=poll_s, count=1):
                    self.handle(message)
            except Exception:  # noqa: BLE001 - keep serving; the coordinator is waiting for results
                log.exception("robot executor for %s: broker error, retrying in 1 s", ", ".join(self.topics))
                self.stop.wait(1.0)

    def start_thread(self) -> threading.Thread:
        thread = threading.Thread(target=self.serve, name=f"rcan-executor-{self.topics}", daemon=True)
        thread.start()
        return thread
