"""Closed-loop human-likeness (docs/results.md, "Learning from recorded drivers"): the tables of
`sumo-rail evaluate-scene`'s episodes of experiments/specs/human_likeness_closed_loop.toml, with BC, RAIL and GAIL
pooled over their three training seeds and RAIL and GAIL each paired with the BC of the same seed, seat by seat.

    python experiments/human_likeness_closed_loop.py CLOSED_LOOP.parquet
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

from sumo_rail.datasets import read_metadata
from sumo_rail.evaluation.scene_evaluation import tracks_path
from sumo_rail.evaluation.scene_summary import distribution_table, track_table

SEEDS = (0, 1, 2)
METHODS = {"constant set-point (keep)": ["keep"], "SUMO's IDM + LC2013": ["sumo-idm"],
           "rule-based expert": ["expert-normal"], "BC": [f"rail_s{seed}/policy_bc" for seed in SEEDS],
           "RAIL": [f"rail_s{seed}/policy_latest" for seed in SEEDS],
           "GAIL": [f"gail_s{seed}/policy_latest" for seed in SEEDS]}
DIFFERENCES = [("RAIL", "BC"), ("GAIL", "BC")]


def main(path: Path) -> None:
    metrics, tracks = pd.read_parquet(path), pd.read_parquet(tracks_path(path))
    period = read_metadata(path)["config"]["env"]["decision_period_s"]
    seats = metrics.groupby(["scene", "vehicle"]).ngroups
    print(f"{seats} held-out cars' seats in {metrics['scene'].nunique()} scenes of SUMO's drivers, "
          f"{metrics['simulated_s'].max():g} s each; BC, RAIL and GAIL pooled over training seeds "
          f"{', '.join(map(str, SEEDS))}; differences paired by seat and training seed (* : the interval excludes 0)\n")
    print(track_table(metrics, METHODS, DIFFERENCES))
    print("\nWasserstein-1 distance to the humans' distributions (same seats):\n")
    print(distribution_table(tracks, METHODS, period))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
