"""Where a learner's disagreement with the expert lives: per episode and per cruise set-point (issue 25).

Per driver of one or more evaluations (`sumo-rail evaluate --out`, with its `.decisions.parquet` beside): the share
of episodes whose agreement is below one half and the 5% quantile of episode agreement, then the share of decisions
taken with the set-point outside the band in which the expert keeps it (its desired speed +- half a speed step: the
expert accelerates below it and decelerates above it at every decision) and the agreement there and elsewhere.
Drivers named METHOD_sSEED/... are pooled over seeds as METHOD. Prints Markdown.

Usage: python experiments/agreement_episodes.py STYLE METRICS.parquet [METRICS.parquet ...]
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.drivers.expert import STYLES


def method(policy: str) -> str:
    """'bc_mlp_s3/policy_bc' -> 'bc_mlp/policy_bc'; other names unchanged."""
    return re.sub(r"_s\d+/", "/", policy)


def table(style: str, paths: list[Path]) -> str:
    desired, half_step = STYLES[style].desired_speed_mps, Config().env.speed_step_mps / 2
    metrics = pd.concat([pd.read_parquet(path) for path in paths])
    decisions = pd.concat([pd.read_parquet(path.with_suffix(".decisions.parquet")) for path in paths])
    metrics["method"], decisions["method"] = metrics["policy"].map(method), decisions["policy"].map(method)
    decisions["off_band"] = (decisions["set_point_mps"] - desired).abs() > half_step + 1e-6
    decisions["agrees"] = decisions["action"] == decisions["expert_action"]
    lines = ["| driver | episodes | agreement | episodes below 0.5 | 5% quantile of episode agreement | decisions "
             "with the set-point off the expert's band | agreement there | agreement elsewhere |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name, episodes in metrics.groupby("method", sort=False):
        mine = decisions[decisions["method"] == name]
        off, on = mine[mine["off_band"]], mine[~mine["off_band"]]
        lines.append(f"| {name} | {len(episodes)} | {mine['agrees'].mean():.3f} | "
                     f"{(episodes['agreement'] < 0.5).mean():.1%} | {np.quantile(episodes['agreement'], 0.05):.2f} | "
                     f"{mine['off_band'].mean():.1%} | {off['agrees'].mean() if len(off) else float('nan'):.3f} | "
                     f"{on['agrees'].mean():.3f} |")
    return "\n".join(lines)


if __name__ == "__main__":
    print(table(sys.argv[1], [Path(path) for path in sys.argv[2:]]))
