#!/usr/bin/env bash
# The generalisation table (issue 35, docs/results.md "Roads the drivers never saw"): on every road, the expert's
# demonstrations, then BC and DAgger (one `dagger` run gives both: its policy_bc.npz is the BC row) and RAIL (the
# benchmark's settings, N = 32 for 40 iterations on 8 respawning egos a road, from the road's BC) with several seeds,
# in the recommended setting with the route block; every driver evaluated on the same held-out test episodes of
# (a) the road it was trained on (RAIL's in rail_a_KIND: the straight road's before (b), the other roads' last),
# (b) for the straight road's drivers (RAIL's included), every other road and two traffic densities it never saw,
# (c) BC, DAgger and RAIL trained on a mix of every road (demonstrations of each; DAgger's rounds and RAIL's
# directions on each road in turn, `--roads`; RAIL_MIX=0 skips RAIL's), on each road, (d) without the route
# block on each road with a feature (what lacking it costs; NO_ROUTE=0 skips it), and (f) GAIL trained and tested on
# each road (GAIL=1; with RAIL's decisions of the same seed on 8 respawning egos a process; after RAIL's (a) runs).
# experiments/generalisation_table.py makes the tables and the figure.
# Usage: experiments/generalisation.sh [OUT_DIR]   (resumable: what is written is skipped, DAgger runs resume)
#   (environment: KINDS, SEEDS, DEMOS_EPISODES, MIX_EPISODES (per road), DAGGER_ROUNDS, ROUND_EPISODES,
#   TEST_EPISODES, DENSITIES (veh/h), RAIL_KINDS (default every road; "" skips RAIL), RAIL_MIX, RAIL_ITERATIONS,
#   GAIL (default 0), WORKERS)
# The expert drives the test episodes once, in each road's (a) evaluation (and in each density's): the other files
# hold the learners only, on the same episodes (the table pairs them by episode seed).
set -euo pipefail
out=${1:-results/generalisation}
kinds=${KINDS:-straight merge merge_from_ramp lane_drop exit}
seeds=${SEEDS:-0 1 2}
demos_episodes=${DEMOS_EPISODES:-100}
mix_episodes=${MIX_EPISODES:-20}
dagger_rounds=${DAGGER_ROUNDS:-5}
round_episodes=${ROUND_EPISODES:-20}
test_episodes=${TEST_EPISODES:-100}
densities=${DENSITIES:-2000 6000}
rail_kinds=${RAIL_KINDS-$kinds}
rail_iterations=${RAIL_ITERATIONS:-40}
workers=${WORKERS:-2}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
python=${PYTHON:-.venv/bin/python}
setting=(--preset recommended --set observation.lane_block=1 --set observation.route_block=1)
mkdir -p "$out"
evaluate() {  # evaluate OUT_FILE KIND EPISODES [--set ...] --policy ...
  local file=$1 kind=$2 episodes=$3; shift 3
  [ -f "$file" ] || $sumo_rail evaluate "${setting[@]}" --set "scenario.kind=$kind" --episodes "$episodes" \
    --seed 1000 --workers "$workers" --out "$file" "$@"
}
drivers() {  # the policies trained on KIND: BC and DAgger, and RAIL where it is trained
  local kind=$1 seed
  for seed in $seeds; do
    printf -- '--policy %s --policy %s ' "$out/$kind/dagger_s$seed/policy_bc.npz" "$out/$kind/dagger_s$seed/policy_latest.npz"
    [ -f "$out/$kind/rail_s$seed/.done" ] && printf -- '--policy %s ' "$out/$kind/rail_s$seed/policy_latest.npz"
  done
  return 0
}
rail() {  # rail KIND DEMOS [OPTION ...]: RAIL (three seeds) into OUT/KIND, from DEMOS' BC
  local kind=$1 demos=$2 seed run resume; shift 2
  for seed in $seeds; do
    run="$out/$kind/rail_s$seed"
    resume=(); [ -f "$run/checkpoint.pt" ] && resume=(--resume)
    [ -f "$run/.done" ] || $sumo_rail train "${setting[@]}" --demos "$demos" --policy mlp --directions 32 \
      --iterations "$rail_iterations" --eval-every 0 --egos 8 --rollout-decisions 171 --workers "$workers" \
      --seed "$seed" --out "$run" "${resume[@]}" "$@"
    touch "$run/.done"
  done
}
rail_drivers() {  # the RAIL policies trained on KIND
  local kind=$1 seed
  for seed in $seeds; do printf -- '--policy %s ' "$out/$kind/rail_s$seed/policy_latest.npz"; done
}
in_rail_kinds() { [[ " $rail_kinds " == *" $1 "* ]]; }
# (a) trained and tested on each road (BC and DAgger; RAIL of the straight road too, before (b) uses it)
for kind in $kinds; do
  mkdir -p "$out/$kind"
  demos="$out/$kind/demos.parquet"
  [ -f "$demos" ] || $sumo_rail record-expert "${setting[@]}" --set "scenario.kind=$kind" --episodes "$demos_episodes" \
    --seed 0 --workers "$workers" --out "$demos"
  for seed in $seeds; do
    run="$out/$kind/dagger_s$seed"
    resume=(); [ -f "$run/checkpoint.json" ] && resume=(--resume)
    [ -f "$run/.done" ] || $sumo_rail dagger "${setting[@]}" --set "scenario.kind=$kind" --demos "$demos" \
      --rounds "$dagger_rounds" --episodes-per-round "$round_episodes" --eval-every 0 --workers "$workers" \
      --seed "$seed" --out "$run" "${resume[@]}"
    touch "$run/.done"  # finished: not resumed again
  done
  # shellcheck disable=SC2046  # the policies are several words on purpose
  evaluate "$out/a_$kind.parquet" "$kind" "$test_episodes" --policy expert $(drivers "$kind")
