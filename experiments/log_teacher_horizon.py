"""Training against the log: the teacher's horizon chosen on validation seats (docs/results.md, "Training against
the log"). The tables of `evaluate-scene`'s episodes of experiments/specs/log_teacher_horizon.toml: every driver's
position errors at 1, 5 and 10 s and its distributions' distances to the humans', each `dagger --expert log` run
(log_hH_s0/policy_latest: dagger.teacher_horizon_s H) paired seat by seat with the BC it started from (its round 0,
log_h3_s0/policy_bc), SUMO's IDM and the constant speed (keep).

    python experiments/log_teacher_horizon.py VALIDATION.parquet
"""

from __future__ import annotations

from pathlib import Path

import click
import pandas as pd

from sumo_rail.datasets import read_metadata
from sumo_rail.evaluation.human_likeness import HORIZONS_S
from sumo_rail.evaluation.scene_evaluation import tracks_path
from sumo_rail.evaluation.scene_summary import DISTANCE_INTERVALS, distribution_table, track_table

BC = "log_h3_s0/policy_bc"
ERRORS = {f"position error {h:g} s [m]": f"position_error_{h:g}s_m" for h in HORIZONS_S}


@click.command()
@click.argument("path", type=click.Path(exists=True, dir_okay=False, path_type=Path))
def main(path: Path) -> None:
    metrics, tracks = pd.read_parquet(path), pd.read_parquet(tracks_path(path))
    period = read_metadata(path)["config"]["env"]["decision_period_s"]
    names = sorted(set(metrics["policy"]))
    logs = [name for name in names if name.endswith("/policy_latest")]
    methods = {name: [name] for name in names}
    seats = metrics.groupby(["scene", "vehicle"]).ngroups
    print(f"{seats} validation seats, {metrics['simulated_s'].max():g} s each; differences paired by seat "
          f"(* : the interval excludes 0)\n")
    print(track_table(metrics, methods, [(log, reference) for log in logs for reference in (BC, "sumo-idm", "keep")],
                      ERRORS))
    print(f"\nWasserstein-1 distance to the humans' distributions (same seats); differences paired by seat. "
          f"{DISTANCE_INTERVALS}\n")
    print(distribution_table(tracks, methods, period, [(log, BC) for log in logs]))


if __name__ == "__main__":
    main()
