#!/usr/bin/env bash
# The paper's table: the expert, BC, RAIL (two-layer and linear) and GAIL on the same 16 held-out seeds.
# Usage: experiments/imitation_table.sh [OUT_DIR]
#   (environment: ITERATIONS, DIRECTIONS, STEP_SIZE, WORKERS, GAIL_TIMESTEPS)
set -euo pipefail
out=${1:-results/imitation_table}
iterations=${ITERATIONS:-40}
directions=${DIRECTIONS:-32}
step_size=${STEP_SIZE:-0.02}
workers=${WORKERS:-2}
gail_timesteps=${GAIL_TIMESTEPS:-100000}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
mkdir -p "$out"
[ -f "$out/demos.parquet" ] || $sumo_rail record-expert --episodes 200 --seed 0 --workers "$workers" --out "$out/demos.parquet"
for kind in mlp linear; do
  resume=(); [ -f "$out/rail_$kind/checkpoint.pt" ] && resume=(--resume)
  $sumo_rail train --demos "$out/demos.parquet" --policy "$kind" --directions "$directions" --top $((directions / 2)) \
    --step-size "$step_size" --iterations "$iterations" --eval-every 5 --workers "$workers" --seed 0 \
    --out "$out/rail_$kind" "${resume[@]}"
done
[ -f "$out/gail_mlp/policy_latest.npz" ] || $sumo_rail gail --demos "$out/demos.parquet" --policy mlp \
  --timesteps "$gail_timesteps" --envs "$workers" --seed 0 --out "$out/gail_mlp"
$sumo_rail evaluate --policy expert --policy "$out/rail_mlp/policy_bc.npz" --policy "$out/rail_mlp/policy_latest.npz" \
  --policy "$out/rail_linear/policy_bc.npz" --policy "$out/rail_linear/policy_latest.npz" \
  --policy "$out/gail_mlp/policy_latest.npz" \
  --episodes 16 --seed 1000 --workers "$workers" --out "$out/evaluation.parquet" --overwrite | tee "$out/table.txt"
$sumo_rail report "$out/rail_mlp" "$out/rail_linear" "$out/gail_mlp" "$out/evaluation.parquet" --out "$out/report"
