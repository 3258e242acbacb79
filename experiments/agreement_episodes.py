"""Where a learner's disagreement with the expert lives: per episode and per cruise set-point (issue 25).

Per driver of one or more evaluations (`sumo-rail evaluate --out`, with its `.decisions.parquet` beside): the share
of episodes whose agreement is below one half and the 5% quantile of episode agreement, then the share of decisions
taken with the set-point outside the band in which the expert keeps it (its desired speed +- half a speed step: the
expert accelerates below it and decelerates above it at every decision) and the agreement there and elsewhere.
Drivers named METHOD_sSEED/... are pooled over seeds as METHOD. Prints Markdown.

The table reads the records only as each driver's decisions and agreements at each set-point (`setpoint_counts`):
where METRICS.decisions.parquet is not committed, METRICS.setpoints.parquet holds them (--summary writes it beside
every METRICS file from its records).

Usage: python experiments/agreement_episodes.py STYLE METRICS.parquet [METRICS.parquet ...] [--summary]
"""

from __future__ import annotations

import re
from pathlib import Path

import click
import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.drivers.expert import STYLES


def method(policy: str) -> str:
    """'bc_mlp_s3/policy_bc' -> 'bc_mlp/policy_bc'; other names unchanged."""
    return re.sub(r"_s\d+/", "/", policy)


def setpoint_counts(decisions: pd.DataFrame) -> pd.DataFrame:
    """Per driver and set-point [m/s]: its decisions and the ones where it chose the expert's action."""
    agrees = (decisions["action"] == decisions["expert_action"]).astype("int64")
    counts = decisions.assign(agrees=agrees).groupby(["policy", "set_point_mps"], sort=False)["agrees"]
    return pd.DataFrame({"decisions": counts.size(), "agrees": counts.sum()}).reset_index()


def read_counts(path: Path) -> pd.DataFrame:
    """`setpoint_counts` of a metrics file: from its records, or the summary committed in their place."""
    records = path.with_suffix(".decisions.parquet")
    return setpoint_counts(pd.read_parquet(records)) if records.is_file() else pd.read_parquet(
        path.with_suffix(".setpoints.parquet"))


def table(style: str, paths: list[Path]) -> str:
    desired, half_step = STYLES[style].desired_speed_mps, Config().env.speed_step_mps / 2
    metrics = pd.concat([pd.read_parquet(path) for path in paths])
    decisions = pd.concat([read_counts(path) for path in paths])
    metrics["method"], decisions["method"] = metrics["policy"].map(method), decisions["policy"].map(method)
    decisions["off_band"] = (decisions["set_point_mps"] - desired).abs() > half_step + 1e-6
    lines = ["| driver | episodes | agreement | episodes below 0.5 | 5% quantile of episode agreement | decisions "
             "with the set-point off the expert's band | agreement there | agreement elsewhere |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name, episodes in metrics.groupby("method", sort=False):
        mine = decisions[decisions["method"] == name]
        off, on = mine[mine["off_band"]], mine[~mine["off_band"]]
        total, off_total = int(mine["decisions"].sum()), int(off["decisions"].sum())
        off_agreement = off["agrees"].sum() / off_total if off_total else float("nan")
        lines.append(f"| {name} | {len(episodes)} | {mine['agrees'].sum() / total:.3f} | "
                     f"{(episodes['agreement'] < 0.5).mean():.1%} | {np.quantile(episodes['agreement'], 0.05):.2f} | "
                     f"{off_total / total:.1%} | {off_agreement:.3f} | "
                     f"{on['agrees'].sum() / on['decisions'].sum():.3f} |")
    return "\n".join(lines)


def write_summaries(paths: list[Path]) -> None:
    """METRICS.setpoints.parquet beside each metrics file, from its records."""
    for path in paths:
        setpoint_counts(pd.read_parquet(path.with_suffix(".decisions.parquet"))).to_parquet(
            path.with_suffix(".setpoints.parquet"), index=False)


@click.command(help=__doc__)
@click.argument("style", type=click.Choice(sorted(STYLES)))
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--summary", is_flag=True, help="Also write METRICS.setpoints.parquet beside each metrics file.")
def cli(style: str, paths: tuple[Path, ...], summary: bool) -> None:
    if summary:
        write_summaries(list(paths))
    print(table(style, list(paths)))


if __name__ == "__main__":
    cli()
