#!/usr/bin/env bash
# The paper's directions sweep (issue 15): RAIL learning curves for N in {8, 16, 32, 64, 128}, several training
# seeds, validation agreement every few iterations; experiments/directions_plot.py draws the curves (validation
# agreement first, the discriminator's return beside it) and projects N = 512.
# Usage: experiments/directions_sweep.sh DEMOS.parquet [OUT_DIR]   (resumable: runs resume, and a larger ITERATIONS
#   continues finished runs)
#   (environment: SIZES, SEEDS, ITERATIONS, EVAL_EVERY, EVAL_EPISODES, BC_EPOCHS (default 0: from zero weights, as
#   in the paper), STEP_SIZE, WORKERS, OVERRIDES: --set options matching how DEMOS was recorded, PUBLISH: a folder
#   that receives each run's run.json, checkpoint.pt, log.parquet and policy_latest.npz and the figure and table,
#   e.g. docs/results/directions_sweep; copied back into OUT_DIR, the runs continue in another session), EGOS and
#   ROLLOUT_DECISIONS (default: one ego, whole episodes; EGOS=8 ROLLOUT_DECISIONS=171 runs the rollouts on 8
#   respawning egos, as experiments/paper_scale.sh, in run folders nN_k8r_sSEED)
set -euo pipefail
demos=$1
out=${2:-results/directions_sweep}
sizes=${SIZES:-8 16 32 64 128}
seeds=${SEEDS:-0 1}
iterations=${ITERATIONS:-30}
eval_every=${EVAL_EVERY:-5}
eval_episodes=${EVAL_EPISODES:-20}
bc_epochs=${BC_EPOCHS:-0}
step_size=${STEP_SIZE:-0.02}
workers=${WORKERS:-2}
egos=${EGOS:-1}
rollout_decisions=${ROLLOUT_DECISIONS:-}
tag=""; budget=()
if [ "$egos" != 1 ]; then
  tag="_k${egos}"; [ -n "$rollout_decisions" ] && { tag="${tag}r"; budget=(--rollout-decisions "$rollout_decisions"); }
fi
overrides=${OVERRIDES---set observation.lane_block=1}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
python=${PYTHON:-.venv/bin/python}
mkdir -p "$out"
for seed in $seeds; do
  for n in $sizes; do
    run="$out/n${n}${tag}_s$seed"
    resume=(); [ -f "$run/checkpoint.pt" ] && resume=(--resume)
    # shellcheck disable=SC2086  # the overrides are several words on purpose
    $sumo_rail train $overrides --demos "$demos" --policy mlp --bc-epochs "$bc_epochs" --directions "$n" \
      --step-size "$step_size" --iterations "$iterations" --eval-every "$eval_every" --eval-episodes "$eval_episodes" \
      --workers "$workers" --egos "$egos" "${budget[@]}" --seed "$seed" --out "$run" "${resume[@]}"
  done
done
$python experiments/directions_plot.py "$out" | tee "$out/table.md"  # every run in OUT_DIR
if [ -n "${PUBLISH:-}" ]; then
  for seed in $seeds; do
    for n in $sizes; do
      mkdir -p "$PUBLISH/n${n}${tag}_s$seed"
      cp "$out/n${n}${tag}_s$seed"/{run.json,checkpoint.pt,log.parquet,policy_latest.npz} "$PUBLISH/n${n}${tag}_s$seed/"
    done
  done
  cp "$out/directions.png" "$out/table.md" "$PUBLISH/"
fi
