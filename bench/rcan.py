"""RCAN throughput and latency through its transports, as ratios against the in-process broker.

Runs the same plan (``--activities`` move-to-component activities in two independent chains, one per
robot, on the sim robots with no sleeping) through:

- the in-process broker (reference),
- Redis streams with the executors as threads of this process,
- Redis streams with the executor in a separate process (``bimrobot rcan executor``),
- ROS 2 actions against the shipped robot node (in-process broker, ``ros2`` backend),

and prints activities per second and the p50/p99 latency from sending an RCAN node to receiving its
result (best of ``--repeats`` runs each). Redis is started on a free loopback port and stopped afterwards; ROS 2 runs with shared-memory
transport on a random domain. Usage: ``python bench/rcan.py [--activities 400] [--no-redis] [--no-ros]``.

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


def write_table() -> str:
    """The bench's capability table as a temporary file (JSON is YAML) for the other processes."""
    handle, path = tempfile.mkstemp(prefix="bench-rcan-", suffix=".yaml")
    with os.fdopen(handle, "w") as out:
        json.dump(TABLE, out)
    return path


REPEATS = 3


def measure(name: str, n: int, **kwargs) -> dict:
    """The best of :data:`REPEATS` runs (the machine is shared: the best run is the least disturbed)."""
    caps = parse_capabilities(TABLE, "bench table")
    runs = []
    for _ in range(REPEATS):
        report = run_plan(bench_plan(n), caps, timeout_s=300, **kwargs)
        assert report.status == "completed", f"{name}: {report.status}"
        latencies = np.array(report.latencies_s) * 1000
        runs.append({"transport": name, "activities": n, "activities_per_s": n / report.wall_s,
                     "p50_ms": float(np.percentile(latencies, 50)), "p99_ms": float(np.percentile(latencies, 99))})
    return max(runs, key=lambda run: run["activities_per_s"])


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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--activities", type=int, default=400)
    parser.add_argument("--no-redis", action="store_true")
    parser.add_argument("--no-ros", action="store_true")
    parser.add_argument("--repeats", type=int, default=3, help="runs per transport; the best is reported")
    parser.add_argument("--json", help="also write the results to this JSON file")
    parser.add_argument("--scaling", type=int, nargs="*", metavar="N",
                        help="measure only dispatch time against activities (default sizes 1000 3000 10000)")
    args = parser.parse_args()
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
        from bimrobot.rcan.backends import ros2

        ok, why = ros2.ros2_available()
        if not ok:
            print(f"ROS 2 skipped: {why}")
        else:
            os.environ.setdefault("FASTDDS_BUILTIN_TRANSPORTS", "SHM")
            os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(1, 200)))
            caps_file = write_table()
            try:
                with ros2.robot_node_process(caps_file):
                    rows.append(measure("ros2 actions", n, backend="ros2"))
            finally:
                os.unlink(caps_file)
    reference = rows[0]
    print(f"RCAN transports, {n} activities (2 robots, sim kinematics without sleeping), best of {REPEATS} runs; "
          "ratios vs in-process")
    print(f"{'transport':28s} {'act/s':>9s} {'p50 ms':>8s} {'p99 ms':>8s} {'act/s ratio':>12s} {'p50 ratio':>10s}")
    for row in rows:
        print(f"{row['transport']:28s} {row['activities_per_s']:9.1f} {row['p50_ms']:8.2f} {row['p99_ms']:8.2f} "
              f"{row['activities_per_s'] / reference['activities_per_s']:12.3f} {row['p50_ms'] / reference['p50_ms']:10.1f}")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(rows, handle, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
