#!/usr/bin/env bash
# GAIL's choices (issue 15): GAIL with every choice on (the defaults), then with each switched off in turn, for
# several training seeds; every policy is evaluated on validation episodes by its argmax and by sampling from it
# (experiments/gail_choices_table.py).
# Usage: experiments/gail_choices.sh DEMOS.parquet [OUT_DIR]   (resumable: finished runs are skipped)
#   (environment: TIMESTEPS, SEEDS, VALIDATION_EPISODES, ENVS, WORKERS, and OVERRIDES: --set options matching how
#   DEMOS was recorded, for example "--set observation.lane_block=1")
set -euo pipefail
demos=$1
out=${2:-results/gail_choices}
timesteps=${TIMESTEPS:-100000}
seeds=${SEEDS:-0 1 2}
validation_episodes=${VALIDATION_EPISODES:-60}
envs=${ENVS:-2}
workers=${WORKERS:-2}
overrides=${OVERRIDES:-}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
python=${PYTHON:-.venv/bin/python}
declare -A variants=(
  [all]=""                           # every choice on
  [nonorm]="--no-normalize-reward"   # PPO on the raw (padded) discriminator rewards
  [nowarmup]="--critic-warmup 0"     # the actor moves from the first update
)
mkdir -p "$out"
policies=(--policy expert)
for seed in $seeds; do
  for variant in all nonorm nowarmup; do
    run="$out/${variant}_s$seed"
    if [ ! -d "$run" ]; then  # a GAIL run cannot be resumed: train aside, keep only finished runs
      rm -rf "$run.partial"
      # shellcheck disable=SC2086  # the overrides and the variant's options are several words on purpose
      $sumo_rail gail $overrides --demos "$demos" --policy mlp --timesteps "$timesteps" --envs "$envs" \
        --seed "$seed" ${variants[$variant]} --out "$run.partial"
      mv "$run.partial" "$run"
    fi
    policies+=(--policy "$run/policy_latest.npz" --sample-policy "$run/policy_latest.npz")
  done
  policies+=(--policy "$out/all_s$seed/policy_bc.npz")  # BC, the same start for every variant of this seed
done
# shellcheck disable=SC2086
[ -f "$out/validation.parquet" ] || $sumo_rail evaluate $overrides "${policies[@]}" --pool validation \
  --seed 2000000 --episodes "$validation_episodes" --workers "$workers" --out "$out/validation.parquet" \
  > "$out/validation.txt"
$python experiments/gail_choices_table.py "$out/validation.parquet" | tee "$out/validation.md"
