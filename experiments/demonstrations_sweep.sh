#!/usr/bin/env bash
# The paper's figure of expert trajectories (issue 15): BC, RAIL and DAgger trained on 5 to 200 expert episodes,
# several seeds each, in the benchmark's setting; every policy evaluated on the same test episodes;
# experiments/demonstrations_plot.py draws agreement against the number of demonstrations. The BC that starts RAIL
# gets the same number of gradient steps at every count (BC_PASSES / count epochs: 20 epochs at 200 episodes), as
# train's fixed 20 epochs leave it under-trained on a few episodes (docs/results.md); DAgger keeps its defaults.
# Usage: experiments/demonstrations_sweep.sh [OUT_DIR]   (resumable: finished recordings, runs and evaluations
#   are skipped, RAIL and DAgger runs resume)
#   (environment: COUNTS, SEEDS, BC_PASSES, DIRECTIONS, ITERATIONS, DAGGER_ROUNDS, ROUND_EPISODES, TEST_EPISODES,
#   WORKERS, OVERRIDES: --set options of the setting, default the lane-wise block; "" for the paper's)
set -euo pipefail
out=${1:-results/demonstrations_sweep}
counts=${COUNTS:-5 10 20 40 100 200}
seeds=${SEEDS:-0 1 2}
bc_passes=${BC_PASSES:-4000}
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
for count in $counts; do
  demos="$out/demos_$count.parquet"  # episode k of every recording is the same episode (seeded by its index)
  # shellcheck disable=SC2086  # the overrides are several words on purpose
  [ -f "$demos" ] || $sumo_rail record-expert $overrides --episodes "$count" --seed 0 --workers "$workers" \
    --out "$demos"
  policies=(--policy expert)
  bc_epochs=$(( (bc_passes + count - 1) / count ))
  for seed in $seeds; do
    train_learners "$demos" "$out" "k$count" "$seed"
  done
  # shellcheck disable=SC2086
  [ -f "$out/test_k$count.parquet" ] || $sumo_rail evaluate $overrides "${policies[@]}" --seed 1000 \
    --episodes "$test_episodes" --workers "$workers" --out "$out/test_k$count.parquet" > "$out/test_k$count.txt"
done
# shellcheck disable=SC2086
$python experiments/demonstrations_plot.py "$out" $counts | tee "$out/table.md"
