#!/usr/bin/env bash
# Sourced by experiments/style_fidelity.sh and experiments/demonstrations_sweep.sh: BC, RAIL and DAgger trained on
# one demonstrations file with one seed, in the caller's setting.
# train_learners DEMOS OUT TAG SEED writes OUT/rail_TAG_sSEED (RAIL, two-layer), OUT/bc_TAG_sSEED (the BC policy RAIL
# started from, as its own driver: its run.json names it by the folder) and OUT/dagger_TAG_sSEED, resuming runs
# already begun, and appends the three policies to the caller's array `policies` as evaluate options.
# Reads the caller's variables overrides, bc_epochs (of the BC that starts RAIL), directions, iterations,
# dagger_rounds, round_episodes, workers, sumo_rail.
train_learners() {
  local demos=$1 out=$2 tag=$3 seed=$4
  local rail="$out/rail_${tag}_s$seed" bc="$out/bc_${tag}_s$seed" dagger="$out/dagger_${tag}_s$seed"
  local resume=()
  [ -f "$rail/checkpoint.pt" ] && resume=(--resume)
  # shellcheck disable=SC2086  # the overrides are several words on purpose
  $sumo_rail train $overrides --demos "$demos" --policy mlp --bc-epochs "$bc_epochs" --directions "$directions" \
    --iterations "$iterations" --eval-every 0 --workers "$workers" --seed "$seed" --out "$rail" "${resume[@]}"
  mkdir -p "$bc"
  cp "$rail/policy_bc.npz" "$rail/run.json" "$bc/"
  resume=()
  [ -f "$dagger/checkpoint.json" ] && resume=(--resume)
  # shellcheck disable=SC2086
  $sumo_rail dagger $overrides --demos "$demos" --rounds "$dagger_rounds" --episodes-per-round "$round_episodes" \
    --eval-every 0 --workers "$workers" --seed "$seed" --out "$dagger" "${resume[@]}"
  policies+=(--policy "$bc/policy_bc.npz" --policy "$rail/policy_latest.npz" --policy "$dagger/policy_latest.npz")
}
