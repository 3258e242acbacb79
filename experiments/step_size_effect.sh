#!/usr/bin/env bash
# How far one ARS step size moves a BC-initialised policy (issue 14): for each alpha, a few RAIL iterations at the
# default N (common traffic and the merged normaliser, as when it was published), then the share of demonstrated
# states whose decision changed (experiments/step_size_effect.py).
# Usage: experiments/step_size_effect.sh DEMOS.parquet [OUT_DIR]   (resumable: finished runs are skipped)
#   (environment: STEP_SIZES, ITERATIONS, WORKERS, OVERRIDES: --set options matching how DEMOS was recorded)
set -euo pipefail
demos=$1
out=${2:-results/step_size_effect}
step_sizes=${STEP_SIZES:-0.001 0.005 0.02 0.05}
iterations=${ITERATIONS:-3}
workers=${WORKERS:-2}
overrides=${OVERRIDES:-}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
python=${PYTHON:-.venv/bin/python}
runs=()
for alpha in $step_sizes; do
  run="$out/alpha_$alpha"
  resume=(); [ -f "$run/checkpoint.pt" ] && resume=(--resume)
  # shellcheck disable=SC2086  # the overrides are several words on purpose
  $sumo_rail train $overrides --demos "$demos" --policy mlp --step-size "$alpha" --traffic common --merge-normalizer \
    --iterations "$iterations" --eval-every 0 --workers "$workers" --seed 0 --out "$run" "${resume[@]}"
  runs+=("$run")
done
$python experiments/step_size_effect.py "$demos" "${runs[@]}" | tee "$out/table.md"
