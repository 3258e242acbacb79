"""The table of specs/rail_remedies.toml: every variant against BC and against the paper's setting, paired by
training seed and episode (experiments/seeded.py says how seeds are pooled). Prints Markdown.

Usage: python experiments/remedies_table.py METRICS.parquet [METRICS.parquet ...]   (evaluations on the same validation
episodes, e.g. later variants evaluated apart, are read as one)
"""

from __future__ import annotations

import click
import pandas as pd
from seeded import difference_cell, digits_of, seed_samples, training_seeds, value_cell

MEASURES = ("agreement", "lane_change_recall", "average_speed_kmh", "overtakes", "lane_changes")
LABELS = {
    "bc": "BC (the start of every run)",
    "paper": "RAIL, the paper's setting (train's defaults: nu 0.03, 1 episode)",
    "agreement": "search on agreement itself (control), nu 0.03",
    "agreement_flip20": "search on agreement itself (control), flip rate 0.2",
    "agreement_flip20_ep4": "search on agreement itself (control), flip rate 0.2, 4 episodes",
    "flip20": "RAIL, flip rate 0.2",
    "flip20_ep4": "RAIL, flip rate 0.2, 4 episodes",
    "ep4": "RAIL, 4 episodes",
    "balanced_flip20": "RAIL, balanced discriminator, flip rate 0.2",
    "rank_flip20": "RAIL, centred ranks, flip rate 0.2",
}


def main(*paths: str) -> None:
    metrics = pd.concat([pd.read_parquet(path) for path in paths]).drop_duplicates(["policy", "seed"])
    seeds = training_seeds(metrics, "bc")
    variants = [name for name in LABELS if training_seeds(metrics, name) == seeds]
    samples = {name: seed_samples(metrics, name, seeds) for name in variants}
    print(f"{metrics.groupby('policy').size().max()} validation episodes, training seeds "
          f"{', '.join(map(str, seeds))}\n")
    print("| driver | " + " | ".join(MEASURES) + " |")
    print("|---|" + "---|" * len(MEASURES))
    for name in variants:
        print(f"| {LABELS[name]} | " + " | ".join(value_cell(samples[name], measure, digits_of(measure))
                                                  for measure in MEASURES) + " |")
    for reference in ("bc", "paper"):
        print(f"\nEach minus {LABELS[reference]}:\n")
        print("| driver | " + " | ".join(MEASURES) + " |")
        print("|---|" + "---|" * len(MEASURES))
        for name in variants:
            if name in ("bc", reference):
                continue
            print(f"| {LABELS[name]} | " + " | ".join(
                difference_cell(samples[name], samples[reference], measure, digits_of(measure))
                for measure in MEASURES) + " |")


@click.command(help=__doc__)
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False))
def cli(paths: tuple[str, ...]) -> None:
    main(*paths)


if __name__ == "__main__":
    cli()
