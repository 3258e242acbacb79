#!/usr/bin/env bash
# RAIL at the paper's scale (issue 34): N = 512 directions from the benchmark's BC (two-layer), nu 0.03, the
# benchmark's observation setting and demonstrations (experiments/imitation_table.sh), validation agreement every
# EVAL_EVERY iterations; experiments/directions_plot.py draws the curve beside the directions sweep's.
# Usage: experiments/paper_scale.sh DEMOS.parquet [OUT_DIR]   (resumable: a run with a checkpoint resumes, and a
#   larger ITERATIONS continues a finished one)
#   (environment: SEEDS (0), STEP_SIZES (0.02: train's default; the paper's is 0.001), DIRECTIONS (512), ITERATIONS,
#   EVAL_EVERY, EVAL_EPISODES, WORKERS, EGOS (8) and ROLLOUT_DECISIONS (171, the benchmark's mean decisions a
#   rollout; "" for whole episodes): rollouts on respawning egos, TAG (the run folder's: k8r), OVERRIDES: --set
#   options matching how DEMOS was recorded)
set -euo pipefail
demos=$1
out=${2:-results/paper_scale}
seeds=${SEEDS:-0}
step_sizes=${STEP_SIZES:-0.02}
directions=${DIRECTIONS:-512}
iterations=${ITERATIONS:-40}
eval_every=${EVAL_EVERY:-5}
eval_episodes=${EVAL_EPISODES:-20}
workers=${WORKERS:-2}
egos=${EGOS:-8}
rollout_decisions=${ROLLOUT_DECISIONS-171}
tag=${TAG:-k8r}
overrides=${OVERRIDES---set observation.lane_block=1}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
mkdir -p "$out"
for seed in $seeds; do
  for alpha in $step_sizes; do
    run="$out/n${directions}_a${alpha}_${tag}_s$seed"
    budget=(); [ -n "$rollout_decisions" ] && budget=(--rollout-decisions "$rollout_decisions")
    resume=(); [ -f "$run/checkpoint.pt" ] && resume=(--resume)
    # shellcheck disable=SC2086  # the overrides are several words on purpose
    $sumo_rail train $overrides --demos "$demos" --policy mlp --directions "$directions" --step-size "$alpha" \
      --iterations "$iterations" --eval-every "$eval_every" --eval-episodes "$eval_episodes" --workers "$workers" \
      --egos "$egos" "${budget[@]}" --seed "$seed" --out "$run" "${resume[@]}"
  done
done
