"""RCAN throughput and latency through its transports, as ratios against the in-process broker.

Runs the same plan (``--activities`` move-to-component activities in two independent chains, one per
robot, on the sim robots with no sleeping) through:

- the in-process broker (reference),
- Redis streams with the executors as threads of this process,
- Redis streams with the executor in a separate process (``bimrobot rcan executor``),
- ROS 2 actions against the shipped robot node (in-process broker, ``ros2`` backend),

and prints activities per second and the p50/p99 latency from sending an RCAN node to receiving its
result (medians of ``--repeats`` runs each), and each as ratios against the in-process run of the same
repeat (min/median/max). Redis is started on a free loopback port and stopped afterwards; ROS 2 runs
with shared-memory transport on a random domain.
Usage: ``python bench/rcan.py [--activities 400] [--no-redis] [--no-ros]``.

``python bench/rcan.py --references`` measures each transport against the bare round trip of the same
transport in the same run, repeat after repeat (min/median/max of the ratios over ``--repeats``):

- Redis: RCAN's p50 dispatch latency against a raw ``XADD`` -> ``XREAD BLOCK`` ping-pong on the same
  server, the echo side a thread of this process (executors as threads) or another process (executor
  process);
- ROS 2: RCAN's p50 against the fastest bare rclpy action round trip on the same action type (a server
  process that succeeds at once; clients and servers with the single- and multi-threaded executors,
  one node and one action client per robot for all goals), p50 and p99 side by side;

each with one round trip in flight (RCAN: one chain of activities) and with two (two chains on two
robots; two ping-pongs, two action clients).

With the journal on disk (``--state-db`` as ``bimrobot build`` runs it; skip with ``--no-disk``), the
in-process run's p50 is measured against one bare fsync'ed SQLite commit (WAL, ``synchronous=FULL``, as
the state database) on the same disk in the same round: the ratio is the number of disk syncs'
worth of time on the dispatch path (the robot's record of the goal, the coordinator's turn).

``python bench/rcan.py --scaling [1000 3000 10000]`` measures instead how the time of a whole in-process
run grows with the number of activities (min/median/max over ``--repeats``, growth ratios against the
smallest size).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import random
import shutil
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time

import numpy as np

from bimrobot.rcan.activities import ActivityKind, Pose, RcanActivity
from bimrobot.rcan.generation import parse_capabilities
from bimrobot.rcan.system import run_plan

TABLE = {
    "robot_types": {"mobile_base": {"activities": ["move_to_component", "transport"]},
                    "manipulator": {"activities": ["position_for_picking_up", "position_for_installing"]},
                    "gripper": {"activities": ["pick_up", "install"]}},
    "robots": {name: {"types": ["mobile_base", "manipulator", "gripper"], "payload_kg": 100, "reach_m": 2,
                      "speed_m_s": 1.0, "home": [0, 0, 0]} for name in ("robot_a", "robot_b")},
}


def bench_plan(n: int) -> list[RcanActivity]:
    """``n`` move-to-component activities in two chains (components C0 and C1), each robot shuttling."""
    plan, last = [], {}
    for i in range(n):
        chain = i % 2
        activity_id = f"B{chain}.{i // 2 + 1}"
        plan.append(RcanActivity(activity_id, f"C{chain}", ActivityKind.MOVE_TO_COMPONENT,
                                 Pose(float(i % 7), float(chain), 0.0), robot=f"robot_{'ab'[chain]}",
                                 predecessors=(last[chain],) if chain in last else ()))
        last[chain] = activity_id
    return plan


def chain_plan(n: int) -> list[RcanActivity]:
    """``n`` move-to-component activities of one component in one chain: one RCAN node in flight at a
    time, as in a ping-pong."""
    return [RcanActivity(f"S.{i}", "C0", ActivityKind.MOVE_TO_COMPONENT, Pose(float(i % 7), 0.0, 0.0),
                         robot="robot_a", predecessors=(f"S.{i - 1}",) if i else ()) for i in range(n)]


def write_table() -> str:
    """The bench's capability table as a temporary file (JSON is YAML) for the other processes."""
    handle, path = tempfile.mkstemp(prefix="bench-rcan-", suffix=".yaml")
    with os.fdopen(handle, "w") as out:
        json.dump(TABLE, out)
    return path


REPEATS = 3


