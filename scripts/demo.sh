#!/usr/bin/env bash
# The main job, end to end on the built-in steel frame. Output goes to $DEMO_OUT (default demo-out/).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${VENV:-.venv}
OUT=${DEMO_OUT:-demo-out}
BIMROBOT="$VENV/bin/bimrobot"
mkdir -p "$OUT"
echo "== bimrobot demo: output in $OUT/"
