#!/usr/bin/env bash
# Style fidelity (issue 15, beyond the paper): BC, RAIL and DAgger trained on calm and on sporty demonstrations,
# several seeds, in the benchmark's setting; every policy and both experts on the same test episodes, each policy's
# agreement measured against the style it learned from; experiments/style_table.py says whether each learner is
# closer to its own expert than to the other.
# Usage: experiments/style_fidelity.sh [OUT_DIR]   (resumable: finished recordings, runs and evaluations are skipped)
#   (environment: SEEDS, EPISODES, BC_EPOCHS, DIRECTIONS, ITERATIONS, DAGGER_ROUNDS, ROUND_EPISODES, TEST_EPISODES,
#   WORKERS, OVERRIDES: --set options of the setting, default the lane-wise block; "" for the paper's)
set -euo pipefail
out=${1:-results/style_fidelity}
seeds=${SEEDS:-0 1 2}
episodes=${EPISODES:-200}
bc_epochs=${BC_EPOCHS:-20}
directions=${DIRECTIONS:-32}
iterations=${ITERATIONS:-20}
dagger_rounds=${DAGGER_ROUNDS:-5}
round_episodes=${ROUND_EPISODES:-20}
test_episodes=${TEST_EPISODES:-250}
workers=${WORKERS:-2}
overrides=${OVERRIDES---set observation.lane_block=1}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
python=${PYTHON:-.venv/bin/python}
# shellcheck source=experiments/learners.sh
source "$(dirname "$0")/learners.sh"
mkdir -p "$out"
policies=(--policy expert:calm --policy expert:sporty)
for style in calm sporty; do
  demos="$out/demos_$style.parquet"
  # shellcheck disable=SC2086  # the overrides are several words on purpose
  [ -f "$demos" ] || $sumo_rail record-expert $overrides --style "$style" --episodes "$episodes" --seed 0 \
    --workers "$workers" --out "$demos"
  for seed in $seeds; do
    train_learners "$demos" "$out" "$style" "$seed"
  done
done
# shellcheck disable=SC2086
[ -f "$out/test.parquet" ] || $sumo_rail evaluate $overrides "${policies[@]}" --seed 1000 \
  --episodes "$test_episodes" --workers "$workers" --out "$out/test.parquet" > "$out/test.txt"
$python experiments/style_table.py "$out/test.parquet" | tee "$out/table.md"
