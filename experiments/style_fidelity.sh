#!/usr/bin/env bash
# Style fidelity: RAIL trained on calm and on sporty demonstrations, each evaluated next to both experts.
# Usage: experiments/style_fidelity.sh [OUT_DIR]   (environment: ITERATIONS, DIRECTIONS, STEP_SIZE, WORKERS)
set -euo pipefail
out=${1:-results/style_fidelity}
iterations=${ITERATIONS:-20}
directions=${DIRECTIONS:-16}
step_size=${STEP_SIZE:-0.02}
workers=${WORKERS:-2}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
mkdir -p "$out"
for style in calm sporty; do
  [ -f "$out/demos_$style.parquet" ] || $sumo_rail record-expert --style "$style" --episodes 200 --seed 0 \
    --workers "$workers" --out "$out/demos_$style.parquet"
  resume=(); [ -f "$out/rail_$style/checkpoint.pt" ] && resume=(--resume)
  $sumo_rail train --demos "$out/demos_$style.parquet" --policy mlp --directions "$directions" \
    --top $((directions / 2)) --step-size "$step_size" --iterations "$iterations" --eval-every 0 \
    --workers "$workers" --seed 0 --out "$out/rail_$style" "${resume[@]}"
done
$sumo_rail evaluate --policy expert:calm --policy expert:sporty --policy "$out/rail_calm/policy_latest.npz" \
  --policy "$out/rail_sporty/policy_latest.npz" --episodes 16 --seed 1000 --workers "$workers" \
  --out "$out/evaluation.parquet" --overwrite | tee "$out/table.txt"
$sumo_rail report "$out/rail_calm" "$out/rail_sporty" "$out/evaluation.parquet" --out "$out/report"
