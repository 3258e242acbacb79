#!/usr/bin/env bash
# `make demo`: the whole pipeline in the recommended setting (--preset recommended: the paper's observation plus
# the lane-wise and route blocks) on the straight road, small enough for two cores in a few minutes: record the expert,
# train BC then RAIL, train DAgger, evaluate the expert, BC, RAIL and DAgger on the same held-out episodes, and
# report. EPISODES sets the evaluation episodes (60 here to stay quick; `evaluate`'s own default is 250);
# PRESET=paper runs the paper's setting instead.
set -euo pipefail
out=${1:-demo_output}
sumo_rail=${SUMO_RAIL:-.venv/bin/sumo-rail}
preset=${PRESET:-recommended}
episodes=${EPISODES:-60}
rm -rf "$out"  # the demo's own folder: each run starts clean
mkdir -p "$out/policies"
$sumo_rail record-expert --preset "$preset" --episodes 40 --seed 0 --workers 2 --out "$out/demos.parquet"
# BC: 100 epochs, not train's 20: on 40 demonstration episodes 20 leave BC under-trained (about 0.2 agreement
# with the expert against about 0.6; docs/results.md, "Number of expert demonstrations", gives BC 4000 / episodes)
$sumo_rail train --preset "$preset" --demos "$out/demos.parquet" --set network.shape=mlp --set bc.epochs=100 \
  --set rail.directions=16 --set rail.top=8 --iterations 15 --eval-every 5 --workers 2 --seed 0 --out "$out/rail"
$sumo_rail dagger --preset "$preset" --demos "$out/demos.parquet" --set network.shape=mlp --set bc.epochs=100 \
  --rounds 3 --set dagger.episodes_per_round=10 --eval-every 3 --workers 2 --seed 0 --out "$out/dagger"
# the policies under the names the table shows
cp "$out/rail/policy_bc.npz" "$out/policies/BC.npz"
cp "$out/rail/policy_latest.npz" "$out/policies/RAIL.npz"
cp "$out/dagger/policy_latest.npz" "$out/policies/DAgger.npz"
$sumo_rail evaluate --preset "$preset" --policy expert --policy "$out/policies/BC.npz" \
  --policy "$out/policies/RAIL.npz" --policy "$out/policies/DAgger.npz" --episodes "$episodes" --seed 1000 \
  --workers 2 --gui-off --out "$out/evaluation.parquet" > "$out/table.txt"
$sumo_rail report "$out/rail" "$out/evaluation.parquet" --out "$out/report"
echo
echo "The expert, BC, RAIL and DAgger on the same $episodes held-out episodes, setting '$preset' (95% intervals;"
echo "agreement: the share of a driver's decisions the expert would have made in that very traffic):"
cat "$out/table.txt"
echo
echo "Plots and summary: $out/report/report.md"
if [ "$preset" = recommended ]; then
  echo "The paper's setting (its 24-beam LIDAR alone, which misses cars one lane over, so every learner imitates"
  echo "the expert less closely): PRESET=paper make demo, or --preset paper (the default) in any command."
fi
