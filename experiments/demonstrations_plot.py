"""The figure of specs/demonstrations_sweep.toml: on-policy agreement, lane-change recall and lane changes per
episode of BC, RAIL and DAgger against the number of expert episodes they learned from, each point over the
training seeds with its 95% interval (experiments/seeded.py) and each run's own estimate as a dot, the expert's
lane changes dashed. Prints the table as Markdown, then RAIL - BC and DAgger - BC in agreement and lane changes
at each count (paired seed by seed and episode by episode: RAIL seed s starts from BC seed s), and writes
OUT_DIR/demonstrations.png.

Usage: python experiments/demonstrations_plot.py OUT_DIR COUNT [COUNT ...]   (reads OUT_DIR/test_kCOUNT.parquet)
"""

from __future__ import annotations

from pathlib import Path

import click
import pandas as pd
from benchmark_table import expert_driver
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from seeded import difference_cell, digits_of, pooled, seed_samples, training_seeds

from sumo_rail.evaluation.statistics import Sample, ratio
from sumo_rail.evaluation.summary import measure_samples

METHODS = {"bc": "BC", "rail": "RAIL", "dagger": "DAgger"}
MEASURES = {"agreement": "on-policy agreement", "lane_change_recall": "lane-change recall",
            "lane_changes": "lane changes per episode"}
COMPARED = ("rail", "dagger")
"""Methods compared with BC (method - BC)."""
DIFFERENCES = ("agreement", "lane_changes")
DODGE = 1.08
"""Factor between neighbouring methods' x positions on the log axis."""

PerSeed = list[dict[str, Sample]]


def evaluations(out: Path, counts: list[int]) -> dict[int, pd.DataFrame]:
    """count -> the per-episode metrics of its test evaluation, for the counts already evaluated."""
    return {count: pd.read_parquet(path) for count in counts if (path := out / f"test_k{count}.parquet").is_file()}


def per_seed(metrics: pd.DataFrame, method: str, count: int) -> PerSeed:
    stem = f"{method}_k{count}"
    return seed_samples(metrics, stem, training_seeds(metrics, stem))


def plot(found: dict[int, dict[str, PerSeed]], expert_lane_changes: float) -> Figure:
    figure = Figure(figsize=(14, 4), layout="constrained")
    FigureCanvasAgg(figure)
    counts = list(found)
    for axes, (measure, label) in zip(figure.subplots(1, len(MEASURES)), MEASURES.items(), strict=True):
        for offset, (method, name) in enumerate(METHODS.items()):
            shifted = [count * DODGE ** (offset - 1) for count in counts]  # side by side, not on top of each other
            intervals = [pooled(found[count][method], measure) for count in counts]
            errors = [[interval.estimate - interval.low for interval in intervals],
                      [interval.high - interval.estimate for interval in intervals]]
            bars = axes.errorbar(shifted, [interval.estimate for interval in intervals], yerr=errors, marker="o",
                                 capsize=3, label=name)
            for x, count in zip(shifted, counts, strict=True):  # each training run's own estimate
                runs = [float(ratio(samples[measure])) for samples in found[count][method]]
                axes.scatter([x] * len(runs), runs, s=10, color=bars.lines[0].get_color(), alpha=0.5, zorder=3)
        if measure == "lane_changes":
            axes.axhline(expert_lane_changes, color="black", linestyle="--", linewidth=1, label="expert")
            axes.set_ylim(bottom=0)
        else:
            axes.set_ylim(0, 1)
        axes.set(xscale="log", xlabel="expert episodes demonstrated", ylabel=label)
        axes.set_xticks(counts, labels=[str(count) for count in counts])
        axes.minorticks_off()
        axes.grid(alpha=0.3)
    axes.legend()
    return figure


def main(out: Path, counts: list[int]) -> None:
    tests = evaluations(out, counts)
    found = {count: {method: per_seed(metrics, method, count) for method in METHODS}
             for count, metrics in tests.items()}
    print("| expert episodes | seeds | " + " | ".join(f"{METHODS[method]} {label}" for method in METHODS
                                                      for label in MEASURES.values()) + " |")
    print("|---:|---:|" + "---|" * len(METHODS) * len(MEASURES))
    for count in counts:
        cells = [pooled(found[count][method], measure).format(digits_of(measure))
                 if count in found else "-" for method in METHODS for measure in MEASURES]
        seeds = len(found[count]["bc"]) if count in found else 0
        print(f"| {count} | {seeds} | " + " | ".join(cells) + " |")
    print("\n| expert episodes | " + " | ".join(f"{METHODS[method]} - BC {measure.replace('_', ' ')}"
                                               for measure in DIFFERENCES for method in COMPARED) + " |")
    print("|---:|" + "---|" * len(COMPARED) * len(DIFFERENCES))
    for count, methods in found.items():
        cells = [difference_cell(methods[method], methods["bc"], measure, digits_of(measure))
                 for measure in DIFFERENCES for method in COMPARED]
        print(f"| {count} | " + " | ".join(cells) + " |")
    if found:
        first = next(iter(tests.values()))  # every count's test drives the expert on the same episodes
        expert = measure_samples(first[first["policy"] == expert_driver(first)].sort_values("seed"))
        plot(found, float(ratio(expert["lane_changes"]))).savefig(out / "demonstrations.png", dpi=120)


@click.command(help=__doc__)
@click.argument("out", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("counts", nargs=-1, required=True, type=click.IntRange(min=1))
def cli(out: Path, counts: tuple[int, ...]) -> None:
    main(out, list(counts))


if __name__ == "__main__":
    cli()
