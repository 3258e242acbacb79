"""The tables of experiments/observation_study.sh: per design, BC's held-out accuracy on demonstrations and the
on-policy agreement with the expert of BC (round 0) and of each DAgger round on validation episodes (point
estimates on the rounds' few episodes), then the final paired evaluation of BC and DAgger's last policy on the
same validation episodes, with 95% intervals.

Usage: python experiments/observation_table.py OUT_DIR DESIGN [DESIGN ...] (prints Markdown)
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

from sumo_rail.evaluation.statistics import interval, paired_difference
from sumo_rail.evaluation.summary import measure_samples


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
    print("\n| design | measure | BC | DAgger, last round | DAgger - BC (paired) |")
    print("|---|---|---|---|---|")
    for design in designs:
        path = out / design / "validation.parquet"
        if not path.is_file():
            continue
        metrics = pd.read_parquet(path)
        bc, dagger = (measure_samples(metrics[metrics["policy"].str.endswith(stem)].sort_values("seed"))
                      for stem in ("/policy_bc", "/policy_latest"))
        for measure in ("agreement", "lane_change_recall", "lane_change_precision"):
            print(f"| {design} | {measure} | {interval(bc[measure]).format(3)} | "
                  f"{interval(dagger[measure]).format(3)} | "
                  f"{paired_difference(dagger[measure], bc[measure]).format(3, signed=True)} |")


if __name__ == "__main__":
    main(Path(sys.argv[1]), sys.argv[2:])
