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
import contextlib
import itertools
import json
import logging
import threading
import time
from collections import defaultdict, deque
from dataclasses import dataclass
from typing import Callable, Iterable

from bimrobot.core.errors import InputError, require_extra

log = logging.getLogger(__name__)

try:  # hiredis (redis[hiredis]) packs a command in C; redis-py's packer adds a Python pass per argument
    from hiredis import pack_command as _pack_command

    def _pack(commands: list[tuple]) -> bytes:
        return b"".join(map(_pack_command, commands))
except ImportError:  # pragma: no cover - redis-py packs them itself
    _pack = None

ACTIVITY_TOPIC = "rcan.activity"
RESULT_TOPIC = "rcan.result"
STATE_TOPIC = "rcan.state"
#: Messages delivered too often without being acknowledged (see :class:`RedisBroker`).
DEAD_LETTER_TOPIC = "rcan.dead"


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

    def post(self, topic: str, payload: dict) -> None:
        """Put ``payload`` on ``topic`` with this sender's next command (a broker on a network sends it
        in the same round trip as the next receive or send; messages keep their order)."""
        self.send(topic, payload)


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
        self._filled: set[str] = set()  # topics with messages: a receiver of 20,000 robot topics scans these
        self._lock = threading.Lock()
        # receivers waiting, each with the topics it waits on: a message wakes one receiver that wants
        # it (waking every thread on every message costs a GIL hand-over per message and receiver; the
        # executor's workers all wait on the same topics, and one of them takes the message)
        # Each waiter holds a plain lock, acquired: the sender releases it to wake the waiter (cheaper
        # than a threading.Event, whose set() goes through a Condition in Python).
        self._waiters: list[tuple[object, threading.Lock]] = []
        self._ids = itertools.count(1)
        self._local = threading.local()  # each thread's posted messages, sent with its next receive or send

    def post(self, topic: str, payload: dict) -> None:
        """As :meth:`Sender.post`: the message goes out with this thread's next receive or send, as on
        Redis (the coordinator commits its journal before what it posted leaves)."""
        posted = getattr(self._local, "posted", None)
        if posted is None:
            posted = self._local.posted = []
        posted.append((topic, payload))

    def _send_posted(self) -> None:
        posted = getattr(self._local, "posted", None)
        if posted:
            self._local.posted = []
            for topic, payload in posted:
                self._put(topic, payload)

    def send(self, topic: str, payload: dict) -> str:
        self._send_posted()
        return self._put(topic, payload)

    def _put(self, topic: str, payload: dict) -> str:
        data = json.dumps(payload)
        with self._lock:
            message_id = str(next(self._ids))
            self._queues[topic].append((message_id, data))
            self._filled.add(topic)
            for n, (wanted, wake) in enumerate(self._waiters):
                if topic in wanted:
                    del self._waiters[n]  # woken: the next message wakes another waiter
                    wake.release()
                    break
        return message_id

    def receive(self, topics: Iterable[str], timeout_s: float = 1.0, count: int = 16) -> list[Message]:
        """As :meth:`Receiver.receive`; ``topics`` in priority order, or a (frozen)set of topics taken in
        any order (an executor of many robots: only the topics holding messages are looked at)."""
        self._send_posted()
        if isinstance(topics, (set, frozenset)):
            wanted, rank = topics, None
        else:
            rank = {t: n for n, t in enumerate(topics)}
            wanted = rank
        with self._lock:
            ready = [t for t in self._filled if t in wanted]
            if not ready and timeout_s > 0:
                wake = threading.Lock()
                wake.acquire()
                waiter = (wanted, wake)
                self._waiters.append(waiter)
        if not ready and timeout_s > 0:
            woken = wake.acquire(timeout=timeout_s)
            with self._lock:
                if not woken:  # timed out: leave the list, unless a sender took it out meanwhile
                    for n, other in enumerate(self._waiters):
                        if other is waiter:
                            del self._waiters[n]
                            break
                ready = [t for t in self._filled if t in wanted]
        if not ready:
            return []
        taken = []
        with self._lock:
            for topic in sorted(ready, key=rank.__getitem__) if rank else ready:
                queue = self._queues[topic]
                while queue and len(taken) < count:
                    taken.append((topic, queue.popleft()))
                if not queue:
                    self._filled.discard(topic)
        # decoded outside the lock
        return [Message(topic, json.loads(data), message_id) for topic, (message_id, data) in taken]

    def ack(self, message: Message) -> None:
        """Nothing to do: in-process messages are gone once received (a crash loses the process anyway)."""

    def close(self) -> None:
        self._send_posted()


