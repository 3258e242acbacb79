#!/usr/bin/env bash
# What sharing the road does to learning (issue 28): RAIL, DAgger and GAIL trained with K egos per simulation, in the
# benchmark's setting and with its settings and seeds, against the benchmark's committed K = 1 runs of the same seeds
# (docs/results/imitation_table/data: rail_mlp_sSEED, dagger_sSEED, gail_sSEED; GAIL with its decisions); the K runs are
# evaluated on the benchmark's test
# episodes (seed 1000, 250 episodes, one ego each), which the committed K = 1 evaluations drove, and
# experiments/shared_road_table.py pairs them seed by seed and episode by episode.
# Usage: experiments/shared_road.sh DEMOS.parquet [OUT_DIR]   (DEMOS: the benchmark's demonstrations; resumable)
#   (environment: EGOS (8), SEEDS (0 1 2), DAGGER (1 or 0), GAIL (1 or 0), TEST_EPISODES (250), WORKERS (2),
#   RAIL_OPTIONS: more train options, e.g. "--rollout-decisions 171" for RAIL's rollouts on respawning egos with
#   the committed runs' decisions (issue 34: 171 a rollout, 437,760 in 40 iterations))
set -euo pipefail
demos=$1
out=${2:-results/shared_road}
egos=${EGOS:-8}
seeds=${SEEDS:-0 1 2}
dagger_runs=${DAGGER:-1}
gail=${GAIL:-1}
rail_options=${RAIL_OPTIONS:-}
test_episodes=${TEST_EPISODES:-250}
workers=${WORKERS:-2}
overrides="--set observation.lane_block=1"
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
python=${PYTHON:-.venv/bin/python}
committed=docs/results/imitation_table/data
mkdir -p "$out"
policies=()
gail_policies=()
for seed in $seeds; do
  rail="$out/rail_k${egos}_s$seed"
  resume=(); [ -f "$rail/checkpoint.pt" ] && resume=(--resume)
  # shellcheck disable=SC2086  # the overrides and options are several words on purpose
  $sumo_rail train $overrides --demos "$demos" --policy mlp --directions 32 --iterations 40 --eval-every 0 \
    --egos "$egos" $rail_options --workers "$workers" --seed "$seed" --out "$rail" "${resume[@]}"
  policies+=(--policy "$rail/policy_latest.npz")
  if [ "$dagger_runs" = 1 ]; then
    dagger="$out/dagger_k${egos}_s$seed"
    resume=(); [ -f "$dagger/checkpoint.json" ] && resume=(--resume)
    # shellcheck disable=SC2086
    $sumo_rail dagger $overrides --demos "$demos" --rounds 5 --episodes-per-round 20 --eval-every 0 --egos "$egos" \
      --workers "$workers" --seed "$seed" --out "$dagger" "${resume[@]}"
    policies+=(--policy "$dagger/policy_latest.npz")
  fi
  if [ "$gail" = 1 ]; then
    gail_run="$out/gail_k${egos}_s$seed"
    budget=$($python -c "import pandas as pd, sys; print(int(pd.read_parquet(sys.argv[1])['env_steps'].sum()))" \
      "$committed/gail_s$seed/log.parquet")
    if [ ! -d "$gail_run" ]; then  # a GAIL run cannot be resumed: train aside, keep only finished runs
      rm -rf "$gail_run.partial"
      # shellcheck disable=SC2086
      # the K = 1 run's update size, 512 decisions x envs, split among the egos: the same updates of the same size
      $sumo_rail gail $overrides --demos "$demos" --policy mlp --timesteps "$budget" --envs "$workers" \
        --egos "$egos" --n-steps $((512 / egos)) --seed "$seed" --out "$gail_run.partial"
      mv "$gail_run.partial" "$gail_run"
    fi
    gail_policies+=(--policy "$gail_run/policy_latest.npz" --sample-policy "$gail_run/policy_latest.npz")
  fi
done
# shellcheck disable=SC2086
[ -f "$out/test_k$egos.parquet" ] || $sumo_rail evaluate $overrides "${policies[@]}" --seed 1000 \
  --episodes "$test_episodes" --workers "$workers" --out "$out/test_k$egos.parquet" > "$out/test_k$egos.txt"
# GAIL's policies apart (trained last, added to the experiment later)
if [ "$gail" = 1 ] && [ ! -f "$out/test_k${egos}_gail.parquet" ]; then
  # shellcheck disable=SC2086
  $sumo_rail evaluate $overrides "${gail_policies[@]}" --seed 1000 --episodes "$test_episodes" --workers "$workers" \
    --out "$out/test_k${egos}_gail.parquet" > "$out/test_k${egos}_gail.txt"
fi
gail_test=(); [ -f "$out/test_k${egos}_gail.parquet" ] && gail_test=("$out/test_k${egos}_gail.parquet")
$python experiments/shared_road_table.py "$egos" "$out/test_k$egos.parquet" "${gail_test[@]}" \
  $committed/test_s*[0-9].parquet \
  | tee "$out/table.md"
