"""RCAN message broker: receiver, sender and router (thesis 5.2.1), in-process or on Redis streams.

- :class:`Sender` puts a message (a JSON-able dict) on a topic.
- :class:`Receiver` takes messages from one or more topics, deserialises them, and acknowledges each
  once it has been handled (Redis keeps unacknowledged messages and hands them out again).
- :class:`Router` delivers each received message to the RCAN part registered for its topic.

Topics used by RCAN: ``rcan.activity`` (a smart component publishes its next construction activity),
``rcan.robot.<robot>`` (an instantiated RCAN node for that robot's executor), ``rcan.result`` (a
robot's execution result) and ``rcan.state`` (a component's new state, for the smart component).

:class:`InProcessBroker` (default) uses thread-safe queues. :class:`RedisBroker` uses one Redis stream
per topic with a consumer group per role, so RCAN nodes can run in separate processes or machines and a
crashed consumer's unacknowledged messages are delivered again when it comes back.
"""

from __future__ import annotations

import abc
import itertools
import json
import threading
from collections import defaultdict, deque
from dataclasses import dataclass
from typing import Callable, Iterable

from bimrobot.errors import InputError, require_extra

ACTIVITY_TOPIC = "rcan.activity"
RESULT_TOPIC = "rcan.result"
STATE_TOPIC = "rcan.state"


def robot_topic(robot: str) -> str:
    """The topic an executor of ``robot`` receives its RCAN nodes on."""
    return f"rcan.robot.{robot}"


@dataclass(frozen=True)
class Message:
    """A delivered message: ``topic``, JSON-able ``payload`` and the broker's ``message_id``."""

    topic: str
    payload: dict
    message_id: str


class Sender(abc.ABC):
    @abc.abstractmethod
    def send(self, topic: str, payload: dict) -> str:
        """Put ``payload`` on ``topic``; returns the message id."""


class Receiver(abc.ABC):
    @abc.abstractmethod
    def receive(self, topics: Iterable[str], timeout_s: float = 1.0, count: int = 16) -> list[Message]:
        """Up to ``count`` messages from ``topics``, waiting at most ``timeout_s`` for the first one."""

    @abc.abstractmethod
    def ack(self, message: Message) -> None:
        """Mark ``message`` handled; an unacknowledged message may be delivered again after a crash."""


class Broker(Sender, Receiver):
    """A sender and a receiver on the same transport."""

    def close(self) -> None:
        """Release the connection."""


class Router:
    """Delivers messages to the RCAN part registered for their topic (or topic prefix ending in '*')."""

    def __init__(self) -> None:
        self._routes: dict[str, Callable[[Message], None]] = {}

    def route(self, topic: str, handler: Callable[[Message], None]) -> None:
        self._routes[topic] = handler

    @property
    def topics(self) -> list[str]:
        return list(self._routes)

    def dispatch(self, message: Message) -> None:
        handler = self._routes.get(message.topic)
        if handler is None:
            raise LookupError(f"no RCAN part is routed for topic {message.topic!r}")
        handler(message)


class InProcessBroker(Broker):
    """Thread-safe queues, one per topic. Messages are serialised to JSON and back like on the wire.
    A topic nobody reads keeps only its last ``max_length`` messages (like the trimmed Redis streams).
    """

    def __init__(self, max_length: int = 100_000) -> None:
        self._queues: dict[str, deque] = defaultdict(lambda: deque(maxlen=max_length))
        self._ready = threading.Condition()
        self._ids = itertools.count(1)

    def send(self, topic: str, payload: dict) -> str:
        data = json.dumps(payload)
        with self._ready:
            message_id = str(next(self._ids))
            self._queues[topic].append((message_id, data))
            self._ready.notify_all()
        return message_id

    def receive(self, topics: Iterable[str], timeout_s: float = 1.0, count: int = 16) -> list[Message]:
        topics = list(topics)
        out: list[Message] = []
        with self._ready:
            self._ready.wait_for(lambda: any(self._queues[t] for t in topics), timeout=timeout_s)
            for topic in topics:
                queue = self._queues[topic]
                while queue and len(out) < count:
                    message_id, data = queue.popleft()
                    out.append(Message(topic, json.loads(data), message_id))
        return out

    def ack(self, message: Message) -> None:
        """Nothing to do: in-process messages are gone once received (a crash loses the process anyway)."""


class RedisBroker(Broker):
    """Redis streams with consumer groups: ``group`` names the role (e.g. ``executor``), ``consumer`` this
    process. Each topic is the stream ``<prefix><topic>``. On start the consumer first re-reads the
    messages it received but never acknowledged (a crash between receive and ack), then new ones.
    """

    def __init__(self, url: str = "redis://127.0.0.1:6379/0", group: str = "rcan", consumer: str = "rcan-1",
                 prefix: str = "bimrobot:", max_length: int = 100_000):
        redis = require_extra("redis", "redis")
        try:
            self._redis = redis.Redis.from_url(url, decode_responses=True)
            self._redis.ping()
        except (ValueError, redis.RedisError) as exc:
            raise InputError(f"cannot reach Redis at {url}: {exc}") from None
        self.group, self.consumer, self.prefix = group, consumer, prefix
        self.max_length = max_length  # streams are trimmed (approximately) to this many messages
        self._known_groups: set[str] = set()
        self._pending_checked: set[str] = set()

    def _key(self, topic: str) -> str:
        return self.prefix + topic

    def _ensure_group(self, key: str) -> None:
        if key in self._known_groups:
            return
        try:
            self._redis.xgroup_create(key, self.group, id="0", mkstream=True)
        except Exception as exc:  # BUSYGROUP: the group exists already
            if "BUSYGROUP" not in str(exc):
                raise
        self._known_groups.add(key)

    def send(self, topic: str, payload: dict) -> str:
        return self._redis.xadd(self._key(topic), {"data": json.dumps(payload)}, maxlen=self.max_length, approximate=True)

    def receive(self, topics: Iterable[str], timeout_s: float = 1.0, count: int = 16) -> list[Message]:
        keys = [self._key(t) for t in topics]
        for key in keys:
            self._ensure_group(key)
        unchecked = [k for k in keys if k not in self._pending_checked]
        if unchecked:  # our own unacknowledged messages from before a restart come first
            self._pending_checked.update(unchecked)
            replies = self._redis.xreadgroup(self.group, self.consumer, {k: "0" for k in unchecked}, count=count)
            messages = self._decode(replies)
            if messages:
                return messages
        block_ms = max(1, int(timeout_s * 1000))
        replies = self._redis.xreadgroup(self.group, self.consumer, {k: ">" for k in keys}, count=count, block=block_ms)
        return self._decode(replies)

    def _decode(self, replies) -> list[Message]:
        out = []
        for key, entries in replies or []:
            topic = key[len(self.prefix):]
            for message_id, fields in entries:
                if fields:  # an entry deleted after delivery comes back with no fields
                    out.append(Message(topic, json.loads(fields["data"]), message_id))
        return out

    def ack(self, message: Message) -> None:
        self._redis.xack(self._key(message.topic), self.group, message.message_id)

    def close(self) -> None:
        self._redis.close()
