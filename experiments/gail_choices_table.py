"""The table of experiments/gail_choices.sh from one evaluation (validation episodes).

Drivers are named VARIANT_sSEED/policy_latest, with " (sampled)" when evaluated by sampling, and
all_sSEED/policy_bc (BC, every variant's start). For each variant, evaluation and measure: its value pooled over
seeds and episodes, and its paired differences to BC and to GAIL with every choice on evaluated the same way,
pairing each seed's policy with the same seed's reference on the same episodes (bootstrap over the (seed,
episode) pairs), with a verdict. Prints Markdown.

Usage: python experiments/gail_choices_table.py METRICS.parquet
"""

from __future__ import annotations

import re
import sys

import numpy as np
import pandas as pd
from ablation_table import MEASURES, verdict

from sumo_rail.evaluation.evaluate import SAMPLED_SUFFIX
from sumo_rail.evaluation.statistics import interval, paired_difference
from sumo_rail.evaluation.summary import measure_samples

VARIANTS = {"all": "GAIL, every choice on", "nonorm": "GAIL, no reward normalisation",
            "nowarmup": "GAIL, no critic warm-up"}
BC = "all_s{seed}/policy_bc"


def pooled(metrics: pd.DataFrame, name: str, seeds: list[int], measure: str) -> tuple[np.ndarray, np.ndarray]:
    """The measure's (numerators, denominators) of the driver `name` (with {seed}), seeds after each other."""
    parts = [measure_samples(metrics[metrics["policy"] == name.format(seed=seed)].sort_values("seed"))[measure]
             for seed in seeds]
    return np.concatenate([part[0] for part in parts]), np.concatenate([part[1] for part in parts])


def main(path: str) -> None:
    metrics = pd.read_parquet(path)
    seeds = sorted({int(match.group(1)) for name in metrics["policy"] if (match := re.match(r"all_s(\d+)/", name))})
    print(f"{metrics.groupby('policy').size().max()} episodes per policy; training seeds {seeds}; cells: value [95% "
          f"interval]; differences pair each seed's policy with the same seed's reference on the same episodes.\n")
    print("| policy | measure | value | minus BC | minus every choice on, same evaluation |")
    print("|---|---|---|---|---|")
    rows = [("BC", BC, None)] + [(f"{label} ({mode})", f"{variant}_s{{seed}}/policy_latest{suffix}",
                                  f"all_s{{seed}}/policy_latest{suffix}")
                                 for mode, suffix in (("argmax", ""), ("sampled", SAMPLED_SUFFIX))
                                 for variant, label in VARIANTS.items()]
    for label, name, reference in rows:
        for measure in MEASURES:
            digits = 3 if "agreement" in measure or "lane_change_" in measure else 2
            sample = pooled(metrics, name, seeds, measure)
            cells = [interval(sample).format(digits)]
            for other in (BC, reference):
                if other in (None, name):
                    cells.append("-")
                    continue
                found = paired_difference(sample, pooled(metrics, other, seeds, measure))
                cells.append(f"{found.format(digits, signed=True)} {verdict(found)}")
            print(f"| {label} | {measure} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1])
