"""The benchmark's figure (experiments/specs/imitation_table.toml): for each method, on-policy agreement, lane-change
recall, lane changes and overtakes per episode, pooled over its training seeds with the 95% interval of
experiments/seeded.py (bar), each training run's own estimate (dots) and the expert's value (dashed line).

Usage: python experiments/benchmark_plot.py OUT_DIR FIGURE.png   (reads OUT_DIR/test_sSEED.parquet)
"""

from __future__ import annotations

from pathlib import Path

import click
from benchmark_table import METHODS, methods_found, read_evaluations
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from sumo_rail.evaluation.statistics import ratio, seeded_interval
from sumo_rail.evaluation.summary import SHARES, measure_samples

PANELS = {"agreement": "on-policy agreement with the expert", "lane_change_recall": "lane-change recall",
          "lane_changes": "lane changes per episode", "overtakes": "overtakes per episode"}


def main(out: Path, figure_path: Path) -> None:
    metrics, _, _, expert_name = read_evaluations(out)
    expert = measure_samples(metrics[metrics["policy"] == expert_name].sort_values("seed"))
    found = methods_found(metrics)
    labels = [f"{METHODS[key][0]} ({len(seeds)} seeds)" for key, (seeds, _) in found.items()]
    figure = Figure(figsize=(12, 0.45 * len(found) + 2.2), layout="constrained")
    FigureCanvasAgg(figure)
    for index, (axes, (measure, title)) in enumerate(zip(figure.subplots(1, len(PANELS), sharey=True),
                                                         PANELS.items(), strict=True)):
        for row, (_, (_, samples)) in enumerate(found.items()):
            pooled = seeded_interval([run[measure] for run in samples], share=measure in SHARES)
            axes.errorbar(pooled.estimate, row, xerr=[[pooled.estimate - pooled.low], [pooled.high - pooled.estimate]],
                          fmt="s", color="tab:blue", capsize=3)
            axes.plot([ratio(run[measure]) for run in samples], [row] * len(samples), "o", color="tab:orange",
                      alpha=0.7, markersize=4)
        axes.axvline(ratio(expert[measure]), color="black", linestyle="--", linewidth=1)
        axes.set(title=title, ylim=(len(found) - 0.5, -0.5))
        axes.grid(axis="x", alpha=0.3)
        if index == 0:
            axes.set_yticks(range(len(found)), labels=labels)
    figure.suptitle("square and bar: pooled over training seeds, 95% interval; dots: each training run; "
                    "dashed: the expert (same test episodes)", fontsize="medium")
    figure.savefig(figure_path, dpi=120)


@click.command(help=__doc__)
@click.argument("out", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("figure_path", type=click.Path(dir_okay=False, path_type=Path))
def cli(out: Path, figure_path: Path) -> None:
    main(out, figure_path)


if __name__ == "__main__":
    cli()
