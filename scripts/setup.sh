#!/usr/bin/env bash
# Sets up everything bimrobot needs on a fresh Debian machine: system packages (when root),
# a virtual environment in .venv, PyTorch (CPU build, pinned first), and the package with all extras.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${VENV:-.venv}
# libosmesa6: MuJoCo's offscreen pictures (MUJOCO_GL=osmesa); chromium + chromium-driver: the replay's browser test
APT_PACKAGES="ignition-tools libsdformat-dev redis-server libosmesa6 chromium chromium-driver"

missing=""
for pkg in $APT_PACKAGES; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing="$missing $pkg"
done
if [ -n "$missing" ]; then
  if [ "$(id -u)" = 0 ]; then
    echo "installing Debian packages:$missing"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $missing >/dev/null
  else
    echo "warning: missing Debian packages:$missing (install them as root; the tests that need them skip)" >&2
  fi
fi

[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install -q --upgrade pip
# torch first and pinned: an unpinned torch would pull a multi-GB CUDA build.
"$VENV/bin/python" -m pip install -q "torch==2.13.0"
"$VENV/bin/python" -m pip install -q -e ".[all,test]"
if [ -x scripts/setup-ros2.sh ]; then
  scripts/setup-ros2.sh "$VENV"
fi
touch "$VENV/.installed"
