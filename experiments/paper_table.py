"""The paper's table (expert, RAIL stacked, RAIL linear: 16 episodes, 40 trajectories, its Unity simulator) beside this
project's benchmark on the same rows, plus agreement and BC; and RAIL at the paper's N = 512 from BC
(specs/paper_scale.toml: each run's test.parquet holds the expert, the run's BC and its RAIL on the benchmark's
test episodes), with RAIL minus its own BC paired by training seed and episode. Prints Markdown.

Usage: python experiments/paper_table.py BENCH_DIR [PAPER_SCALE_DIR]
"""

from __future__ import annotations

from pathlib import Path

import click
import pandas as pd
from benchmark_table import expert_driver, read_evaluations
from seeded import difference_cell, digits_of, pooled, seed_samples, training_seeds

from sumo_rail.evaluation.statistics import interval
from sumo_rail.evaluation.summary import measure_samples

ROWS = ("average_speed_kmh", "overtakes", "lane_changes", "longitudinal_reward", "lateral_reward", "agreement")
PAPER = {"expert": (68.83, 44.48, 14.04, 2642.11, -132.52), "RAIL stacked": (70.38, 45.04, 15.01, 2719.38, -122.98),
         "RAIL linear": (65.00, 40.03, 13.05, 2495.57, -175.6)}
"""The paper's Table (tab:experiment) in ROWS' order; it reports no agreement."""
BENCHMARK = {"BC, two-layer": ("bc_mlp", "policy_bc"), "RAIL two-layer, N = 32": ("rail_mlp", "policy_latest"),
             "RAIL linear, N = 32": ("rail_linear", "policy_latest")}


def paper_scale_runs(folder: Path) -> pd.DataFrame:
    """Every N = 512 run's test evaluation; the expert kept once."""
    frames = [pd.read_parquet(path) for path in sorted(folder.glob("*/test.parquet"))]
    if not frames:
        return pd.DataFrame()
    expert = expert_driver(frames[0])
    return pd.concat([frames[0], *[frame[frame["policy"] != expert] for frame in frames[1:]]])


def main(bench: Path, paper_scale: Path | None) -> None:
    metrics, _, _, expert_name = read_evaluations(bench)
    columns = {"expert": [measure_samples(metrics[metrics["policy"] == expert_name].sort_values("seed"))]}
    for label, (stem, policy) in BENCHMARK.items():
        columns[label] = seed_samples(metrics, stem, training_seeds(metrics, stem), policy)
    pairs = []
    scale = paper_scale_runs(paper_scale) if paper_scale is not None else pd.DataFrame()
    for stem in sorted({name.split("_s")[0] for name in scale.get("policy", []) if name.startswith("n512")}):
        seeds = training_seeds(scale, stem)
        mine, start = seed_samples(scale, stem, seeds, "policy_latest"), seed_samples(scale, stem, seeds, "policy_bc")
        label = f"RAIL two-layer, N = 512, {stem.split('_')[1].replace('a', 'alpha ')}"
        columns[f"BC, the N = 512 runs' start ({len(seeds)})"] = start  # the same BC for every step size
        columns[label + f" ({len(seeds)})"] = mine
        pairs.append((label, mine, start))
    print("| measure | " + " | ".join(f"paper: {name}" for name in PAPER) + " | "
          + " | ".join(columns) + " |")
    print("|---|" + "---|" * (len(PAPER) + len(columns)))
    for row, measure in enumerate(ROWS):
        paper = [f"{values[row]:g}" if row < len(values) else "-" for values in PAPER.values()]
        ours = [interval(samples[0][measure]).format(digits_of(measure)) if len(samples) == 1
                else pooled(samples, measure).format(digits_of(measure))
                for samples in columns.values()]
        print(f"| {measure} | " + " | ".join(paper + ours) + " |")
    for label, mine, start in pairs:
        print(f"\n{label} minus its BC start (paired by training seed and episode):\n")
        print("| measure | difference |\n|---|---|")
        for measure in ROWS:
            print(f"| {measure} | {difference_cell(mine, start, measure, digits_of(measure))} |")


@click.command(help=__doc__)
@click.argument("bench", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("paper_scale", required=False, type=click.Path(exists=True, file_okay=False, path_type=Path))
def cli(bench: Path, paper_scale: Path | None) -> None:
    main(bench, paper_scale)


if __name__ == "__main__":
    cli()
