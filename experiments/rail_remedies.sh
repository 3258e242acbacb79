#!/usr/bin/env bash
# RAIL's remedies on validation episodes (issue 25): each variant trains from the benchmark's BC (same demonstrations,
# BC seed = training seed) with the benchmark's decision budget, then every policy and BC are evaluated on the same
# validation episodes; experiments/remedies_table.py pairs each variant with BC, seed by seed. The paper's setting
# (variant "paper") is the benchmark's committed RAIL run of the same seed, not retrained.
# Usage: experiments/rail_remedies.sh DEMOS.parquet [OUT_DIR]   (resumable: finished runs are skipped, runs resume)
#   (environment: SEEDS (0 1 2), VARIANTS (names below, in order), VALIDATION_EPISODES (100), WORKERS (2),
#   OVERRIDES (default the lane block), DECISIONS (iterations are set so a run drives about the benchmark's 40
#   iterations x 2N x 1 episode; a variant with E episodes per rollout gets 40 / E iterations))
set -euo pipefail
demos=$1
out=${2:-results/rail_remedies}
seeds=${SEEDS:-0 1 2}
validation_episodes=${VALIDATION_EPISODES:-100}
workers=${WORKERS:-2}
overrides=${OVERRIDES---set observation.lane_block=1}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
committed=docs/results/imitation_table/data
declare -A variants=(  # options on top of train's defaults (N = 32, b = 16, alpha = 0.02, nu 0.03, 1 episode)
  [agreement]="--reward agreement"
  [agreement_flip20]="--reward agreement --flip-rate 0.2"
  [agreement_flip20_ep4]="--reward agreement --flip-rate 0.2 --episodes-per-rollout 4"
  [flip20]="--flip-rate 0.2"
  [flip20_ep4]="--flip-rate 0.2 --episodes-per-rollout 4"
  [ep4]="--episodes-per-rollout 4"
  [balanced_flip20]="--flip-rate 0.2 --disc-balance 1"
  [rank_flip20]="--flip-rate 0.2 --fitness rank"
)
order=${VARIANTS:-agreement agreement_flip20 flip20 balanced_flip20 agreement_flip20_ep4 flip20_ep4}
mkdir -p "$out"
policies=()
for seed in $seeds; do
  mkdir -p "$out/bc_s$seed" "$out/paper_s$seed"
  cp "$committed/bc_mlp_s$seed/policy_bc.npz" "$committed/bc_mlp_s$seed/run.json" "$out/bc_s$seed/"
  cp "$committed/rail_mlp_s$seed/policy_latest.npz" "$committed/rail_mlp_s$seed/run.json" "$out/paper_s$seed/"
  policies+=(--policy "$out/bc_s$seed/policy_bc.npz" --policy "$out/paper_s$seed/policy_latest.npz")
done
for variant in $order; do
  options=${variants[$variant]}
  episodes=1; [[ $options =~ --episodes-per-rollout\ ([0-9]+) ]] && episodes=${BASH_REMATCH[1]}
  for seed in $seeds; do
    run="$out/${variant}_s$seed"
    resume=(); [ -f "$run/checkpoint.pt" ] && resume=(--resume)
    # shellcheck disable=SC2086  # the overrides and options are several words on purpose
    $sumo_rail train $overrides --demos "$demos" --iterations $((40 / episodes)) --eval-every 0 --workers "$workers" \
      --seed "$seed" $options --out "$run" "${resume[@]}" 2>> "$out/train.log"
    policies+=(--policy "$run/policy_latest.npz")
  done
done
name=validation_$(echo "$order" | tr ' ' '+' | md5sum | cut -c1-8)
# shellcheck disable=SC2086
[ -f "$out/$name.parquet" ] || $sumo_rail evaluate $overrides --policy expert "${policies[@]}" --pool validation \
  --seed 2000000 --episodes "$validation_episodes" --workers "$workers" --out "$out/$name.parquet" > "$out/$name.txt"
ln -sf "$name.parquet" "$out/validation.parquet"
