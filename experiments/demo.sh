#!/usr/bin/env bash
# `make demo`: the whole pipeline on defaults, small enough for two cores in a few minutes:
# record the expert, train (BC then RAIL), evaluate expert vs BC vs RAIL on held-out episodes, and report.
# EPISODES sets the evaluation episodes (60 here to stay quick; `evaluate`'s own default is 250).
set -euo pipefail
out=${1:-demo_output}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
rm -rf "$out"  # the demo's own folder: each run starts clean
mkdir -p "$out"
$sumo_rail record-expert --episodes 40 --seed 0 --workers 2 --out "$out/demos.parquet"
$sumo_rail train --demos "$out/demos.parquet" --policy mlp --directions 16 --top 8 --step-size 0.02 \
  --iterations 15 --eval-every 5 --eval-episodes 4 --workers 2 --seed 0 --out "$out/run"
$sumo_rail evaluate --policy expert --policy "$out/run/policy_bc.npz" --policy "$out/run/policy_latest.npz" \
  --episodes "${EPISODES:-60}" --seed 1000 --workers 2 --gui-off --out "$out/evaluation.parquet" > "$out/table.txt"
$sumo_rail report "$out/run" "$out/evaluation.parquet" --out "$out/report"
echo
echo "Expert vs BC vs RAIL on ${EPISODES:-60} held-out episodes (95% intervals; differences to the expert):"
cat "$out/table.txt"
echo
echo "Plots and summary: $out/report/report.md"