done
# RAIL of the straight road, tested as (a), before (b) takes it to the other roads
if in_rail_kinds straight; then
  rail straight "$out/straight/demos.parquet" --set scenario.kind=straight
  # shellcheck disable=SC2046
  evaluate "$out/rail_a_straight.parquet" straight "$test_episodes" $(rail_drivers straight)
fi
# (b) the straight road's drivers on every other road, and on the straight road at other densities
for kind in $kinds; do
  [ "$kind" = straight ] && continue
  # shellcheck disable=SC2046
  evaluate "$out/b_$kind.parquet" "$kind" "$test_episodes" $(drivers straight)
done
for flow in $densities; do
  # shellcheck disable=SC2046
  evaluate "$out/b_straight_$flow.parquet" straight "$test_episodes" --set "scenario.flow_veh_per_h=$flow" \
    --policy expert $(drivers straight)
done
# (c) BC, DAgger and RAIL trained on a mix of every road (demonstrations of each; DAgger's rounds and RAIL's
# directions on each road in turn)
mixed=()
for kind in $kinds; do
  part="$out/$kind/demos_mix.parquet"
  [ -f "$part" ] || $sumo_rail record-expert "${setting[@]}" --set "scenario.kind=$kind" --episodes "$mix_episodes" \
    --seed 500 --workers "$workers" --out "$part"
  mixed+=("$part")
done
[ -f "$out/mix_demos.parquet" ] || $python experiments/mix_demos.py "$out/mix_demos.parquet" "${mixed[@]}"
roads=$(echo $kinds | tr ' ' ,)
for seed in $seeds; do
  run="$out/mix/dagger_s$seed"
  resume=(); [ -f "$run/checkpoint.json" ] && resume=(--resume)
  [ -f "$run/.done" ] || $sumo_rail dagger "${setting[@]}" --demos "$out/mix_demos.parquet" --roads "$roads" \
    --rounds "$dagger_rounds" --episodes-per-round "$round_episodes" --eval-every 0 --workers "$workers" \
    --seed "$seed" --out "$run" "${resume[@]}"
  touch "$run/.done"
