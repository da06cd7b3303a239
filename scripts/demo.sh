#!/usr/bin/env bash
# The main job, end to end on the built-in steel frame. Output goes to $DEMO_OUT (default demo-out/).
# Each part of the platform adds one numbered step in scripts/demo.d/, run here in order.
set -euo pipefail
cd "$(dirname "$0")/.."
export VENV=${VENV:-.venv}
export DEMO_OUT=${DEMO_OUT:-demo-out}
export BIMROBOT="$VENV/bin/bimrobot"
# Only a folder an earlier demo wrote (it holds .bimrobot-demo) is cleared; anything else is left alone.
if [ -e "$DEMO_OUT" ] && [ ! -f "$DEMO_OUT/.bimrobot-demo" ] && [ -n "$(ls -A "$DEMO_OUT" 2>/dev/null || echo x)" ]; then
  echo "demo: $DEMO_OUT exists and was not written by the demo; set DEMO_OUT to a new folder (nothing was changed)" >&2
  exit 2
fi
if [ -f "$DEMO_OUT/.bimrobot-demo" ]; then
  rm -rf "$DEMO_OUT"
fi
mkdir -p "$DEMO_OUT"
touch "$DEMO_OUT/.bimrobot-demo"
echo "== bimrobot demo: output in $DEMO_OUT/"
for step in scripts/demo.d/*.sh; do
  [ -e "$step" ] || continue
  echo
  echo "== $(basename "$step" .sh)"
  bash "$step"
done
echo
echo "== done: everything is in $DEMO_OUT/"
