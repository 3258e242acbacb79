"""The table of experiments/rail_ablations.sh from one evaluation (validation or test episodes).

Drivers are named VARIANT_sSEED/policy_* (one per variant and training seed). For each variant and measure: its
value pooled over the training seeds, and its paired difference to BC and to `independent` (RAIL as first
implemented) on the same episodes, with a verdict and each seed's own difference (experiments/seeded.py says how
seeds are pooled). Prints Markdown.

Usage: python experiments/ablation_table.py METRICS.parquet
"""

from __future__ import annotations

import sys

import pandas as pd
from seeded import difference_cell, digits_of, seed_samples, training_seeds, value_cell

MEASURES = ("agreement", "lane_change_recall", "lane_change_precision", "average_speed_kmh", "overtakes",
            "lane_changes", "collisions")
VARIANTS = ("bc", "bcnorm", "independent", "indfrozen", "crn", "frozen", "v2", "disc5")
LABELS = {"bc": "BC", "bcnorm": "BC weights, RAIL's final normaliser", "independent": "RAIL, independent traffic",
          "indfrozen": "RAIL, independent traffic, frozen normaliser", "crn": "RAIL, common traffic",
          "frozen": "RAIL, common traffic, frozen normaliser", "v2": "RAIL, common traffic, V2 (all directions)",
          "disc5": "RAIL, common traffic, discriminator x5"}


def main(path: str) -> None:
    metrics = pd.read_parquet(path)
    seeds = training_seeds(metrics, "crn")
    samples = {variant: seed_samples(metrics, variant, seeds) for variant in VARIANTS}
    episodes = metrics.groupby("policy").size().max()
    print(f"{episodes} episodes per policy; training seeds {seeds}; cells: value [95% interval] over training "
          f"runs and episodes (experiments/seeded.py), each run's own estimate in brackets.\n")
    print("| variant | measure | value | minus BC | minus RAIL, independent traffic |")
    print("|---|---|---|---|---|")
    for variant in VARIANTS:
        for measure in MEASURES:
            digits = digits_of(measure)
            cells = [value_cell(samples[variant], measure, digits)]
            cells += ["-" if reference == variant else
                      difference_cell(samples[variant], samples[reference], measure, digits)
                      for reference in ("bc", "independent")]
            print(f"| {LABELS[variant]} | {measure} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1])
