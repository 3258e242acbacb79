"""The summaries of per-decision records that docs/results commits in their place (issue 45): each table that reads
the records reads only these few numbers of them, and regenerates identically from either.

- BENCH/distributions.parquet (experiments/benchmark_table.py): each driver's distribution distances to the expert
  over all BENCH/test_sSEED evaluations pooled, and its speed, headway and lane histograms
  (`evaluation.distributions.decision_summary`);
- NAME.distributions.parquet beside a metrics file the same of that file alone (`sumo-rail report`);
- NAME.setpoints.parquet: each driver's decisions and agreements at each set-point (experiments/agreement_episodes.py);
- NAME.lane_changes.parquet: each driver's lane changes and close leaders (experiments/lane_change_context.py);
- the closed-loop tracks of human_likeness thinned (experiments/plot_scene_tracks.py `thin_tracks`: positions
  only in the seat the README's figure shows; the table reads none of them);
- and the acceleration study's test tracks without their plane coordinates (x_m, y_m: its table reads the place
  along the lane, the speed, lane and gap).

The records themselves (NAME.decisions.parquet, written by `sumo-rail evaluate --out NAME.parquet`) come back with
the evaluation's grid spec (docs/results.md, "What is committed"); with them beside the metrics files, the tables
read them and this script writes the summaries again.

Usage: python experiments/decision_summaries.py [--check]   (every summary docs/results commits; --check: compare
the summaries made from the records with the committed ones instead of writing them)
"""

from __future__ import annotations

from pathlib import Path

import click
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from agreement_episodes import setpoint_counts
from benchmark_table import SUMMARY, read_evaluations
from lane_change_context import counts_path, lane_change_counts
from plot_scene_tracks import thin_tracks

from sumo_rail.evaluation.distributions import decision_summary, summary_path
from sumo_rail.evaluation.evaluate import decisions_path
from sumo_rail.report.markdown import reference_expert

R = Path("docs/results")
BENCHMARKS = [R / "imitation_table/data", R / "realizable/data", R / "realizable_ppo/data"]
REPORTED = [R / "imitation_table/data/test_s0.parquet", R / "fidelity_demo/evaluation.parquet"]
SETPOINTS = [R / f"imitation_table/data/test_s{seed}.parquet" for seed in range(5)]
LANE_CHANGES = [(R / "ppo_expert/test_ppo_expert.decisions.parquet", 3.0)]
TRACKS = [R / "human_likeness/closed_loop.tracks.parquet"]
ALONG_LANE_TRACKS = [R / "human_likeness_acceleration/test.tracks.parquet"]


def summaries() -> dict[Path, pd.DataFrame]:
    """Every committed summary, made from the records (which must be there)."""
    made = {}
    for out in BENCHMARKS:
        _, decisions, lanes, expert = read_evaluations(out)
        if decisions is None:
            raise SystemExit(f"the per-decision records of {out}'s evaluations are not there")
        made[out / SUMMARY] = decision_summary(decisions, expert, lanes)
    for path in REPORTED:
        decisions = pd.read_parquet(decisions_path(path))
        lanes = int(max(decisions["lane"].max() + 1, 1))
        made[summary_path(path)] = decision_summary(decisions, reference_expert(pd.read_parquet(path)), lanes)
    for path in SETPOINTS:
        made[path.with_suffix(".setpoints.parquet")] = setpoint_counts(pd.read_parquet(decisions_path(path)))
    for path, headway_s in LANE_CHANGES:
        made[counts_path(str(path))] = lane_change_counts(pd.read_parquet(path), headway_s)
    for path in TRACKS:  # thinning thinned tracks changes nothing
        made[path] = thin_tracks(pd.read_parquet(path))
    for path in ALONG_LANE_TRACKS:
        made[path] = pd.read_parquet(path).assign(x_m=float("nan"), y_m=float("nan"))
    return made


def main(check: bool) -> None:
    for path, summary in summaries().items():
        index = summary.index.name is not None
        if check:
            committed = pd.read_parquet(path)
            pd.testing.assert_frame_equal(summary if index else summary.reset_index(drop=True), committed)
            print(f"{path}: the same")
        elif path in TRACKS or path in ALONG_LANE_TRACKS:  # the evaluation's own schema and metadata, data thinned
            schema = pq.read_schema(path)
            pq.write_table(pa.Table.from_pandas(summary, schema=schema, preserve_index=False), path,
                           compression="zstd", compression_level=19)
            print(f"{path}: thinned")
        else:
            summary.to_parquet(path, index=index, compression="zstd", compression_level=19)
            print(f"{path}: {len(summary)} rows")


@click.command(help=__doc__)
@click.option("--check", is_flag=True, help="Compare with the committed summaries instead of writing them.")
def cli(check: bool) -> None:
    main(check)


if __name__ == "__main__":
    cli()
