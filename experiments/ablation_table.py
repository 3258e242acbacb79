"""The table of experiments/rail_ablations.sh from one evaluation (validation or test episodes).

Drivers are named VARIANT_sSEED/policy_* (one per variant and training seed). For each variant and measure:
its value pooled over seeds and episodes, and its paired difference to BC and to `independent` (RAIL as first
implemented), pairing each seed's policy with the same seed's reference on the same episodes, pooled over seeds
(bootstrap over the (seed, episode) pairs), with a verdict. Prints Markdown.

Usage: python experiments/ablation_table.py METRICS.parquet
"""

from __future__ import annotations

import re
import sys

import numpy as np
import pandas as pd

from sumo_rail.evaluation.statistics import Interval, interval, paired_difference
from sumo_rail.evaluation.summary import measure_samples

MEASURES = ("agreement", "lane_change_recall", "lane_change_precision", "average_speed_kmh", "overtakes",
            "lane_changes", "collisions")
VARIANTS = ("bc", "bcnorm", "independent", "crn", "frozen", "v2", "disc5")
LABELS = {"bc": "BC", "bcnorm": "BC weights, RAIL's final normaliser", "independent": "RAIL, independent traffic",
          "crn": "RAIL, common traffic (default)", "frozen": "RAIL, common traffic, frozen normaliser",
          "v2": "RAIL, common traffic, V2 (all directions)", "disc5": "RAIL, common traffic, discriminator x5"}


def pooled(metrics: pd.DataFrame, variant: str, seeds: list[int], measure: str) -> tuple[np.ndarray, np.ndarray]:
    """The measure's (numerators, denominators) of a variant, seeds after each other, episodes in seed order."""
    parts = [measure_samples(metrics[metrics["policy"].str.startswith(f"{variant}_s{seed}/")].sort_values("seed"))
             [measure] for seed in seeds]
    return np.concatenate([part[0] for part in parts]), np.concatenate([part[1] for part in parts])


def verdict(found: Interval) -> str:
    return "higher" if found.low > 0 else "lower" if found.high < 0 else "no detectable difference"


def main(path: str) -> None:
    metrics = pd.read_parquet(path)
    seeds = sorted({int(match.group(1)) for name in metrics["policy"]
                    if (match := re.match(r"crn_s(\d+)/", name))})
    episodes = metrics.groupby("policy").size().max()
    print(f"{episodes} episodes per policy; training seeds {seeds}; cells: value [95% interval]; differences pair "
          f"each seed's policy with the same seed's reference on the same episodes.\n")
    print("| variant | measure | value | minus BC | minus RAIL, independent traffic |")
    print("|---|---|---|---|---|")
    for variant in VARIANTS:
        for measure in MEASURES:
            digits = 3 if "agreement" in measure or "lane_change_" in measure else 2
            sample = pooled(metrics, variant, seeds, measure)
            cells = [interval(sample).format(digits)]
            for reference in ("bc", "independent"):
                if reference == variant:
                    cells.append("-")
                    continue
                found = paired_difference(sample, pooled(metrics, reference, seeds, measure))
                cells.append(f"{found.format(digits, signed=True)} {verdict(found)}")
            print(f"| {LABELS[variant]} | {measure} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1])
