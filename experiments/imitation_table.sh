#!/usr/bin/env bash
# The benchmark (issue 15): the expert, BC, RAIL (two-layer and linear), DAgger and GAIL, each trained with several
# seeds in the benchmark's observation setting (docs/results.md, "What the learner can see"), every policy evaluated
# on the same held-out test episodes; experiments/benchmark_table.py makes the tables and
# experiments/benchmark_plot.py the figure.
# Usage: experiments/imitation_table.sh [OUT_DIR]   (resumable: finished runs and evaluations are skipped, RAIL and
#   DAgger runs resume; a first pass with GAIL=0 gives every other method's table early, and a second with GAIL=1
#   trains GAIL and evaluates it apart on the same episodes, test_sSEED_gail.parquet)
#   (environment: SEEDS, KINDS (RAIL's and BC's policy shapes, default "mlp linear"), DEMOS_EPISODES, DIRECTIONS,
#   ITERATIONS, DAGGER (1 or 0), DAGGER_ROUNDS, ROUND_EPISODES, GAIL (1 or 0), TEST_EPISODES, WORKERS, REPORT_SEED
#   (whose runs `report` draws, default the first of SEEDS; "" for none), OVERRIDES: --set options of the setting,
#   default the lane-wise block; "" for the paper's, EXPERT: who is imitated, a style or a policy file (default
#   normal; a PPO driver from `sumo-rail ppo` gives the realizable benchmark, docs/results.md). More seeds of some
#   methods, e.g. RAIL and BC two-layer only:
#   SEEDS="3 4" KINDS=mlp DAGGER=0 GAIL=0 REPORT_SEED="" experiments/imitation_table.sh)
set -euo pipefail
out=${1:-results/imitation_table}
seeds=${SEEDS:-0 1 2}
kinds=${KINDS:-mlp linear}
demos_episodes=${DEMOS_EPISODES:-200}
directions=${DIRECTIONS:-32}
iterations=${ITERATIONS:-40}
dagger=${DAGGER:-1}
dagger_rounds=${DAGGER_ROUNDS:-5}
round_episodes=${ROUND_EPISODES:-20}
gail=${GAIL:-1}
test_episodes=${TEST_EPISODES:-250}
workers=${WORKERS:-2}
report_seed=${REPORT_SEED-${seeds%% *}}
overrides=${OVERRIDES---set observation.lane_block=1}
expert=${EXPERT:-normal}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
python=${PYTHON:-.venv/bin/python}
demos="$out/demos.parquet"
mkdir -p "$out"
# shellcheck disable=SC2086  # the overrides are several words on purpose
[ -f "$demos" ] || $sumo_rail record-expert $overrides --expert "$expert" --episodes "$demos_episodes" --seed 0 \
  --workers "$workers" --out "$demos"
for seed in $seeds; do
  policies=(--policy expert)
  gail_policies=()
  for kind in $kinds; do
    run="$out/rail_${kind}_s$seed"
    resume=(); [ -f "$run/checkpoint.pt" ] && resume=(--resume)
    # shellcheck disable=SC2086
    $sumo_rail train $overrides --demos "$demos" --policy "$kind" --directions "$directions" \
      --iterations "$iterations" --eval-every 10 --workers "$workers" --seed "$seed" --out "$run" "${resume[@]}"
    mkdir -p "$out/bc_${kind}_s$seed"  # BC as its own driver, bc_KIND_sSEED/policy_bc (run.json names it so)
    cp "$run/policy_bc.npz" "$out/bc_${kind}_s$seed/policy_bc.npz"
    cp "$run/run.json" "$out/bc_${kind}_s$seed/run.json"
    policies+=(--policy "$out/bc_${kind}_s$seed/policy_bc.npz" --policy "$run/policy_latest.npz")
  done
  if [ "$dagger" = 1 ]; then
    resume=(); [ -f "$out/dagger_s$seed/checkpoint.json" ] && resume=(--resume)
    # shellcheck disable=SC2086
    $sumo_rail dagger $overrides --demos "$demos" --rounds "$dagger_rounds" --episodes-per-round "$round_episodes" \
      --eval-every 0 --workers "$workers" --seed "$seed" --out "$out/dagger_s$seed" "${resume[@]}"
    policies+=(--policy "$out/dagger_s$seed/policy_latest.npz")
  fi
  if [ "$gail" = 1 ]; then
    # GAIL gets the decisions RAIL two-layer used with the same seed
    budget=$($python -c "import pandas as pd, sys; print(int(pd.read_parquet(sys.argv[1])['env_steps'].sum()))" \
      "$out/rail_mlp_s$seed/log.parquet")
    if [ ! -d "$out/gail_s$seed" ]; then  # a GAIL run cannot be resumed: train aside, keep only finished runs
      rm -rf "$out/gail_s$seed.partial"
      # shellcheck disable=SC2086
      $sumo_rail gail $overrides --demos "$demos" --policy mlp --timesteps "$budget" --envs "$workers" \
        --seed "$seed" --out "$out/gail_s$seed.partial"
      mv "$out/gail_s$seed.partial" "$out/gail_s$seed"
    fi
    gail_policies=(--policy "$out/gail_s$seed/policy_latest.npz" --sample-policy "$out/gail_s$seed/policy_latest.npz")
  fi
  if [ ! -f "$out/test_s$seed.parquet" ]; then
    # shellcheck disable=SC2086
    $sumo_rail evaluate $overrides --expert "$expert" "${policies[@]}" "${gail_policies[@]}" --seed 1000 \
      --episodes "$test_episodes" --workers "$workers" --out "$out/test_s$seed.parquet" > "$out/test_s$seed.txt"
  elif [ ${#gail_policies[@]} -gt 0 ] && [ ! -f "$out/test_s${seed}_gail.parquet" ] && ! $python -c \
      "import pandas as pd, sys; sys.exit(sys.argv[2] not in set(pd.read_parquet(sys.argv[1])['policy']))" \
      "$out/test_s$seed.parquet" "gail_s$seed/policy_latest"; then
    # a GAIL trained after the others' evaluation (a first pass with GAIL=0): evaluated apart, same episodes
    # shellcheck disable=SC2086
    $sumo_rail evaluate $overrides --expert "$expert" "${gail_policies[@]}" --seed 1000 --episodes "$test_episodes" \
      --workers "$workers" --out "$out/test_s${seed}_gail.parquet" > "$out/test_s${seed}_gail.txt"
  fi
done
$python experiments/benchmark_table.py "$out" | tee "$out/table.md"
$python experiments/benchmark_plot.py "$out" "$out/benchmark.png"
# learning curves, validation curves and the weight figures (first and second layer) of one seed's runs
if [ -n "$report_seed" ]; then
  runs=()
  for run in "$out/rail_mlp_s$report_seed" "$out/rail_linear_s$report_seed" "$out/gail_s$report_seed"; do
    [ -d "$run" ] && runs+=("$run")
  done
  $sumo_rail report "${runs[@]}" "$out/test_s$report_seed.parquet" --out "$out/report"
fi
