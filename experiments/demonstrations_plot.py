"""The figure of experiments/demonstrations_sweep.sh: on-policy agreement and lane-change recall of BC, RAIL and
DAgger against the number of expert episodes they learned from, each point over the training seeds with its 95%
interval (experiments/seeded.py). Prints the table as Markdown and writes OUT_DIR/demonstrations.png.

Usage: python experiments/demonstrations_plot.py OUT_DIR COUNT [COUNT ...]   (reads OUT_DIR/test_kCOUNT.parquet)
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from seeded import seed_samples, training_seeds

from sumo_rail.evaluation.statistics import Interval, seeded_interval

METHODS = {"bc": "BC", "rail": "RAIL", "dagger": "DAgger"}
MEASURES = {"agreement": "on-policy agreement", "lane_change_recall": "lane-change recall"}


def points(out: Path, counts: list[int]) -> dict[tuple[str, str], list[tuple[int, Interval]]]:
    """(method, measure) -> [(count, interval over the seeds)] for the counts already evaluated."""
    found: dict[tuple[str, str], list[tuple[int, Interval]]] = {}
    for count in counts:
        path = out / f"test_k{count}.parquet"
        if not path.is_file():
            continue
        metrics = pd.read_parquet(path)
        for method in METHODS:
            stem = f"{method}_k{count}"
            per_seed = seed_samples(metrics, stem, training_seeds(metrics, stem))
            for measure in MEASURES:
                found.setdefault((method, measure), []).append(
                    (count, seeded_interval([samples[measure] for samples in per_seed])))
    return found


def plot(found: dict[tuple[str, str], list[tuple[int, Interval]]], counts: list[int]) -> Figure:
    figure = Figure(figsize=(10, 4), layout="constrained")
    FigureCanvasAgg(figure)
    for axes, (measure, label) in zip(figure.subplots(1, 2), MEASURES.items(), strict=True):
        for method, name in METHODS.items():
            series = found.get((method, measure), [])
            counts = [count for count, _ in series]
            estimates = [found.estimate for _, found in series]
            errors = [[found.estimate - found.low for _, found in series],
                      [found.high - found.estimate for _, found in series]]
            axes.errorbar(counts, estimates, yerr=errors, marker="o", capsize=3, label=name)
        axes.set(xscale="log", xlabel="expert episodes demonstrated", ylabel=label, ylim=(0, 1))
        axes.set_xticks(counts, labels=[str(count) for count in counts])
        axes.minorticks_off()
        axes.grid(alpha=0.3)
    axes.legend()
    return figure


def main(out: Path, counts: list[int]) -> None:
    found = points(out, counts)
    print("| expert episodes | " + " | ".join(f"{METHODS[method]} {label}" for method in METHODS
                                                for measure, label in MEASURES.items()) + " |")
    print("|---:|" + "---|" * len(METHODS) * len(MEASURES))
    for count in counts:
        cells = [next((interval.format(3) for n, interval in found.get((method, measure), []) if n == count), "-")
                 for method in METHODS for measure in MEASURES]
        print(f"| {count} | " + " | ".join(cells) + " |")
    plot(found, counts).savefig(out / "demonstrations.png", dpi=120)


if __name__ == "__main__":
    main(Path(sys.argv[1]), [int(count) for count in sys.argv[2:]])
