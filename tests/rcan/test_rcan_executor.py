"""The robot executor's workers and the in-process broker they receive from."""

from __future__ import annotations

import threading
from dataclasses import fields

from bimrobot.rcan.backends.interfaces import ActivityResult
from bimrobot.rcan.broker import InProcessBroker


def test_a_result_crosses_the_wire_with_every_field():
    result = ActivityResult("A0001.3", 2, "crane_a", False, "robot lost", 1.5, 4.0, robot_lost=True)
    message = result.to_message()
    assert set(message) == {f.name for f in fields(ActivityResult)}
    assert ActivityResult.from_message(message) == result


def test_receivers_waiting_on_the_same_topics_get_each_message_exactly_once():
    """The executor's workers all wait on the robots' topics; a message wakes one of them and none is
    lost or handed out twice, whatever the interleaving."""
    broker = InProcessBroker()
    topics = frozenset({"rcan.robot.a", "rcan.robot.b"})
    received, lock, stop = [], threading.Lock(), threading.Event()

    def worker() -> None:
        while not stop.is_set():
            for message in broker.receive(topics, timeout_s=0.05, count=1):
                with lock:
                    received.append(message.payload["n"])

    workers = [threading.Thread(target=worker) for _ in range(4)]
    for thread in workers:
        thread.start()
    for n in range(400):
        broker.send("rcan.robot.a" if n % 2 else "rcan.robot.b", {"n": n})
    deadline = threading.Event()
    for _ in range(200):  # up to 10 s for the workers to drain the queues
        with lock:
            if len(received) >= 400:
                break
        deadline.wait(0.05)
    stop.set()
    for thread in workers:
        thread.join()
    assert sorted(received) == list(range(400))