done
for kind in $kinds; do
  # shellcheck disable=SC2046
  evaluate "$out/c_$kind.parquet" "$kind" "$test_episodes" $(drivers mix)
done
if [ "${RAIL_MIX:-1}" = 1 ] && [ -n "$rail_kinds" ]; then  # RAIL on the mix, tested as (c): rail_c_KIND.parquet
  rail mix "$out/mix_demos.parquet" --roads "$roads"
  for kind in $kinds; do
    # shellcheck disable=SC2046
    evaluate "$out/rail_c_$kind.parquet" "$kind" "$test_episodes" $(rail_drivers mix)
  done
fi
# (d) what the route block is worth: DAgger (and its BC) without it on every road with a feature, tested as (a)
if [ "${NO_ROUTE:-1}" = 1 ]; then
  for kind in $kinds; do
    [ "$kind" = straight ] && continue
    demos="$out/$kind/demos_no_route.parquet"  # the same episodes and decisions, without the route block
    [ -f "$demos" ] || $sumo_rail record-expert "${setting[@]}" --set observation.route_block=0 \
      --set "scenario.kind=$kind" --episodes "$demos_episodes" --seed 0 --workers "$workers" --out "$demos"
    policies=()
    for seed in $seeds; do
      run="$out/$kind/no_route_s$seed"
      resume=(); [ -f "$run/checkpoint.json" ] && resume=(--resume)
      [ -f "$run/.done" ] || $sumo_rail dagger "${setting[@]}" --set observation.route_block=0 \
        --set "scenario.kind=$kind" --demos "$demos" --rounds "$dagger_rounds" --episodes-per-round "$round_episodes" \
        --eval-every 0 --workers "$workers" --seed "$seed" --out "$run" "${resume[@]}"
      touch "$run/.done"
      policies+=(--policy "$run/policy_bc.npz" --policy "$run/policy_latest.npz")
    done
    evaluate "$out/d_$kind.parquet" "$kind" "$test_episodes" --set observation.route_block=0 "${policies[@]}"
  done
fi
# (e) RAIL trained on each other road of RAIL_KINDS, tested as (a) on the same episodes: rail_a_KIND.parquet
for kind in $rail_kinds; do
  [ "$kind" = straight ] && continue
  rail "$kind" "$out/$kind/demos.parquet" --set "scenario.kind=$kind"
  # shellcheck disable=SC2046
  evaluate "$out/rail_a_$kind.parquet" "$kind" "$test_episodes" $(rail_drivers "$kind")
done
# (f) GAIL trained on each road with the decisions RAIL used there with the same seed, tested as (a) on the same
# episodes: gail_a_KIND.parquet
if [ "${GAIL:-0}" = 1 ]; then
  for kind in $rail_kinds; do
    policies=()
    for seed in $seeds; do
      run="$out/$kind/gail_s$seed"
      budget=$($python -c "import pandas as pd, sys; print(int(pd.read_parquet(sys.argv[1])['env_steps'].sum()))" \
        "$out/$kind/rail_s$seed/log.parquet")
      resume=(); [ -f "$run/checkpoint.pt" ] && resume=(--resume)
      [ -f "$run/.done" ] || $sumo_rail gail "${setting[@]}" --set "scenario.kind=$kind" \
        --demos "$out/$kind/demos.parquet" --policy mlp --timesteps "$budget" --envs "$workers" --egos 8 \
        --n-steps 64 --seed "$seed" --out "$run" "${resume[@]}"
      touch "$run/.done"
      policies+=(--policy "$run/policy_latest.npz")
    done
    evaluate "$out/gail_a_$kind.parquet" "$kind" "$test_episodes" "${policies[@]}"
  done
fi
