#!/usr/bin/env bash
# The main job, end to end on the built-in steel frame. Output goes to $DEMO_OUT (default demo-out/).
# Each part of the platform adds one numbered step in scripts/demo.d/, run here in order.
set -euo pipefail
cd "$(dirname "$0")/.."
export VENV=${VENV:-.venv}
export DEMO_OUT=${DEMO_OUT:-demo-out}
export BIMROBOT="$VENV/bin/bimrobot"
rm -rf "$DEMO_OUT"
mkdir -p "$DEMO_OUT"
echo "== bimrobot demo: output in $DEMO_OUT/"
for step in scripts/demo.d/*.sh; do
  [ -e "$step" ] || continue
  echo
  echo "== $(basename "$step" .sh)"
  bash "$step"
done
echo
echo "== done: everything is in $DEMO_OUT/"