def measure(name: str, n: int, **kwargs) -> list[dict]:
    """:data:`REPEATS` runs of the bench plan through one transport."""
    caps = parse_capabilities(TABLE, "bench table")
    runs = []
    for _ in range(REPEATS):
        report = run_plan(bench_plan(n), caps, timeout_s=300, **kwargs)
        assert report.status == "completed", f"{name}: {report.status}"
        latencies = np.array(report.latencies_s) * 1000
        runs.append({"transport": name, "activities": n, "activities_per_s": n / report.wall_s,
                     "p50_ms": float(np.percentile(latencies, 50)), "p99_ms": float(np.percentile(latencies, 99))})
    return runs


@contextlib.contextmanager
def redis_server():
    server = shutil.which("redis-server")
    if server is None:
        raise RuntimeError("redis-server is not installed")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    process = subprocess.Popen([server, "--bind", "127.0.0.1", "--port", str(port), "--save", "", "--appendonly", "no"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    import redis

    url = f"redis://127.0.0.1:{port}/0"
    client = redis.Redis.from_url(url)
    for _ in range(200):
        with contextlib.suppress(redis.ConnectionError):
            client.ping()
            break
        time.sleep(0.02)
    try:
        yield url
    finally:
        client.close()
        process.terminate()
        process.wait(timeout=10)


def independent_plan(n: int) -> list[RcanActivity]:
    """``n`` move-to-component activities of ``n`` components, all ready at once (each frees its robot):
    the longest waiting list, the case where a dispatcher that rescans it becomes quadratic."""
    return [RcanActivity(f"D{i}", f"C{i}", ActivityKind.MOVE_TO_COMPONENT, Pose(float(i % 7), 0.0, 0.0),
                         frees_robot=True) for i in range(n)]


def dispatch_scaling(sizes: list[int], repeats: int) -> list[dict]:
    """Wall time of a whole in-process sim run (planning + dispatch + execution) against the number of
    activities, min/median/max over ``repeats`` runs; growth ratios against the smallest size (a
    linear dispatcher grows like the activities: 3k/1k about 3, 10k/1k about 10)."""
    caps = parse_capabilities(TABLE, "bench table")
    rows = []
    for n in sizes:
        times = []
        for _ in range(repeats):
            for plan in (independent_plan(n), bench_plan(n)):
                started = time.perf_counter()
                report = run_plan(plan, caps, timeout_s=600)
                assert report.status == "completed"
                times.append((plan[0].activity_id[0], time.perf_counter() - started))
        for kind, label in (("D", "independent"), ("B", "two chains")):
            runs = sorted(t for k, t in times if k == kind)
            rows.append({"plan": label, "activities": n, "min_s": runs[0], "median_s": float(np.median(runs)),
                         "max_s": runs[-1]})
    print(f"RCAN dispatch time vs activities (in-process broker, sim robots without sleeping, 2 robots), "
          f"{repeats} repeats; growth = median / median of {sizes[0]}, against activities / {sizes[0]}")
    print(f"{'plan':12s} {'activities':>10s} {'min s':>8s} {'median s':>9s} {'max s':>8s} {'act/s':>8s} "
          f"{'growth':>7s} {'linear':>7s}")
    for row in rows:
        base = next(r for r in rows if r["plan"] == row["plan"] and r["activities"] == sizes[0])
        print(f"{row['plan']:12s} {row['activities']:10d} {row['min_s']:8.2f} {row['median_s']:9.2f} "
              f"{row['max_s']:8.2f} {row['activities'] / row['median_s']:8.0f} "
              f"{row['median_s'] / base['median_s']:7.2f} {row['activities'] / sizes[0]:7.2f}")
    return rows


# ------------------------------------------------------------------------------ bare references


def _percentiles(seconds: list[float]) -> tuple[float, float]:
    ms = np.array(seconds) * 1000
    return float(np.percentile(ms, 50)), float(np.percentile(ms, 99))


def redis_echo(url: str, pair: int = 0, stop=None) -> None:
    """The echo side of ping-pong ``pair``: ``XREAD BLOCK`` on its ping stream, ``XADD`` the same to its pong."""
    import redis

    client = redis.Redis.from_url(url)
    last = "0-0"  # the ping-pong starts on empty streams
    while stop is None or not stop.is_set():
        reply = client.xread({f"bench:ping:{pair}": last}, block=200, count=1)
        for _, entries in reply or []:
            for message_id, fields in entries:
                last = message_id
                client.xadd(f"bench:pong:{pair}", fields)
    client.close()


def _echo_process(url: str, pairs: int) -> None:
    import threading

    for pair in range(pairs):
        threading.Thread(target=redis_echo, args=(url, pair), daemon=True).start()
    print("echo ready", flush=True)
    threading.Event().wait()  # until terminated


def redis_pingpong(url: str, n: int, in_process: bool, pairs: int = 1) -> list[float]:
    """Round trips ``XADD ping`` -> echo ``XREAD BLOCK`` + ``XADD pong`` -> ``XREAD BLOCK pong`` (seconds
    each, after 20 warm-up trips), ``n`` in all, on ``pairs`` ping-pongs at once (each pinger and each
    echo a thread); the echoes are threads of this process or of another one."""
    import threading

    import redis

    client = redis.Redis.from_url(url)
    keys = [f"bench:{side}:{pair}" for pair in range(pairs) for side in ("ping", "pong")]
    client.delete(*keys)
    stop, process = threading.Event(), None
    if in_process:
        for pair in range(pairs):
            threading.Thread(target=redis_echo, args=(url, pair, stop), daemon=True).start()
    else:
        process = subprocess.Popen([sys.executable, __file__, "--redis-echo", url, "--pairs", str(pairs)],
                                   stdout=subprocess.PIPE, text=True)
        process.stdout.readline()
    out, lock = [], threading.Lock()
    payload = {"data": json.dumps({"node": "x" * 300})}  # about an RCAN node message

    def ping(pair: int) -> None:
        pinger, last = redis.Redis.from_url(url), "0-0"
        for i in range(n // pairs + 20):
            started = time.perf_counter()
            pinger.xadd(f"bench:ping:{pair}", payload)
            reply = pinger.xread({f"bench:pong:{pair}": last}, block=5000, count=1)
            last = reply[0][1][0][0]
            if i >= 20:
                with lock:
                    out.append(time.perf_counter() - started)
        pinger.close()

    try:
        pingers = [threading.Thread(target=ping, args=(pair,)) for pair in range(pairs)]
        for thread in pingers:
            thread.start()
        for thread in pingers:
            thread.join()
    finally:
        stop.set()
        if process is not None:
            process.terminate()
            process.wait(timeout=10)
            process.stdout.close()
        client.delete(*keys)
        client.close()
    return out


BARE_ACTION = "/bimrobot_bench/bare"


def _ros_executor(kind: str, context):
    from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor

    return SingleThreadedExecutor(context=context) if kind == "single" else MultiThreadedExecutor(2, context=context)


def bare_action_server(kind: str) -> None:
    """A bare ConstructionActivity action server that succeeds at once, spun by a ``kind`` executor."""
    from rclpy.action import ActionServer

    from bimrobot.rcan.backends.ros2.environment import load_ros2

    rclpy, action = load_ros2()
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("bench_bare_server", context=context)

    def execute(goal_handle):
        goal_handle.succeed()
        result = action.Result()
        result.success = True
        return result

    ActionServer(node, action, BARE_ACTION, execute)
    executor = _ros_executor(kind, context)
    executor.add_node(node)
    print("bare action server ready", flush=True)
    with contextlib.suppress(Exception):
        executor.spin()


def _spin(executor) -> None:
    with contextlib.suppress(Exception):  # the context shuts down at the end
        executor.spin()


def bare_action_round_trips(client_kind: str, n: int, in_flight: int = 1) -> list[float]:
    """Goal round trips (send goal, accepted, result; seconds each after 20 warm-up goals), ``n`` in
    all, to the bare server: one node, ``in_flight`` action clients each sending its goals one after
    the other from its own thread (as RCAN has one client per robot), the executor spinning in a
    thread, waiting on the futures' done callbacks."""
    import threading

    from rclpy.action import ActionClient

    from bimrobot.rcan.backends.ros2.environment import load_ros2

    rclpy, action = load_ros2()
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("bench_bare_client", context=context)
    clients = [ActionClient(node, action, BARE_ACTION) for _ in range(in_flight)]
    executor = _ros_executor(client_kind, context)
    executor.add_node(node)
    spinner = threading.Thread(target=_spin, args=(executor,), daemon=True)
    spinner.start()

    def wait(future, timeout_s: float = 10.0):
        done = threading.Event()
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout_s):
            raise TimeoutError(f"bare action: no answer within {timeout_s:g} s")
        return future.result()

    out, lost, lock = [], [], threading.Lock()

    def trips(client) -> None:
        if not client.wait_for_server(timeout_sec=30):
            raise RuntimeError("bare action server not found")
        goal = action.Goal()
        for attempt in range(10):  # a request sent just after discovery can be lost: warm up until answered
            with contextlib.suppress(TimeoutError):
                wait(wait(client.send_goal_async(goal), 2.0).get_result_async(), 2.0)
                break
        for i in range(n // in_flight + 20):
            goal = action.Goal()
            goal.activity_id, goal.robot = f"bare.{i}", "bare"
            started = time.perf_counter()
            try:
                handle = wait(client.send_goal_async(goal), 2.0)
                wait(handle.get_result_async(), 2.0)
            except TimeoutError:  # DDS lost a request or reply: not a round trip (counted, printed)
                lost.append(i)
                continue
            if i >= 20:
                with lock:
                    out.append(time.perf_counter() - started)

    try:
        threads = [threading.Thread(target=trips, args=(client,)) for client in clients]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        if lost:
            print(f"bare action ({client_kind}-threaded client): {len(lost)} goals lost (no answer in 2 s)")
    finally:
        executor.shutdown(timeout_sec=2)
        for client in clients:
            client.destroy()
        node.destroy_node()
        rclpy.shutdown(context=context)
        spinner.join(timeout=5)
    return out


def fastest_bare_action(n: int, in_flight: int = 1) -> tuple[str, list[float]]:
    """The fastest of the executor choices (server, client) for the bare round trip, in this run."""
    best = None
    for server_kind in ("multi", "single"):
        process = subprocess.Popen([sys.executable, __file__, "--bare-action-server", server_kind],
                                   stdout=subprocess.PIPE, text=True)
        try:
            process.stdout.readline()
            for client_kind in ("single", "multi"):
                trips = bare_action_round_trips(client_kind, n, in_flight)
                label = f"server {server_kind}-threaded, client {client_kind}-threaded"
                if best is None or np.median(trips) < np.median(best[1]):
                    best = (label, trips)
        finally:
            process.terminate()
            process.wait(timeout=10)
            process.stdout.close()
    return best


def bare_commits(folder: str, n: int) -> list[float]:
    """Seconds per SQLite commit of one row, WAL with ``synchronous=FULL`` as the state database (one
    disk sync each), ``n`` of them after 5 warm-up commits, in a database under ``folder``."""
    path = os.path.join(folder, "bare-commits.sqlite")
    db = sqlite3.connect(path, isolation_level=None)
    try:
        db.execute("PRAGMA journal_mode=WAL")
        db.execute("PRAGMA synchronous=FULL")
        db.execute("CREATE TABLE IF NOT EXISTS t (n INTEGER)")
        out = []
        for i in range(n + 5):
            started = time.perf_counter()
            db.execute("BEGIN IMMEDIATE")
            db.execute("INSERT INTO t VALUES (?)", (i,))
            db.execute("COMMIT")
            if i >= 5:
                out.append(time.perf_counter() - started)
    finally:
        db.close()
    return out


def _summary(ratios: list[float]) -> str:
    return f"{min(ratios):6.2f} {float(np.median(ratios)):6.2f} {max(ratios):6.2f}"


def references(n: int, repeats: int, redis: bool = True, ros: bool = True, disk: bool = True) -> list[dict]:
    """Each transport's p50 dispatch latency against its bare round trip, measured alternately in
    each of ``repeats`` rounds (and, with ``disk``, the in-process run with its state database in a
    file against one bare fsync'ed commit); returns one row per (transport, round)."""
    caps = parse_capabilities(TABLE, "bench table")

    def rcan_p50(in_flight: int, **kwargs) -> tuple[float, float]:
        """(p50, p99) ms of RCAN dispatch with ``in_flight`` robots working at once: one chain of
        activities (one RCAN node in flight, as in a ping-pong) or two chains on two robots."""
        report = run_plan(chain_plan(n) if in_flight == 1 else bench_plan(n), caps, timeout_s=300, **kwargs)
        assert report.status == "completed", f"{report.status}: {[str(e) for e in report.escalations]}"
        return _percentiles(report.latencies_s)

    def add(transport: str, in_flight: int, reference: str, ref: list[float], rcan: tuple[float, float]) -> None:
        rows.append({"transport": f"{transport}, {in_flight} in flight", "reference": reference,
                     "ref_ms": _percentiles(ref), "rcan_ms": rcan})

    rows = []
    for _ in range(repeats if redis else 0):
        for in_flight in (1, 2):
            with redis_server() as url:
                ref = redis_pingpong(url, n, in_process=True, pairs=in_flight)
                add("redis, executor threads", in_flight, "XADD -> XREAD BLOCK ping-pong, echo threads", ref,
                    rcan_p50(in_flight, redis_url=url))
            with redis_server() as url:
                caps_file = write_table()
                executor = subprocess.Popen([sys.executable, "-m", "bimrobot", "rcan", "executor", "--redis", url,
                                             "--capabilities", caps_file], stdout=subprocess.PIPE, text=True)
                executor.stdout.readline()
                try:
                    ref = redis_pingpong(url, n, in_process=False, pairs=in_flight)
                    rcan = rcan_p50(in_flight, redis_url=url, spawn_executors=False)
                finally:
                    executor.terminate()
                    executor.wait(timeout=10)
                    executor.stdout.close()
                    os.unlink(caps_file)
                add("redis, executor process", in_flight, "XADD -> XREAD BLOCK ping-pong, echo process", ref, rcan)
    for _ in range(repeats if disk else 0):
        with tempfile.TemporaryDirectory(prefix="bench-rcan-") as folder:
            ref = bare_commits(folder, 100)
            for in_flight in (1, 2):
                rcan = rcan_p50(in_flight, state_db=os.path.join(folder, f"state-{in_flight}.sqlite"))
                add("in-process, state db file", in_flight, "one fsync'ed SQLite commit (WAL, synchronous=FULL)",
                    ref, rcan)
    if ros:
        from bimrobot.rcan.backends.ros2 import robot_node_process

        with ros2_capabilities() as caps_file:
            for _ in range(repeats if caps_file else 0):
                bare = {in_flight: fastest_bare_action(n, in_flight) for in_flight in (1, 2)}
                with robot_node_process(caps_file):
                    for in_flight in (1, 2):
                        # a generous discovery time: the shared machine is loaded
                        rcan = rcan_p50(in_flight, backend="ros2", backend_options={"server_timeout_s": 60.0})
                        label, trips = bare[in_flight]
                        add("ros2 actions", in_flight, f"bare rclpy action ({label})", trips, rcan)
    print(f"RCAN p50 dispatch latency / the bare round trip of its transport, same run, {repeats} rounds, "
          f"{n} round trips / activities each, with 1 or 2 in flight at once (RCAN: 1 chain of activities or 2 "
          "chains on 2 robots, sim kinematics without sleeping); ms are medians over the rounds")
    print(f"{'transport':40s} {'ref p50':>8s} {'ref p99':>8s} {'rcan p50':>9s} {'rcan p99':>9s} "
          f"{'p50 ratio min/median/max':>25s} {'p99 ratio':>10s}")
    for transport in dict.fromkeys(r["transport"] for r in rows):
        mine = [r for r in rows if r["transport"] == transport]
        med = lambda key, i: float(np.median([r[key][i] for r in mine]))  # noqa: E731
        ratios = [r["rcan_ms"][0] / r["ref_ms"][0] for r in mine]
        p99 = float(np.median([r["rcan_ms"][1] / r["ref_ms"][1] for r in mine]))
        print(f"{transport:40s} {med('ref_ms', 0):8.2f} {med('ref_ms', 1):8.2f} {med('rcan_ms', 0):9.2f} "
              f"{med('rcan_ms', 1):9.2f} {_summary(ratios):>25s} {p99:10.2f}")
        print(f"{'':40s} reference: {mine[-1]['reference']}")
    return rows


@contextlib.contextmanager
def ros2_capabilities():
    """The capability table's file for a ROS 2 run, in the benchmarks' ROS 2 environment (Fast DDS over
    shared memory, a random domain); None, with the reason printed, when ROS 2 is not installed. The
    table and the Fast DDS files the run leaves are removed afterwards."""
    from bimrobot.rcan.backends.ros2 import cleanup_fastdds, fastdds_files, ros2_available

    ok, why = ros2_available()
    if not ok:
        print(f"ROS 2 skipped: {why}")
        yield None
        return
    os.environ.setdefault("FASTDDS_BUILTIN_TRANSPORTS", "SHM")
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(1, 200)))
    before = fastdds_files()
    caps_file = write_table()
    try:
        yield caps_file
    finally:
        os.unlink(caps_file)
        cleanup_fastdds(before)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--activities", type=int, default=400)
    parser.add_argument("--no-redis", action="store_true")
    parser.add_argument("--no-ros", action="store_true")
    parser.add_argument("--no-disk", action="store_true",
                        help="--references: skip the run with the state database in a file")
    parser.add_argument("--repeats", type=int, default=3, help="runs per transport (at least 3 for min/median/max)")
    parser.add_argument("--json", help="also write the results to this JSON file")
    parser.add_argument("--scaling", type=int, nargs="*", metavar="N",
                        help="measure only dispatch time against activities (default sizes 1000 3000 10000)")
    parser.add_argument("--references", action="store_true",
                        help="measure each transport against its bare round trip (Redis ping-pong, bare ROS 2 action)")
    parser.add_argument("--redis-echo", metavar="URL", help=argparse.SUPPRESS)  # the echo process of the ping-pong
    parser.add_argument("--pairs", type=int, default=1, help=argparse.SUPPRESS)
    parser.add_argument("--bare-action-server", metavar="EXECUTOR", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.redis_echo:
        _echo_process(args.redis_echo, args.pairs)
        return 0
    if args.bare_action_server:
        bare_action_server(args.bare_action_server)
        return 0
    if args.references:
        rows = references(args.activities, args.repeats, redis=not args.no_redis, ros=not args.no_ros,
                          disk=not args.no_disk)
        if args.json:
            with open(args.json, "w") as handle:
                json.dump(rows, handle, indent=2)
        return 0
    global REPEATS
    REPEATS = args.repeats
    if args.scaling is not None:
        rows = dispatch_scaling(args.scaling or [1000, 3000, 10000], args.repeats)
        if args.json:
            with open(args.json, "w") as handle:
                json.dump(rows, handle, indent=2)
        return 0
    n = args.activities
    rows = [measure("in-process", n)]
    if not args.no_redis:
        with redis_server() as url:
            rows.append(measure("redis (executor threads)", n, redis_url=url))
        with redis_server() as url:
            caps_file = write_table()
            executor = subprocess.Popen([sys.executable, "-m", "bimrobot", "rcan", "executor", "--redis", url,
                                         "--capabilities", caps_file], stdout=subprocess.PIPE, text=True)
            executor.stdout.readline()  # "rcan executor serving ...": it is up
            try:
                rows.append(measure("redis (executor process)", n, redis_url=url, spawn_executors=False))
            finally:
                executor.terminate()
                executor.wait(timeout=10)
                executor.stdout.close()
                os.unlink(caps_file)
    if not args.no_ros:
        from bimrobot.rcan.backends.ros2 import robot_node_process

        with ros2_capabilities() as caps_file:
            if caps_file:
                with robot_node_process(caps_file):
                    rows.append(measure("ros2 actions", n, backend="ros2"))
    reference = rows[0]
    print(f"RCAN transports, {n} activities (2 robots, sim kinematics without sleeping), {REPEATS} runs each; "
          "figures are medians, ratios vs the in-process run of the same repeat (min/median/max)")
    print(f"{'transport':28s} {'act/s':>9s} {'p50 ms':>8s} {'p99 ms':>8s} {'act/s ratio':>20s} {'p50 ratio':>20s}")
    for runs in rows:
        med = lambda key: float(np.median([run[key] for run in runs]))  # noqa: E731
        speed = [run["activities_per_s"] / ref["activities_per_s"] for run, ref in zip(runs, reference)]
        p50 = [run["p50_ms"] / ref["p50_ms"] for run, ref in zip(runs, reference)]
        print(f"{runs[0]['transport']:28s} {med('activities_per_s'):9.1f} {med('p50_ms'):8.2f} {med('p99_ms'):8.2f} "
              f"{_summary(speed):>20s} {_summary(p50):>20s}")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(rows, handle, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
