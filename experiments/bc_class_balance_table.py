"""The table of experiments/specs/bc_class_balance.toml: BC with class balance 0.75 against plain cross-entropy
(balance 0), paired seed by seed and episode by episode on the same validation episodes (experiments/seeded.py says
how seeds are pooled). Prints Markdown.

Usage: python experiments/bc_class_balance_table.py VALIDATION.parquet
"""

from __future__ import annotations

import click
import pandas as pd
from seeded import difference_cell, digits_of, seed_samples, training_seeds, value_cell

MEASURES = ("agreement", "lane_change_recall", "lane_change_precision", "average_speed_kmh", "lane_changes")
LABELS = {"balance0": "BC, plain cross-entropy (balance 0)", "balance075": "BC, class weights (balance 0.75)"}


def main(path: str) -> None:
    metrics = pd.read_parquet(path)
    seeds = training_seeds(metrics, "balance0")
    samples = {name: seed_samples(metrics, name, seeds) for name in LABELS}
    print(f"{metrics.groupby('policy').size().max()} validation episodes, training seeds "
          f"{', '.join(map(str, seeds))}\n")
    print("| driver | " + " | ".join(MEASURES) + " |")
    print("|---|" + "---|" * len(MEASURES))
    for name, label in LABELS.items():
        print(f"| {label} | " + " | ".join(value_cell(samples[name], measure, digits_of(measure))
                                           for measure in MEASURES) + " |")
    print("\n| balance 0.75 minus balance 0 | " + " | ".join(
        difference_cell(samples["balance075"], samples["balance0"], measure, digits_of(measure))
        for measure in MEASURES) + " |")


@click.command(help=__doc__)
@click.argument("path", type=click.Path(exists=True, dir_okay=False))
def cli(path: str) -> None:
    main(path)


if __name__ == "__main__":
    cli()
