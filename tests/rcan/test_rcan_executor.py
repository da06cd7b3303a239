"""The robot executor's workers and the in-process broker they receive from."""

from __future__ import annotations

import threading
from dataclasses import fields

from bimrobot.rcan.backends.info import ActivityResult
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


def test_a_posted_message_leaves_with_the_posters_next_receive_not_before():
    """``post`` sends with the poster's next receive or send (as on Redis, where it shares that round
    trip): the coordinator commits its journal before the RCAN nodes it posted reach an executor."""
    broker = InProcessBroker()
    broker.post("rcan.robot.a", {"node": 1})
    other = []
    reader = threading.Thread(target=lambda: other.extend(broker.receive(["rcan.robot.a"], timeout_s=0.0)))
    reader.start()
    reader.join()
    assert other == []  # not sent yet
    assert broker.receive(["rcan.result"], timeout_s=0.0) == []  # the poster's next receive sends it
    assert [m.payload for m in broker.receive(["rcan.robot.a"], timeout_s=0.0)] == [{"node": 1}]
