"""The table of experiments/observation_study.sh: per design, BC's held-out accuracy on demonstrations and the
on-policy agreement with the expert of BC (round 0) and of each DAgger round, on validation episodes.

Usage: python experiments/observation_table.py OUT_DIR DESIGN [DESIGN ...] (prints Markdown)
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd


def main(out: Path, designs: list[str]) -> None:
    logs = {design: pd.read_parquet(out / design / "dagger" / "log.parquet") for design in designs}
    rounds = max(len(log) for log in logs.values())
    print("| design | observation size | BC held-out accuracy | BC agreement (lane-change recall) | "
          + " | ".join(f"DAgger round {r} agreement (recall)" for r in range(1, rounds)) + " |")
    print("|---|---:|---:|---|" + "---|" * (rounds - 1))
    for design, log in logs.items():
        size = pd.read_parquet(out / design / "demos.parquet", columns=["observation"])["observation"].iloc[0].size
        cells = [f"{row.eval_agreement:.3f} ({row.eval_lane_change_recall:.2f})" for row in log.itertuples()]
        print(f"| {design} | {size} | {log['bc_holdout_accuracy'].iloc[0]:.3f} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(Path(sys.argv[1]), sys.argv[2:])
