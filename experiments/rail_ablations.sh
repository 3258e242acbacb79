#!/usr/bin/env bash
# RAIL ablations (issue 14): each variant changes one thing against another, for several training
# seeds; every policy is evaluated on validation episodes (to choose train's defaults) and once on test episodes
# (the published table, experiments/ablation_table.py).
# Usage: experiments/rail_ablations.sh DEMOS.parquet [OUT_DIR]   (resumable: finished runs are skipped)
#   (environment: SEEDS, DIRECTIONS, ITERATIONS, VALIDATION_EPISODES, TEST_EPISODES, WORKERS, and OVERRIDES: --set
#   options matching how DEMOS was recorded, for example "--set observation.lane_block=1")
set -euo pipefail
demos=$1
out=${2:-results/rail_ablations}
seeds=${SEEDS:-0 1 2}
directions=${DIRECTIONS:-16}
iterations=${ITERATIONS:-15}
validation_episodes=${VALIDATION_EPISODES:-60}
test_episodes=${TEST_EPISODES:-100}
workers=${WORKERS:-2}
overrides=${OVERRIDES:-}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
python=${PYTHON:-.venv/bin/python}
declare -A variants=(  # each says its traffic and normaliser, whatever train's defaults are; b = N / 2 unless said
  [crn]="--traffic common --merge-normalizer"  # common random numbers
  [independent]="--traffic independent --merge-normalizer"  # RAIL as first implemented
  [frozen]="--traffic common --freeze-normalizer"  # the normaliser stays BC's
  [v2]="--traffic common --merge-normalizer --top $directions"  # ARS V2: every direction
  [disc5]="--traffic common --merge-normalizer --disc-steps 50"  # discriminator x5
  [indfrozen]="--traffic independent --freeze-normalizer"  # independent and frozen
)
mkdir -p "$out"
policies=(--policy expert)
for seed in $seeds; do
  for variant in crn independent frozen v2 disc5 indfrozen; do
    run="$out/${variant}_s$seed"
    resume=(); [ -f "$run/checkpoint.pt" ] && resume=(--resume)
    # shellcheck disable=SC2086  # the variant's options are several words on purpose
    $sumo_rail train $overrides --demos "$demos" --policy mlp --directions "$directions" --iterations "$iterations" \
      --eval-every 0 --workers "$workers" --seed "$seed" ${variants[$variant]} --out "$run" "${resume[@]}"
    policies+=(--policy "$run/policy_latest.npz")
  done
  mkdir -p "$out/bc_s$seed" "$out/bcnorm_s$seed"
  echo '{}' > "$out/bc_s$seed/run.json"; echo '{}' > "$out/bcnorm_s$seed/run.json"  # names them bc_sN/...
  cp "$out/crn_s$seed/policy_bc.npz" "$out/bc_s$seed/policy_bc.npz"
  $python experiments/swap_normalizer.py "$out/crn_s$seed/policy_bc.npz" "$out/independent_s$seed/policy_latest.npz" \
    "$out/bcnorm_s$seed/policy_bc.npz"
  policies+=(--policy "$out/bc_s$seed/policy_bc.npz" --policy "$out/bcnorm_s$seed/policy_bc.npz")
done
# shellcheck disable=SC2086
[ -f "$out/validation.parquet" ] || $sumo_rail evaluate $overrides "${policies[@]}" --pool validation --seed 2000000 \
  --episodes "$validation_episodes" --workers "$workers" --out "$out/validation.parquet" > "$out/validation.txt"
# shellcheck disable=SC2086
[ -f "$out/test.parquet" ] || $sumo_rail evaluate $overrides "${policies[@]}" --seed 1000 --episodes "$test_episodes" \
  --workers "$workers" --out "$out/test.parquet" > "$out/test.txt"
for split in validation test; do
  $python experiments/ablation_table.py "$out/$split.parquet" | tee "$out/$split.md"
done
