"""Collecting the tests stays light (issue 37: collection under 10 s): a test module imports at its top
only what collection needs, and heavy libraries in an autouse module fixture (tests/conftest.py). This
checks the rule itself, not a time: after ``pytest --collect-only`` no heavy library is loaded."""

from __future__ import annotations

import json
import subprocess
import sys

from shared_data import REPO_ROOT

#: each costs 0.3-2.5 s of imports; together they once tripled the collection's time
HEAVY = ("torch", "stable_baselines3", "sb3_contrib", "rerun", "datafusion", "mujoco", "trimesh", "scipy",
         "numba", "rdflib", "pyoxigraph", "ortools", "plotly", "pandas")

COLLECT = """
import contextlib, io, json, sys
import pytest
with contextlib.redirect_stdout(io.StringIO()):
    code = pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider", "tests"])
print(json.dumps({"code": int(code), "loaded": sorted(m for m in sys.argv[1:] if m in sys.modules)}))
"""


def test_collecting_the_tests_imports_no_heavy_library():
    run = subprocess.run([sys.executable, "-c", COLLECT, *HEAVY], cwd=REPO_ROOT, capture_output=True, text=True,
                         check=True)
    result = json.loads(run.stdout.strip().splitlines()[-1])
    assert result["code"] == 0, run.stderr[-2000:]
    assert result["loaded"] == [], f"collection imports {result['loaded']}: import them in a module fixture"
