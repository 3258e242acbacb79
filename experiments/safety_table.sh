#!/usr/bin/env bash
# The safety measures of a benchmark's committed policies (issue 36): the expert and METHODS (of bc, rail: two-layer,
# dagger and gail: argmax and sampled) of BENCH evaluated again on the benchmark's test episodes (seeds from 1000,
# 250 episodes) by an `evaluate` that writes the safety columns; every other column reproduces the committed
# evaluation. The realizable benchmark: BENCH=docs/results/realizable_ppo/data
# EXPERT=docs/results/realizable_ppo/data/ppo_expert/policy_latest.npz METHODS="bc rail dagger gail".
# Usage: experiments/safety_table.sh [OUT_DIR]   (resumable: finished evaluations are skipped)
#   (environment: SEEDS (default "0 1 2"), TEST_EPISODES, WORKERS, BENCH (the committed runs), EXPERT (a style or a
#   policy file, default the benchmark's rule expert), METHODS (default "bc rail dagger"), SUMO_RAIL)
set -euo pipefail
out=${1:-results/safety}
seeds=${SEEDS:-0 1 2}
test_episodes=${TEST_EPISODES:-250}
workers=${WORKERS:-2}
bench=${BENCH:-docs/results/imitation_table/data}
expert=${EXPERT:-normal}
methods=" ${METHODS:-bc rail dagger} "
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
mkdir -p "$out"
first=${seeds%% *}
for seed in $seeds; do
  policies=()
  [ "$seed" = "$first" ] && policies+=(--policy expert)  # the expert does not depend on a training seed
  [[ $methods = *" bc "* ]] && policies+=(--policy "$bench/bc_mlp_s$seed/policy_bc.npz")
  [[ $methods = *" rail "* ]] && policies+=(--policy "$bench/rail_mlp_s$seed/policy_latest.npz")
  [[ $methods = *" dagger "* ]] && [ -d "$bench/dagger_s$seed" ] && policies+=(--policy "$bench/dagger_s$seed/policy_latest.npz")
  [[ $methods = *" gail "* ]] && policies+=(--policy "$bench/gail_s$seed/policy_latest.npz"
                                           --sample-policy "$bench/gail_s$seed/policy_latest.npz")
  [ -f "$out/test_s$seed.parquet" ] || $sumo_rail evaluate --set observation.lane_block=1 --expert "$expert" \
    "${policies[@]}" --seed 1000 --episodes "$test_episodes" --workers "$workers" --out "$out/test_s$seed.parquet" \
    > "$out/test_s$seed.txt"
done
