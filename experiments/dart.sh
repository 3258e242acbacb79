#!/usr/bin/env bash
# DART (issue 36): BC on demonstrations recorded while noise perturbs what the car executes (record-expert
# --dart-noise EPSILON: with probability epsilon a uniformly random action; the labels stay the expert's).
# 1. The noise level, on validation episodes: for each EPSILON of LEVELS, 200 noisy expert episodes (recording seeds
#    from 0, as the benchmark's demonstrations), BC with training seed 0 (`dagger --rounds 0`: the benchmark's BC),
#    evaluated on VALIDATION_EPISODES episodes of the validation pool (seeds from 2000); epsilon 0 is the benchmark's
#    own BC of seed 0. The rule (experiments/dart_choose.py): the level whose BC agrees most with the expert there.
# 2. The DART row: BC with training seeds SEEDS on the chosen level's recording (the same budget as BC: one recording
#    of 200 episodes, one BC per seed), each evaluated on the benchmark's test episodes (seeds from 1000, 250),
#    test_sSEED.parquet, to be paired with the committed runs (experiments/dart_table.py).
# Usage: experiments/dart.sh [OUT_DIR]   (resumable: finished files are skipped)
#   (environment: LEVELS, SEEDS, DEMOS_EPISODES, VALIDATION_EPISODES, TEST_EPISODES, WORKERS, BENCH (the committed
#   benchmark runs), SUMO_RAIL, PYTHON)
set -euo pipefail
out=${1:-results/dart}
levels=${LEVELS:-0.1 0.2 0.3}
seeds=${SEEDS:-0 1 2 3 4}
demos_episodes=${DEMOS_EPISODES:-200}
validation_episodes=${VALIDATION_EPISODES:-100}
test_episodes=${TEST_EPISODES:-250}
workers=${WORKERS:-2}
bench=${BENCH:-docs/results/imitation_table/data}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
python=${PYTHON:-.venv/bin/python}
overrides=(--set observation.lane_block=1)
mkdir -p "$out"
validate() {  # validate POLICY OUT: the policy on the validation episodes
  [ -f "$2" ] || $sumo_rail evaluate "${overrides[@]}" --policy "$1" --pool validation --seed 2000 \
    --episodes "$validation_episodes" --workers "$workers" --out "$2" > "${2%.parquet}.txt"
}
bc() {  # bc DEMOS SEED RUN: BC alone (dagger without rounds), a run left unfinished started again
  [ -f "$3/policy_bc.npz" ] && return
  rm -rf "$3"
  $sumo_rail dagger "${overrides[@]}" --demos "$1" --rounds 0 --eval-every 0 --seed "$2" --out "$3"
}
validate "$bench/bc_mlp_s0/policy_bc.npz" "$out/validation_eps0.parquet"
for level in $levels; do
  demos="$out/demos_eps$level.parquet"
  [ -f "$demos" ] || $sumo_rail record-expert "${overrides[@]}" --dart-noise "$level" --episodes "$demos_episodes" \
    --seed 0 --workers "$workers" --out "$demos"
  bc "$demos" 0 "$out/bc_eps${level}_s0"
  validate "$out/bc_eps${level}_s0/policy_bc.npz" "$out/validation_eps$level.parquet"
done
chosen=$($python experiments/dart_choose.py "$out" | tee "$out/choice.txt" | tail -1)
for seed in $seeds; do
  run="$out/dart_s$seed"
  bc "$out/demos_eps$chosen.parquet" "$seed" "$run"
  [ -f "$out/test_s$seed.parquet" ] || $sumo_rail evaluate "${overrides[@]}" --policy "$run/policy_bc.npz" \
    --seed 1000 --episodes "$test_episodes" --workers "$workers" --out "$out/test_s$seed.parquet" > "$out/test_s$seed.txt"
done
