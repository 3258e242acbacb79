#!/usr/bin/env bash
# The meter of RAIL's step (issue 25): `sumo-rail step-signal` at the benchmark's BC policy (two-layer, seed 0) and
# at zero weights, in the paper's setting and with each remedy for the noise; every run measures all the
# discriminator variants (rewards). experiments/step_signal_table.py makes the table of docs/results.md.
# Usage: experiments/step_signal.sh DEMOS.parquet [OUT_DIR]   (resumable: settings with a report are skipped)
#   (environment: SETTINGS, names from the list below, default all; DIRECTIONS (32); WORKERS (2); POLICY, the
#   policy file measured, default the committed BC of the benchmark's seed 0; OVERRIDES, default the lane block)
set -euo pipefail
demos=$1
out=${2:-results/step_signal}
directions=${DIRECTIONS:-32}
workers=${WORKERS:-2}
policy=${POLICY:-docs/results/imitation_table/data/bc_mlp_s0/policy_bc.npz}
overrides=${OVERRIDES---set observation.lane_block=1}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
declare -A settings=(
  [bc_paper]=""
  [bc_episodes4]="--episodes-per-rollout 4"
  [bc_flip20]="--flip-rate 0.2"
  [bc_flip20_episodes4]="--flip-rate 0.2 --episodes-per-rollout 4"
  [bc_flip02_episodes4]="--flip-rate 0.02 --episodes-per-rollout 4"
  [bc_common]="--traffic common"
  [bc_flip20_common]="--flip-rate 0.2 --traffic common"
  [zero_paper]="--zero-weights"
  [zero_episodes4]="--zero-weights --episodes-per-rollout 4"
)
order=${SETTINGS:-bc_paper bc_episodes4 bc_flip20 zero_paper bc_flip20_episodes4 bc_common bc_flip20_common zero_episodes4 bc_flip02_episodes4}
mkdir -p "$out"
for name in $order; do
  [ -f "$out/$name.json" ] && continue
  # shellcheck disable=SC2086  # the overrides and settings are several words on purpose
  $sumo_rail step-signal $overrides --demos "$demos" --policy "$policy" --directions "$directions" \
    --workers "$workers" ${settings[$name]} --out "$out/$name.json" > "$out/$name.md" 2> "$out/$name.log"
done
