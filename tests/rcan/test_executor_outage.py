"""Issue 35: ``rcan executor`` ignored ``--redis-reconnect`` and printed a traceback every few seconds of
a long Redis outage. It now stops after the reconnection time with one sentence and exit 2."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.redis


def _start_redis(port: int) -> subprocess.Popen:
    server = shutil.which("redis-server")
    if server is None:
        pytest.skip("redis-server is not installed (Debian package redis-server)")
    redis = pytest.importorskip("redis", reason="the redis Python client is not installed: pip install 'bimrobot[redis]'")
    process = subprocess.Popen([server, "--bind", "127.0.0.1", "--port", str(port), "--save", "", "--appendonly", "no"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    client = redis.Redis(port=port)
    for _ in range(500):  # bounded by tries, not by time
        try:
            client.ping()
            break
        except redis.ConnectionError:
            time.sleep(0.02)
    client.close()
    return process


def test_the_executor_gives_up_after_redis_reconnect_with_one_sentence(tmp_path, free_port):
    port = free_port()
    server = _start_redis(port)
    url = f"redis://127.0.0.1:{port}/0"
    executor = subprocess.Popen([sys.executable, "-m", "bimrobot", "rcan", "executor", "--redis", url, "--backend", "sim",
                                 "--redis-reconnect", "1"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert "rcan executor serving" in executor.stdout.readline()  # it is up and reading
        server.terminate()
        server.wait(timeout=30)
        _, err = executor.communicate(timeout=120)  # a bound for a broken executor, not a measured time
    finally:
        if executor.poll() is None:
            executor.kill()
            executor.wait()
        if server.poll() is None:
            server.kill()
            server.wait()
    assert executor.returncode == 2, err
    assert "Traceback" not in err, err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1 and "was not back within 1 s" in errors[0], err
