"""Does a driver change lanes to overtake? For each driver of an evaluation's per-decision file: how often a leader
is within HEADWAY seconds at any decision, and at the decision before each lane change to the left and to the right
(a driver that overtakes moves left when it is close behind a leader far more often than the base rate), and the
share of decisions in each lane (0 = rightmost). Prints Markdown.

Where the records are not committed, EVALUATION.lane_changes.parquet beside them holds the counts the table is made
of (`lane_change_counts`; --summary writes it from the records).

Usage: python experiments/lane_change_context.py EVALUATION.decisions.parquet [HEADWAY_S (3.0)] [--summary]
"""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
import pandas as pd


def lane_change_counts(decisions: pd.DataFrame, headway_s: float) -> pd.DataFrame:
    """One row per driver: its decisions (but each episode's last), the ones with a leader within `headway_s`, its
    changes to the left and right and the ones taken with a leader that close, and its decisions in each lane: all the
    table reads of the records (LANE_CHANGES beside them holds it where they are not committed)."""
    rows = []
    lanes_seen = int(decisions["lane"].max()) + 1
    for policy, driver in decisions.sort_values(["policy", "seed", "step"]).groupby("policy", sort=False):
        changes, close, lanes = [], [], []
        for _, episode in driver.groupby("seed"):
            lane = episode["lane"].to_numpy()
            changes.append(np.diff(lane))
            close.append(np.nan_to_num(episode["headway_s"].to_numpy()[:-1], nan=np.inf) < headway_s)
            lanes.append(lane[:-1])
        change, near, lane = np.concatenate(changes), np.concatenate(close), np.concatenate(lanes).astype(int)
        counts = np.bincount(lane, minlength=lanes_seen)
        rows.append({"driver": policy, "headway_s": headway_s, "decisions": len(change), "close": int(near.sum()),
                     "changes_left": int((change > 0).sum()), "close_left": int(near[change > 0].sum()),
                     "changes_right": int((change < 0).sum()), "close_right": int(near[change < 0].sum()),
                     **{f"lane_{k}": int(count) for k, count in enumerate(counts)}})
    return pd.DataFrame(rows)


def lane_change_context(counts: pd.DataFrame) -> pd.DataFrame:
    """One row per driver of `lane_change_counts`: decisions, the shares with a leader within its headway (all,
    before a change to the left or right, with the changes' counts) and the lane shares."""
    lanes = [column for column in counts.columns if column.startswith("lane_")]
    rows = []
    for row in counts.itertuples(index=False):
        values = row._asdict()
        shares = np.array([values[lane] for lane in lanes]) / row.decisions
        rows.append({"driver": row.driver, "decisions": row.decisions, "leader close, any decision":
                     row.close / row.decisions, "before a change left": _share(row.close_left, row.changes_left),
                     "changes left": row.changes_left, "before a change right":
                     _share(row.close_right, row.changes_right), "changes right": row.changes_right,
                     "lane shares (0 = rightmost)": ", ".join(f"{share:.2f}" for share in shares)})
    return pd.DataFrame(rows)


def _share(part: int, whole: int) -> float:
    return part / whole if whole else float("nan")


def counts_path(path: str) -> Path:
    """LANE_CHANGES: NAME.lane_changes.parquet beside NAME.decisions.parquet."""
    return Path(path.removesuffix(".decisions.parquet") + ".lane_changes.parquet")


def main(path: str, headway_s: float = 3.0, write: bool = False) -> None:
    if Path(path).is_file():
        counts = lane_change_counts(pd.read_parquet(path), headway_s)
        if write:
            counts.to_parquet(counts_path(path), index=False)
    else:
        counts = pd.read_parquet(counts_path(path))
        if set(counts["headway_s"]) != {headway_s}:
            raise SystemExit(f"{counts_path(path)} counts leaders within {set(counts['headway_s'])} s, not "
                             f"{headway_s:g}; its records ({path}) are not here")
    table = lane_change_context(counts)
    print(f"Share of decisions with a leader within {headway_s:g} s\n")
    print("| " + " | ".join(table.columns) + " |")
    print("|---|" + "---:|" * (len(table.columns) - 2) + "---|")
    for row in table.itertuples(index=False):
        print("| " + " | ".join(f"{value:.3f}" if isinstance(value, float) else str(value) for value in row) + " |")


@click.command(help=__doc__)
@click.argument("path", type=click.Path(dir_okay=False))
@click.argument("headway_s", required=False, default=3.0, type=click.FloatRange(min=0.0, min_open=True))
@click.option("--summary", is_flag=True, help="Also write NAME.lane_changes.parquet beside the decisions.")
def cli(path: str, headway_s: float, summary: bool) -> None:
    if not Path(path).is_file() and not counts_path(path).is_file():
        raise click.BadParameter(f"neither {path} nor the counts beside it ({counts_path(path)}) exist",
                                 param_hint="PATH")
    main(path, headway_s, write=summary)


if __name__ == "__main__":
    cli()
