#!/usr/bin/env bash
# The paper's directions sweep: RAIL learning curves for N in {8, 16, 32, 64, 128} without BC initialisation.
# Usage: experiments/directions_sweep.sh DEMOS [OUT_DIR]   (environment: ITERATIONS, STEP_SIZE, WORKERS, SIZES)
set -euo pipefail
demos=$1
out=${2:-results/directions_sweep}
iterations=${ITERATIONS:-10}
step_size=${STEP_SIZE:-0.02}
workers=${WORKERS:-2}
sizes=${SIZES:-8 16 32 64 128}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
mkdir -p "$out"
runs=()
for n in $sizes; do
  resume=(); [ -f "$out/n$n/checkpoint.pt" ] && resume=(--resume)
  $sumo_rail train --demos "$demos" --policy mlp --bc-epochs 0 --directions "$n" --top $((n / 2)) \
    --step-size "$step_size" --iterations "$iterations" --eval-every 0 --workers "$workers" --seed 0 \
    --out "$out/n$n" "${resume[@]}"
  runs+=("$out/n$n")
done
$sumo_rail report "${runs[@]}" --out "$out/report"
