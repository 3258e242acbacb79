"""The table of experiments/specs/gail_choices.toml from one evaluation (validation episodes).

Drivers are named VARIANT_sSEED/policy_latest, with " (sampled)" when evaluated by sampling, and
all_sSEED/policy_bc (BC, every variant's start). For each variant, evaluation and measure: its value over the
training seeds, and its paired differences to BC and to GAIL with every choice on evaluated the same way, with a
verdict and each seed's own difference (experiments/seeded.py says how seeds are pooled). Prints Markdown.

Usage: python experiments/gail_choices_table.py METRICS.parquet
"""

from __future__ import annotations

import click
import pandas as pd
from ablation_table import MEASURES
from seeded import difference_cell, digits_of, seed_samples, training_seeds, value_cell

from sumo_rail.runners.experts import SAMPLED_SUFFIX

VARIANTS = {"all": "GAIL, every choice on", "nonorm": "GAIL, no reward normalisation",
            "nowarmup": "GAIL, no critic warm-up"}


def main(path: str) -> None:
    metrics = pd.read_parquet(path)
    seeds = training_seeds(metrics, "all")
    print(f"{metrics.groupby('policy').size().max()} episodes per policy; training seeds {seeds}; cells: value [95% "
          f"interval] over training runs and episodes, each run's own estimate in brackets.\n")
    print("| policy | measure | value | minus BC | minus every choice on, same evaluation |")
    print("|---|---|---|---|---|")
    bc = seed_samples(metrics, "all", seeds, "policy_bc")
    rows = [("BC", bc, None)]
    for mode, suffix in (("argmax", ""), ("sampled", SAMPLED_SUFFIX)):
        every_choice = seed_samples(metrics, "all", seeds, f"policy_latest{suffix}")
        rows += [(f"{label} ({mode})", seed_samples(metrics, variant, seeds, f"policy_latest{suffix}"),
                  None if variant == "all" else every_choice) for variant, label in VARIANTS.items()]
    for label, samples, reference in rows:
        for measure in MEASURES:
            digits = digits_of(measure)
            cells = [value_cell(samples, measure, digits)]
            cells += ["-" if other is None or other is samples else difference_cell(samples, other, measure, digits)
                      for other in (bc, reference)]
            print(f"| {label} | {measure} | " + " | ".join(cells) + " |")


@click.command(help=__doc__)
@click.argument("path", type=click.Path(exists=True, dir_okay=False))
def cli(path: str) -> None:
    main(path)


if __name__ == "__main__":
    cli()
