"""Does a driver change lanes to overtake? For each driver of an evaluation's per-decision file: how often a leader
is within HEADWAY seconds at any decision, and at the decision before each lane change to the left and to the right
(a driver that overtakes moves left when it is close behind a leader far more often than the base rate), and the
share of decisions in each lane (0 = rightmost). Prints Markdown.

Usage: python experiments/lane_change_context.py EVALUATION.decisions.parquet [HEADWAY_S (3.0)]
"""

from __future__ import annotations

import sys

import numpy as np
import pandas as pd


def lane_change_context(decisions: pd.DataFrame, headway_s: float) -> pd.DataFrame:
    """One row per driver: decisions, the shares with a leader within `headway_s` (all, before a change to the left
    or right, with the changes' counts) and the lane shares."""
    rows = []
    for policy, driver in decisions.sort_values(["policy", "seed", "step"]).groupby("policy", sort=False):
        changes, close, lanes = [], [], []
        for _, episode in driver.groupby("seed"):
            lane = episode["lane"].to_numpy()
            changes.append(np.diff(lane))
            close.append(np.nan_to_num(episode["headway_s"].to_numpy()[:-1], nan=np.inf) < headway_s)
            lanes.append(lane[:-1])
        change, near, lane = np.concatenate(changes), np.concatenate(close), np.concatenate(lanes).astype(int)
        shares = np.bincount(lane, minlength=int(decisions["lane"].max()) + 1) / len(lane)
        rows.append({"driver": policy, "decisions": len(change), "leader close, any decision": near.mean(),
                     "before a change left": near[change > 0].mean(), "changes left": int((change > 0).sum()),
                     "before a change right": near[change < 0].mean(), "changes right": int((change < 0).sum()),
                     "lane shares (0 = rightmost)": ", ".join(f"{share:.2f}" for share in shares)})
    return pd.DataFrame(rows)


def main(path: str, headway_s: float = 3.0) -> None:
    table = lane_change_context(pd.read_parquet(path), headway_s)
    print(f"Share of decisions with a leader within {headway_s:g} s\n")
    print("| " + " | ".join(table.columns) + " |")
    print("|---|" + "---:|" * (len(table.columns) - 2) + "---|")
    for row in table.itertuples(index=False):
        print("| " + " | ".join(f"{value:.3f}" if isinstance(value, float) else str(value) for value in row) + " |")


if __name__ == "__main__":
    main(sys.argv[1], *(float(value) for value in sys.argv[2:]))
