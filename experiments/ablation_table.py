"""The table of experiments/specs/rail_ablations.toml from one evaluation (validation or test episodes).

Drivers are named VARIANT_sSEED/policy_* (one per variant and training seed). For each variant and measure: its
value pooled over the training seeds, and its paired difference to BC and to `independent` (RAIL as first
implemented) on the same episodes, with a verdict and each seed's own difference (experiments/seeded.py says how
seeds are pooled); then each single choice, the two variants that differ only in it against each other; then how
far each variant's search moved from BC (the run folders beside METRICS.parquet). Prints Markdown.

Usage: python experiments/ablation_table.py METRICS.parquet
"""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
import pandas as pd
from benchmark_table import expert_driver
from seeded import difference_cell, digits_of, seed_samples, training_seeds, value_cell

from sumo_rail.drivers.policies import load_policy
from sumo_rail.evaluation.statistics import interval
from sumo_rail.evaluation.summary import measure_samples

MEASURES = ("agreement", "lane_change_recall", "lane_change_precision", "average_speed_kmh", "overtakes",
            "lane_changes", "collisions")
VARIANTS = ("bc", "bcnorm", "independent", "indfrozen", "crn", "frozen", "v2", "disc5")
LABELS = {"bc": "BC", "bcnorm": "BC weights, RAIL's final normaliser", "independent": "RAIL, independent traffic",
          "indfrozen": "RAIL, independent traffic, frozen normaliser", "crn": "RAIL, common traffic",
          "frozen": "RAIL, common traffic, frozen normaliser", "v2": "RAIL, common traffic, V2 (all directions)",
          "disc5": "RAIL, common traffic, discriminator x5"}

CHOICES = (  # (what the choice is, variant with it, variant without it)
    ("frozen normaliser, with independent traffic", "indfrozen", "independent"),
    ("frozen normaliser, with common traffic", "frozen", "crn"),
    ("common traffic, with merged normaliser", "crn", "independent"),
    ("common traffic, with frozen normaliser", "frozen", "indfrozen"),
    ("V2 (all N directions) against V2-t (top N / 2)", "v2", "crn"),
    ("discriminator steps x5", "disc5", "crn"),
    ("RAIL's final normaliser under BC's weights (no search)", "bcnorm", "bc"),
)
CHOICE_MEASURES = ("agreement", "lane_change_recall", "average_speed_kmh", "overtakes", "lane_changes")


def main(path: str) -> None:
    metrics = pd.read_parquet(path)
    seeds = training_seeds(metrics, "crn")
    samples = {variant: seed_samples(metrics, variant, seeds) for variant in VARIANTS}
    episodes = metrics.groupby("policy").size().max()
    print(f"{episodes} episodes per policy; training seeds {seeds}; cells: value [95% interval] over training "
          f"runs and episodes (experiments/seeded.py), each run's own estimate in brackets.\n")
    print("| variant | measure | value | minus BC | minus RAIL, independent traffic |")
    print("|---|---|---|---|---|")
    expert = measure_samples(metrics[metrics["policy"] == expert_driver(metrics)].sort_values("seed"))
    for measure in MEASURES[3:]:  # the expert's own agreement and lane-change rates are 1
        print(f"| expert | {measure} | {interval(expert[measure]).format(digits_of(measure))} | | |")
    for variant in VARIANTS:
        for measure in MEASURES:
            digits = digits_of(measure)
            cells = [value_cell(samples[variant], measure, digits)]
            cells += ["-" if reference == variant else
                      difference_cell(samples[variant], samples[reference], measure, digits)
                      for reference in ("bc", "independent")]
            print(f"| {LABELS[variant]} | {measure} | " + " | ".join(cells) + " |")
    print("\n| choice | " + " | ".join(CHOICE_MEASURES) + " |")
    print("|---|" + "---|" * len(CHOICE_MEASURES))
    for label, with_it, without in CHOICES:
        print(f"| {label} | " + " | ".join(difference_cell(samples[with_it], samples[without], measure,
                                                            digits_of(measure)) for measure in CHOICE_MEASURES) + " |")
    print("\n| variant | mean distance of the weights from BC's | discriminator return, first 3 iterations | "
          "last 3 iterations |")
    print("|---|---:|---:|---:|")
    for variant in VARIANTS[2:]:  # the RAIL runs
        runs = [Path(path).parent / f"{variant}_s{seed}" for seed in seeds]
        print(f"| {LABELS[variant]} | " + " | ".join(f"{value:.3f}" for value in movement(runs)) + " |")


def movement(runs: list[Path]) -> tuple[float, float, float]:
    """Mean over runs of |theta_end - theta_BC| and of the discriminator return of the first and last 3 iterations."""
    distances, first, last = [], [], []
    for run in runs:
        start, _ = load_policy(run / "policy_bc.npz")
        end, _ = load_policy(run / "policy_latest.npz")
        distances.append(np.linalg.norm(end.parameters - start.parameters))
        returns = pd.read_parquet(run / "log.parquet", columns=["return_mean"])["return_mean"].to_numpy()
        first.append(returns[:3].mean())
        last.append(returns[-3:].mean())
    return float(np.mean(distances)), float(np.mean(first)), float(np.mean(last))


@click.command(help=__doc__)
@click.argument("path", type=click.Path(exists=True, dir_okay=False))
def cli(path: str) -> None:
    main(path)


if __name__ == "__main__":
    cli()
