#!/usr/bin/env bash
# RAIL started from DART (issue 36): `train` (RAIL with the benchmark's settings) on the DART recording of
# experiments/dart.sh, so its BC start is the DART policy of the same seed; each run evaluated on the benchmark's test
# episodes (seeds from 1000), test_sSEED.parquet, paired with the committed runs by experiments/dart_table.py.
# Usage: experiments/dart_rail.sh DART_DIR [OUT_DIR]   (resumable: runs resume, finished evaluations are skipped)
#   (environment: SEEDS (default "0 1 2"), EPSILON (the chosen level, default: DART_DIR/choice.txt's), DIRECTIONS,
#   ITERATIONS, TEST_EPISODES, WORKERS, EGOS (8) and ROLLOUT_DECISIONS (171): rollouts on respawning egos, as
#   `train --egos 8 --rollout-decisions 171` (the same learning as one ego a SUMO, docs/results.md "RAIL's
#   rollouts on respawning egos", at a quarter of the core-seconds); EGOS=1 ROLLOUT_DECISIONS="" for the
#   benchmark's own form, SUMO_RAIL)
set -euo pipefail
dart=$1
out=${2:-$dart/rail}
seeds=${SEEDS:-0 1 2}
epsilon=${EPSILON:-$(tail -1 "$dart/choice.txt")}
directions=${DIRECTIONS:-32}
iterations=${ITERATIONS:-40}
test_episodes=${TEST_EPISODES:-250}
workers=${WORKERS:-2}
egos=${EGOS:-8}
rollout_decisions=${ROLLOUT_DECISIONS-171}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
mkdir -p "$out"
for seed in $seeds; do
  run="$out/rail_dart_s$seed"
  resume=(); [ -f "$run/checkpoint.pt" ] && resume=(--resume)
  budget=(); [ -n "$rollout_decisions" ] && budget=(--rollout-decisions "$rollout_decisions")
  $sumo_rail train --set observation.lane_block=1 --demos "$dart/demos_eps$epsilon.parquet" --policy mlp \
    --directions "$directions" --iterations "$iterations" --eval-every 10 --workers "$workers" --egos "$egos" \
    "${budget[@]}" --seed "$seed" --out "$run" "${resume[@]}"
  [ -f "$out/test_s$seed.parquet" ] || $sumo_rail evaluate --set observation.lane_block=1 \
    --policy "$run/policy_latest.npz" --seed 1000 --episodes "$test_episodes" --workers "$workers" \
    --out "$out/test_s$seed.parquet" > "$out/test_s$seed.txt"
done
