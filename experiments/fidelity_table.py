"""The fidelity table of docs/results.md from an evaluation: each driver's measures with 95% intervals, its
paired difference to the expert, and whether a candidate is closer to the expert than a baseline.

Usage: `python experiments/fidelity_table.py METRICS.parquet --expert expert-normal --candidate RAIL_NAME
--baseline BC_NAME` (driver names as `sumo-rail evaluate` printed them). Prints Markdown.
"""

from __future__ import annotations

import argparse

import pandas as pd

from sumo_rail.evaluation.statistics import Interval
from sumo_rail.evaluation.summary import MEASURES, closeness, intervals, paired_differences

SHOWN = ("agreement", "lane_change_recall", "lane_change_precision", "lateral_agreement", "longitudinal_agreement",
         "average_speed_kmh", "overtakes", "lane_changes", "collisions")


def cell(measure: str, found: pd.Series, signed: bool = False) -> str:
    digits = 3 if MEASURES.index(measure) < 5 else 2
    return Interval(found["estimate"], found["low"], found["high"]).format(digits, signed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("metrics")
    parser.add_argument("--expert", required=True)
    parser.add_argument("--candidate", required=True)
    parser.add_argument("--baseline", required=True)
    args = parser.parse_args()
    metrics = pd.read_parquet(args.metrics)
    drivers = list(dict.fromkeys(metrics["policy"]))
    means = intervals(metrics).set_index(["measure", "policy"])
    differences = paired_differences(metrics, args.expert).set_index(["measure", "policy"])
    verdicts = closeness(metrics, args.candidate, args.baseline, args.expert).set_index("measure")
    others = [driver for driver in drivers if driver != args.expert]
    print("| measure | " + " | ".join(drivers) + " | " + " | ".join(f"{d} - {args.expert}" for d in others)
          + f" | {args.candidate} vs {args.baseline}: closer to the expert? |")
    print("|---|" + "---|" * (len(drivers) + len(others) + 1))
    for measure in SHOWN:
        row = [cell(measure, means.loc[(measure, driver)]) for driver in drivers]
        row += [cell(measure, differences.loc[(measure, driver)], signed=True)
                + (" *" if differences.loc[(measure, driver), "detectable"] else "") for driver in others]
        verdict = verdicts.loc[measure]
        row.append(f"{verdict['verdict']} ({cell(measure, verdict, signed=True)})")
        print(f"| {measure} | " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
