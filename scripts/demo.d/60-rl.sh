#!/usr/bin/env bash
# rl: a short MaskablePPO training run on Env1 Scenario 2, its greedy evaluation, and a GIF of the agent.
set -euo pipefail
out="$DEMO_OUT/rl"
mkdir -p "$out"

"$BIMROBOT" rl train --setting E1S2 --algo maskable-ppo --profile fast --shaping 1 --timesteps 4e4 --seed 0 \
    --eval-episodes 10 --checkpoint-every 2e4 --no-progress -o "$out"
run="$out/E1S2-maskable-ppo-s0"
"$BIMROBOT" rl eval "$run" --episodes 10
"$BIMROBOT" assembly play --setting E1S2 --policy "$run" --gif "$out/E1S2-maskable-ppo.gif"

echo
echo "rl: a 40k-step MaskablePPO run (fast profile, distance shaping) on E1S2 is in $run/:"
echo "  config.json, model.zip     what was trained and the trained model (bimrobot rl eval / assembly play --policy)"
echo "  episodes.csv, progress.csv every training episode's return; SB3's training log (tensorboard --logdir $out)"
echo "  results.json               last-100 training mean, 10 greedy evaluation episodes, normalised scores"
echo "  $out/E1S2-maskable-ppo.gif  the trained agent playing one episode"
echo "  The full benchmark table (all 16 settings, every algorithm benchmarked) is in docs/results/table.md."
