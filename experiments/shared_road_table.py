"""The table of specs/shared_road.toml: RAIL, DAgger and GAIL (by argmax and sampled) trained with K egos per
simulation minus the same method trained with one, paired by training seed and test episode (experiments/seeded.py).
Prints Markdown.

Usage: python experiments/shared_road_table.py K METRICS.parquet [METRICS.parquet ...]   (evaluations on the same
test episodes: the K runs' and the benchmark's committed test_sSEED.parquet; where one drove fewer, the episodes
every evaluation drove)
"""

from __future__ import annotations

import click
import pandas as pd
from seeded import difference_cell, digits_of, seed_samples, training_seeds, value_cell

MEASURES = ("agreement", "lane_change_recall", "average_speed_kmh", "overtakes", "lane_changes", "collisions")
METHODS = {"RAIL, two-layer": ("rail_mlp", "policy_latest"), "DAgger, two-layer": ("dagger", "policy_latest"),
           "GAIL, argmax": ("gail", "policy_latest"), "GAIL, sampled": ("gail", "policy_latest (sampled)")}
"""Label -> the K = 1 runs' folder stem and driver name; the K runs are rail_kK, dagger_kK and gail_kK. A method
whose runs are missing from the evaluations is left out."""


def main(egos: int, *paths: str) -> None:
    paths = tuple(path for path in paths if not path.endswith(".decisions.parquet"))  # a shell glob may catch them
    metrics = pd.concat([pd.read_parquet(path) for path in paths]).drop_duplicates(["policy", "seed"])
    shared = set.intersection(*(set(group["seed"]) for _, group in metrics.groupby("policy")))
    metrics = metrics[metrics["seed"].isin(shared)]  # a shorter evaluation pairs with the others' first episodes
    print(f"{len(shared)} test episodes (one ego each, those every evaluation drove); each driver pooled over its "
          f"training seeds\n")
    print("| method | egos per simulation in training | seeds | " + " | ".join(MEASURES) + " |")
    print("|---|---|---|" + "---|" * len(MEASURES))
    pairs = {}
    for label, (alone, driver) in METHODS.items():
        shared = f"{alone.split('_')[0]}_k{egos}"
        seeds = sorted(set(training_seeds(metrics, shared)) & set(training_seeds(metrics, alone)))
        if not seeds:
            continue
        pairs[label] = seeds, [seed_samples(metrics, stem, seeds, driver) for stem in (shared, alone)]
        for count, samples in zip((egos, 1), pairs[label][1], strict=True):
            print(f"| {label} | {count} | {len(seeds)} | " + " | ".join(
                value_cell(samples, measure, digits_of(measure)) for measure in MEASURES) + " |")
    print(f"\nK = {egos} minus K = 1, paired by training seed and episode:\n")
    print("| method | seeds | " + " | ".join(MEASURES) + " |")
    print("|---|---|" + "---|" * len(MEASURES))
    for label, (seeds, (shared, alone)) in pairs.items():
        print(f"| {label} | {', '.join(map(str, seeds))} | " + " | ".join(
            difference_cell(shared, alone, measure, digits_of(measure)) for measure in MEASURES) + " |")


@click.command(help=__doc__)
@click.argument("egos", type=click.IntRange(min=1))
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False))
def cli(egos: int, paths: tuple[str, ...]) -> None:
    main(egos, *paths)


if __name__ == "__main__":
    cli()
