#!/usr/bin/env bash
# What the learner can see (issue 14): for each observation design (and an expert limited to the sensor's
# range), record the expert, then BC and DAgger rounds; the table is BC's held-out accuracy on demonstrations and
# on-policy agreement with the expert on validation episodes (validation seeds and warm states, never test ones).
# DAgger's last round estimates the information ceiling of the design: what a learner that is asked about its own
# states can reach.
# Usage: experiments/observation_study.sh [OUT_DIR]   (resumable: finished steps are skipped, DAgger resumes)
#   (environment: EPISODES demonstrations, ROUNDS, ROUND_EPISODES, EVAL_EPISODES per round, FINAL_EPISODES for the
#   final paired evaluation of BC and DAgger's last policy, WORKERS, DESIGNS)
set -euo pipefail
out=${1:-results/observation_study}
episodes=${EPISODES:-100}
rounds=${ROUNDS:-4}
round_episodes=${ROUND_EPISODES:-20}
eval_episodes=${EVAL_EPISODES:-20}
final_episodes=${FINAL_EPISODES:-60}
workers=${WORKERS:-2}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
python=${PYTHON:-.venv/bin/python}
declare -A overrides=(
  [lidar24]=""
  [lidar72]="--set lidar.beams=72"
  [lidar24_lanes]="--set observation.lane_block=1"
  [lidar24_sensor_expert]="--set expert.view_range_m=100"
  [lidar24_lanes_sensor_expert]="--set observation.lane_block=1 --set expert.view_range_m=100"
)
designs=${DESIGNS:-lidar24 lidar72 lidar24_lanes lidar24_sensor_expert lidar24_lanes_sensor_expert}
for design in $designs; do
  folder="$out/$design"
  mkdir -p "$folder"
  # shellcheck disable=SC2086  # the overrides are several words on purpose
  [ -f "$folder/demos.parquet" ] || $sumo_rail record-expert ${overrides[$design]} --episodes "$episodes" --seed 0 \
    --workers "$workers" --out "$folder/demos.parquet"
  resume=(); [ -f "$folder/dagger/checkpoint.json" ] && resume=(--resume)
  # shellcheck disable=SC2086
  $sumo_rail dagger ${overrides[$design]} --demos "$folder/demos.parquet" --rounds "$rounds" \
    --episodes-per-round "$round_episodes" --eval-every 1 --eval-episodes "$eval_episodes" --workers "$workers" \
    --seed 0 --out "$folder/dagger" "${resume[@]}"
  # shellcheck disable=SC2086
  [ -f "$folder/validation.parquet" ] || $sumo_rail evaluate ${overrides[$design]} --policy expert \
    --policy "$folder/dagger/policy_bc.npz" --policy "$folder/dagger/policy_latest.npz" --pool validation \
    --seed 3000000 --episodes "$final_episodes" --workers "$workers" --out "$folder/validation.parquet" \
    > "$folder/validation.txt"
done
$python experiments/observation_table.py "$out" $designs | tee "$out/table.md"