class RedisBroker(Broker):
    """Redis streams with consumer groups: ``group`` names the role (e.g. ``executor``), ``consumer`` this
    process. Each topic is the stream ``<prefix><topic>``. On start the consumer first re-reads the
    messages it received but never acknowledged (a crash between receive and ack), then new ones.

    Reliability (at-least-once delivery; the robot side makes the effects exactly-once):

    - a lost connection (Redis restarting, with or without persistence) is retried with exponential
      back-off (0.05 s doubling to 2 s) for up to ``reconnect_s`` seconds, then an InputError; every
      reconnection is counted in :attr:`reconnections`, so the coordinator re-publishes what its state
      database says is not done (a Redis without persistence comes back empty);
    - a consumer group that is gone (NOGROUP) is created again, not cached as existing;
    - messages another consumer of the group received but has not acknowledged for ``claim_idle_s``
      seconds (a dead executor) are claimed with XAUTOCLAIM;
    - a message delivered more than ``max_deliveries`` times is not handed out again: it goes to the
      dead-letter stream (topic :data:`DEAD_LETTER_TOPIC`, with its topic and delivery count), where
      the coordinator escalates its activity.
    """

    def __init__(self, url: str = "redis://127.0.0.1:6379/0", group: str = "rcan", consumer: str = "rcan-1",
                 prefix: str = "bimrobot:", max_length: int = 100_000, reconnect_s: float = 120.0,
                 claim_idle_s: float | None = 60.0, max_deliveries: int = 5):
        redis = require_extra("redis", "redis")
        self._errors = (redis.ConnectionError, redis.TimeoutError, redis.BusyLoadingError)
        self._ResponseError = redis.ResponseError
        self.url = url
        from redis.backoff import NoBackoff
        from redis.retry import Retry

        try:
            # no silent retries inside the client: every lost connection reaches _call, which counts it,
            # so the coordinator knows to re-publish what a restarted Redis may have lost
            self._redis = redis.Redis.from_url(url, decode_responses=True, socket_connect_timeout=2.0,
                                               health_check_interval=10, retry=Retry(NoBackoff(), 0))
            self._redis.ping()
        except (ValueError, redis.RedisError) as exc:
            raise InputError(f"cannot reach Redis at {url}: {exc}") from None
        self.group, self.consumer, self.prefix = group, consumer, prefix
        self.max_length = max_length  # streams are trimmed (approximately) to this many messages
        self.reconnect_s, self.claim_idle_s, self.max_deliveries = reconnect_s, claim_idle_s, max_deliveries
        self.reconnections = 0
        self._known_groups: set[str] = set()
        self._pending_checked: set[str] = set()
        self._last_claim = 0.0
        self._lock = threading.Lock()  # the caches above are shared by an executor's worker threads
        # posted messages and acknowledgements not yet sent, in order: they go with the next command in
        # one pipeline (a round trip less each); a crash before that is a crash before sending or
        # acknowledging, which the protocol survives (re-sending, redelivery)
        self._pending: list[tuple[str, str, str]] = []  # ("xadd", key, data) or ("xack", key, message id)
        self._local = threading.local()  # each thread's own connection (see _connection)
        self._connections: list = []

    def _key(self, topic: str) -> str:
        return self.prefix + topic

    def _call(self, operation: Callable):
        """``operation()`` with reconnection: connection errors are retried with back-off; after a
        reconnection the group caches are dropped (Redis may have come back empty)."""
        delay, deadline, failed = 0.05, time.monotonic() + self.reconnect_s, False
        while True:
            try:
                result = operation()
            except self._errors as exc:
                if time.monotonic() > deadline:
                    raise InputError(f"lost Redis at {self.url} and it was not back within {self.reconnect_s:g} s "
                                     f"({exc}); rerun the same command to resume") from None
                if not failed:
                    log.warning("Redis at %s unreachable (%s): reconnecting", self.url, exc)
                failed = True
                time.sleep(delay)
                delay = min(2.0, delay * 2)
                continue
            if failed:
                with self._lock:
                    self.reconnections += 1
                    self._known_groups.clear()
                    self._pending_checked.clear()
                log.warning("Redis at %s is back", self.url)
            return result

    def _ensure_group(self, key: str) -> None:
        if key in self._known_groups:
            return
        try:
            self._redis.xgroup_create(key, self.group, id="0", mkstream=True)
        except self._ResponseError as exc:  # BUSYGROUP: the group exists already
            if "BUSYGROUP" not in str(exc):
                raise
        with self._lock:
            self._known_groups.add(key)

    def _take_pending(self) -> list[tuple[str, str, str]]:
        """The posted messages and acknowledgements waiting to be sent (and forget them)."""
        with self._lock:
            pending, self._pending = self._pending, []
        return pending

    def _connection(self):
        """This thread's own connection to Redis, kept for the broker's life. The hot path (posts, acks
        and the blocking read of every turn) talks on it directly: redis-py's pipeline objects, taken
        from and given back to the pool on every call, cost about as much CPU as the round trip itself.
        An executor's workers block in their reads at the same time: each needs its own connection."""
        connection = getattr(self._local, "connection", None)
        if connection is None:
            connection = self._local.connection = self._redis.connection_pool.make_connection()
            with self._lock:
                self._connections.append(connection)
        return connection

    def _with_pending(self, pending: list[tuple[str, str, str]], command: tuple):
        """Redis ``command`` (its arguments) preceded by the ``pending`` operations, in one round trip on
        this thread's connection; returns the command's reply as Redis sent it. An acknowledgement Redis
        refuses (NOGROUP: it restarted empty) is dropped: nothing to acknowledge."""
        commands = [("XADD", key, "MAXLEN", "~", self.max_length, "*", "data", value) if operation == "xadd"
                    else ("XACK", key, self.group, value) for operation, key, value in pending]
        commands.append(command)
        connection = self._connection()
        connection.send_packed_command([_pack(commands)] if _pack else connection.pack_commands(commands))
        refused = None
        for operation, _, _ in pending:  # every reply is read, so the connection stays in step
            try:
                connection.read_response()
            except self._ResponseError as exc:  # a refused XADD is not dropped
                if operation == "xadd" and refused is None:
                    refused = exc
        reply = connection.read_response()  # the command's own error (e.g. NOGROUP) is raised here
        if refused is not None:
            raise refused
        return reply

    def _flushing(self, command: tuple):
        """Redis ``command`` (its arguments) with the pending operations, reconnecting as :meth:`_call` does (a lost
        connection sends them again with the command: sending or acknowledging twice is harmless)."""
        pending = self._take_pending()
        return self._call(lambda: self._with_pending(pending, command))

    def send(self, topic: str, payload: dict) -> str:
        data = json.dumps(payload)
        return self._flushing(("XADD", self._key(topic), "MAXLEN", "~", self.max_length, "*", "data", data))

    def post(self, topic: str, payload: dict) -> None:
        """As :meth:`Sender.post`: the message goes to Redis with this broker's next command."""
        data = json.dumps(payload)
        with self._lock:
            self._pending.append(("xadd", self._key(topic), data))

    def receive(self, topics: Iterable[str], timeout_s: float = 1.0, count: int = 16) -> list[Message]:
        keys = [self._key(t) for t in topics]
        while True:
            try:
                return self._call(lambda: self._receive(keys, timeout_s, count))
            except self._ResponseError as exc:
                if "NOGROUP" not in str(exc):
                    raise
                log.warning("Redis consumer group %s is gone (Redis restarted empty?): creating it again", self.group)
                with self._lock:
                    self.reconnections += 1  # whatever was in the streams is gone: counts as a restart
                    self._known_groups.clear()
                    self._pending_checked.clear()

    def _receive(self, keys: list[str], timeout_s: float, count: int) -> list[Message]:
        for key in keys:
            self._ensure_group(key)
        unchecked = [k for k in keys if k not in self._pending_checked]
        if unchecked:  # our own unacknowledged messages from before a restart come first
            replies = self._redis.xreadgroup(self.group, self.consumer, {k: "0" for k in unchecked}, count=count)
            with self._lock:
                self._pending_checked.update(unchecked)
            messages = self._screen(self._decode(replies))
            if messages:
                return messages
        if self.claim_idle_s is not None and time.monotonic() - self._last_claim >= min(self.claim_idle_s, 5.0):
            self._last_claim = time.monotonic()
            claimed = self._screen(self._claim(keys, count))
            if claimed:
                return claimed
        block_ms = max(1, int(timeout_s * 1000))
        pending = self._take_pending()
        try:
            replies = self._with_pending(pending, ("XREADGROUP", "GROUP", self.group, self.consumer, "COUNT", count,
                                                   "BLOCK", block_ms, "STREAMS", *keys, *[">"] * len(keys)))
        except self._errors:
            with self._lock:  # the connection was lost: kept for the retry (_call retries this receive)
                self._pending[:0] = pending
            raise
        return self._decode_raw(replies)

    def _claim(self, keys: list[str], count: int) -> list[Message]:
        """Messages other consumers of the group left unacknowledged for ``claim_idle_s`` (XAUTOCLAIM)."""
        out = []
        idle_ms = int(self.claim_idle_s * 1000)
        for key in keys:
            reply = self._redis.xautoclaim(key, self.group, self.consumer, idle_ms, "0-0", count=count)
            entries = reply[1] if reply and len(reply) > 1 else []
            if entries:
                log.warning("claimed %d message(s) of %s left unacknowledged for %g s by a dead consumer",
                            len(entries), key, self.claim_idle_s)
            out += self._decode([(key, entries)])
        return out

    def _screen(self, messages: list[Message]) -> list[Message]:
        """Messages handed out again (re-read or claimed): one delivered more than ``max_deliveries``
        times goes to the dead-letter stream instead (acknowledged here)."""
        out = []
        for message in messages:
            key = self._key(message.topic)
            pending = self._redis.xpending_range(key, self.group, message.message_id, message.message_id, 1)
            deliveries = pending[0]["times_delivered"] if pending else 1
            if deliveries > self.max_deliveries:
                log.warning("message %s of %s delivered %d times: moved to the dead-letter stream",
                            message.message_id, message.topic, deliveries)
                self._redis.xadd(self._key(DEAD_LETTER_TOPIC), {"data": json.dumps(
                    {"topic": message.topic, "payload": message.payload, "deliveries": deliveries,
                     "group": self.group})}, maxlen=self.max_length, approximate=True)
                self._redis.xack(key, self.group, message.message_id)
            else:
                out.append(message)
        return out

    def _decode(self, replies) -> list[Message]:
        out = []
        for key, entries in replies or []:
            topic = key[len(self.prefix):]
            for message_id, fields in entries:
                if fields:  # an entry deleted after delivery comes back with no fields
                    out.append(Message(topic, json.loads(fields["data"]), message_id))
        return out

    def _decode_raw(self, replies) -> list[Message]:
        """Messages of an XREADGROUP reply as Redis sent it: a map (RESP3) or a list of pairs (RESP2) of
        stream key -> [[message id, [field, value, ...]], ...]."""
        out = []
        for key, entries in replies.items() if isinstance(replies, dict) else replies or []:
            topic = key[len(self.prefix):]
            for message_id, fields in entries:
                if fields:  # an entry deleted after delivery comes back with no fields
                    out.append(Message(topic, json.loads(fields[fields.index("data") + 1]), message_id))
        return out

    def ack(self, message: Message) -> None:
        """Acknowledge ``message`` with this broker's next command (see ``_pending``)."""
        with self._lock:
            self._pending.append(("xack", self._key(message.topic), message.message_id))

    def flush(self) -> None:
        """Send the posted messages and acknowledgements now."""
        if self._pending:
            self._flushing(("PING",))

    def close(self) -> None:
        with contextlib.suppress(Exception):  # best effort: what is not acknowledged is delivered again
            self.flush()
        for connection in self._connections:
            connection.disconnect()
        self._redis.close()
