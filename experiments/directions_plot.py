"""The figure of experiments/directions_sweep.sh: for each number of directions N, validation agreement with the
expert against environment decisions (mean over training seeds, the seeds' range shaded), and the discriminator's
mean return beside it (it moves with the discriminator, so it is the secondary panel). Prints a table of each N's
cost (decisions per iteration: mean over seeds; wall time per iteration: the fastest seed's, as a run sharing the
machine only gets slower) and last validation agreement, with N = 512 projected from a straight-line fit of the
cost in N (a projection, not a run). Writes OUT_DIR/directions.png.

Usage: python experiments/directions_plot.py OUT_DIR N [N ...]   (reads OUT_DIR/nN_sSEED/log.parquet)
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import EngFormatter, LogLocator, NullFormatter

PROJECTED = 512
LAST = 3
"""Validations averaged for a run's final agreement (one validation of 20 episodes is noisy)."""


def logs(out: Path, size: int) -> list[pd.DataFrame]:
    """The logs of every training seed of N = size, with cumulative decisions."""
    found = []
    for folder in sorted(out.glob(f"n{size}_s*")):
        if re.fullmatch(rf"n{size}_s\d+", folder.name) and (folder / "log.parquet").is_file():
            log = pd.read_parquet(folder / "log.parquet")
            found.append(log.assign(decisions=log["env_steps"].cumsum()))
    return found


def across_seeds(runs: list[pd.DataFrame], column: str) -> pd.DataFrame:
    """Mean, min and max of a column over the seeds at each iteration all of them logged it."""
    table = pd.concat([run.set_index("iteration")[[column, "decisions"]] for run in runs], axis=1,
                      keys=range(len(runs)))
    values = table.xs(column, axis=1, level=1).dropna()
    decisions = table.xs("decisions", axis=1, level=1).loc[values.index].mean(axis=1)
    return pd.DataFrame({"decisions": decisions, "mean": values.mean(axis=1), "low": values.min(axis=1),
                         "high": values.max(axis=1)})


def plot(curves: dict[int, list[pd.DataFrame]]) -> Figure:
    figure = Figure(figsize=(11, 4.2), layout="constrained")
    FigureCanvasAgg(figure)
    panels = figure.subplots(1, 2)
    for axes, column, label in zip(panels, ("eval_agreement", "return_mean"),
                                   ("validation agreement with the expert", "discriminator return (mean)"),
                                   strict=True):
        for size, runs in curves.items():
            series = across_seeds(runs, column)
            line, = axes.plot(series["decisions"], series["mean"], marker="o", markersize=3,
                              label=f"N = {size} ({len(runs)} seed{'s' * (len(runs) > 1)})")
            axes.fill_between(series["decisions"], series["low"], series["high"], color=line.get_color(), alpha=0.15)
        axes.set(xlabel="environment decisions", ylabel=label, xscale="log")
        axes.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))  # 10k, 20k, 50k, 100k, ...
        axes.xaxis.set_major_formatter(EngFormatter())
        axes.xaxis.set_minor_formatter(NullFormatter())
        axes.grid(alpha=0.3)
    panels[0].set_ylim(0, 1)
    panels[0].legend(fontsize="small")
    return figure


def main(out: Path, sizes: list[int]) -> None:
    curves = {size: runs for size in sizes if (runs := logs(out, size))}
    print("| N | seeds | iterations | decisions per iteration | wall time per iteration [s] | first validation "
          f"agreement (mean over seeds) | mean of the last {LAST} validations (mean, range over seeds) |")
    print("|---:|---:|---:|---:|---:|---:|---|")
    costs = []
    for size, runs in curves.items():
        steps = np.mean([run["env_steps"].mean() for run in runs])
        seconds = min(run["wall_time_s"].mean() for run in runs)  # the least disturbed run
        costs.append((size, steps, seconds))
        validations = [run["eval_agreement"].dropna() for run in runs]
        first = np.mean([values.iloc[0] for values in validations])
        last = [values.iloc[-LAST:].mean() for values in validations]
        print(f"| {size} | {len(runs)} | {min(len(run) for run in runs)} | {steps:,.0f} | {seconds:.1f} | "
              f"{first:.3f} | {np.mean(last):.3f} ({min(last):.3f}-{max(last):.3f}) |")
    if len(costs) >= 2:
        sizes_run, steps, seconds = (np.array(column, dtype=float) for column in zip(*costs, strict=True))
        projected = [np.polyval(np.polyfit(sizes_run, values, 1), PROJECTED) for values in (steps, seconds)]
        print(f"| {PROJECTED} (projected) | - | - | {projected[0]:,.0f} | {projected[1]:.1f} | not run | not run |")
    plot(curves).savefig(out / "directions.png", dpi=120)


if __name__ == "__main__":
    main(Path(sys.argv[1]), [int(size) for size in sys.argv[2:]])
