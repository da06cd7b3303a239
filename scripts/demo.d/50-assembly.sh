#!/usr/bin/env bash
# Assembly-planning benchmark: the exact planner solves Env4 S4 (13 components, obstacles) as a GIF,
# a random policy plays the same setting for comparison, and the optimal/random reference returns.
set -euo pipefail
OUT="$DEMO_OUT/assembly"
mkdir -p "$OUT"
"$BIMROBOT" assembly play --setting E4S4 --policy planner --gif "$OUT/E4S4-planner.gif"
"$BIMROBOT" assembly play --setting E4S4 --policy random --seed 0 | tee "$OUT/E4S4-random.txt"
"$BIMROBOT" assembly optimum --setting E2S2,E4S4 --episodes 100 --json "$OUT/reference_returns.json"
echo "assembly: $OUT/ holds E4S4-planner.gif (the planner's optimal episode, thesis colours),"
echo "          E4S4-random.txt (a random policy's episode) and reference_returns.json (optimal vs random returns)"
