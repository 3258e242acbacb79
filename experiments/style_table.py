"""The table of experiments/specs/style_fidelity.toml: for each style (calm, sporty) and method (BC, RAIL, DAgger, over
their training seeds, experiments/seeded.py), agreement with the expert of the style it learned from, and on speed,
overtakes and lane changes the difference to its own expert and to the other style's expert, with which is
closer (point estimates); then RAIL - BC and DAgger - BC in agreement, paired. Prints Markdown.

Usage: python experiments/style_table.py METRICS.parquet
"""

from __future__ import annotations

import click
import pandas as pd
from seeded import difference_cell, digits_of, seed_samples, training_seeds, value_cell

from sumo_rail.evaluation.statistics import ratio
from sumo_rail.evaluation.summary import measure_samples

STYLES = ("calm", "sporty")
METHODS = {"bc": "BC", "rail": "RAIL", "dagger": "DAgger"}
MEASURES = ("average_speed_kmh", "overtakes", "lane_changes")


def main(path: str) -> None:
    metrics = pd.read_parquet(path)
    experts = {style: measure_samples(metrics[metrics["policy"] == f"expert-{style}"].sort_values("seed"))
               for style in STYLES}
    print(f"{int((metrics['policy'] == 'expert-calm').sum())} test episodes; cells: value or difference [95% "
          f"interval] over training runs and episodes, each run's own in brackets.\n")
    print("| style | method | agreement with its own expert | measure | minus its own expert | minus the other "
          "expert | closer to |")
    print("|---|---|---|---|---|---|---|")
    for style in STYLES:
        other = STYLES[1 - STYLES.index(style)]
        for method, label in METHODS.items():
            stem = f"{method}_{style}"
            per_seed = seed_samples(metrics, stem, training_seeds(metrics, stem))
            agreement = value_cell(per_seed, "agreement", 3)
            for measure in MEASURES:
                digits = digits_of(measure)
                own, theirs = ([experts[name]] * len(per_seed) for name in (style, other))
                pooled = sum(ratio(samples[measure]) for samples in per_seed) / len(per_seed)
                closer = style if abs(pooled - ratio(experts[style][measure])) <= abs(
                    pooled - ratio(experts[other][measure])) else other
                print(f"| {style} | {label} | {agreement} | {measure} | "
                      f"{difference_cell(per_seed, own, measure, digits)} | "
                      f"{difference_cell(per_seed, theirs, measure, digits)} | {closer} |")
    print("\n| style | comparison (paired by seed and episode) | agreement difference |")
    print("|---|---|---|")
    for style in STYLES:
        per_method = {method: seed_samples(metrics, f"{method}_{style}", training_seeds(metrics, f"{method}_{style}"))
                      for method in METHODS}
        for method in ("rail", "dagger"):
            print(f"| {style} | {METHODS[method]} - BC | "
                  f"{difference_cell(per_method[method], per_method['bc'], 'agreement', 3)} |")


@click.command(help=__doc__)
@click.argument("path", type=click.Path(exists=True, dir_okay=False))
def cli(path: str) -> None:
    main(path)


if __name__ == "__main__":
    cli()
