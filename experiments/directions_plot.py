"""The figure of experiments/specs/directions_sweep.toml: for each number of directions N, validation agreement with the
expert against training iterations and against environment decisions (mean over training seeds, the seeds' range
shaded), and the discriminator's mean return beside them (it moves with the discriminator, so it is the secondary
panel). Prints a table of each N's cost (decisions per iteration: mean over seeds; wall time per iteration: the
fastest seed's, as a run sharing the machine only gets slower), its last validation agreement, and whether each
run's agreement has flattened: the slope of agreement over the run's last half of validations (at least
TREND_POINTS of them) with its 95% interval: "rising" while the interval lies above 0 (the run was cut short),
"falling" where it lies below 0, "flattened" where it holds 0 and lies below FLAT (a further rise, if any, is too
slow to matter), "undecided" when it is too wide to say. Runs with no validation yet are left out. Beside it,
how far the search moved the weights against how far a search without signal would wander (experiments/wander.py;
about 1 when the steps are noise). N = 512 is projected from a straight-line fit of the cost in N (a projection,
not a run) until a run of N = 512 is there. Runs whose rollouts are decision budgets on K respawning egos
(experiments/specs/directions_sweep.toml with EGOS, folders nN_kKr_sSEED) are a series of their own.
Writes OUT_DIR/directions.png.

Usage: python experiments/directions_plot.py OUT_DIR [SERIES ...]   (reads OUT_DIR/SERIES_sSEED/log.parquet, a
series being nN or nN_kKr; without SERIES, every series found there)
"""

from __future__ import annotations

import re
from pathlib import Path

import click
import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import EngFormatter, LogLocator, NullFormatter
from wander import wander

from sumo_rail.evaluation.statistics import Interval, slope

PROJECTED = 512
RUN_FOLDER = re.compile(r"(n(\d+)(?:_k(\d+)r?)?)_s\d+")
"""A run's folder: SERIES_sSEED, the series nN (one ego, whole episodes) or nN_kKr (K respawning egos)."""
LAST = 3
"""Validations averaged for a run's final agreement (one validation of 20 episodes is noisy)."""
TREND_POINTS = 4
"""The fewest validations a run's trend is fitted on (its last half when it has more)."""
TREND_PER = 10
"""The trend's unit: change of agreement per this many iterations."""
FLAT = 0.01
"""A run has flattened when its trend's upper bound is below this [agreement per TREND_PER iterations]."""


def series_found(out: Path) -> list[str]:
    """The series of the runs in `out`, by N ascending, one-ego runs first."""
    found = {match.group(1): (int(match.group(2)), int(match.group(3) or 1))
             for folder in out.iterdir() if (match := RUN_FOLDER.fullmatch(folder.name))}
    return sorted(found, key=found.__getitem__)


def size_of(series: str) -> int:
    """N of a series."""
    return int(RUN_FOLDER.fullmatch(f"{series}_s0").group(2))  # type: ignore[union-attr]


def label(series: str) -> str:
    """'128', or '512, 8 respawning egos'."""
    egos = RUN_FOLDER.fullmatch(f"{series}_s0").group(3)  # type: ignore[union-attr]
    return f"{size_of(series)}" + (f", {egos} respawning egos" if egos else "")


def logs(out: Path, series: str) -> list[pd.DataFrame]:
    """The logs of every training seed of a series that has a validation, with cumulative decisions."""
    runs = []
    for folder in sorted(out.glob(f"{series}_s*")):
        name = RUN_FOLDER.fullmatch(folder.name)
        if name and name.group(1) == series and (folder / "log.parquet").is_file():
            log = pd.read_parquet(folder / "log.parquet").assign(decisions=lambda log: log["env_steps"].cumsum())
            log.attrs["folder"] = folder
            if log["eval_agreement"].notna().any():
                runs.append(log)
    return runs


def across_seeds(runs: list[pd.DataFrame], column: str) -> pd.DataFrame:
    """Mean, min and max of a column over the seeds at each iteration all of them logged it (iterations done,
    from 1, and decisions done)."""
    table = pd.concat([run.set_index("iteration")[[column, "decisions"]] for run in runs], axis=1,
                      keys=range(len(runs)))
    values = table.xs(column, axis=1, level=1).dropna()
    decisions = table.xs("decisions", axis=1, level=1).loc[values.index].mean(axis=1)
    return pd.DataFrame({"iteration": values.index + 1, "decisions": decisions, "mean": values.mean(axis=1),
                         "low": values.min(axis=1), "high": values.max(axis=1)})


def trend(run: pd.DataFrame) -> Interval:
    """The slope of validation agreement [per TREND_PER iterations] over the run's last half of validations."""
    validations = run.dropna(subset=["eval_agreement"])
    last = validations.iloc[-max(TREND_POINTS, -(-len(validations) // 2)):]
    found = slope(last["iteration"].to_numpy(), last["eval_agreement"].to_numpy())
    return Interval(*(TREND_PER * value for value in (found.estimate, found.low, found.high)))


def trend_word(found: Interval) -> str:
    """'rising' or 'falling' where the trend's interval lies above or below 0, else 'flattened' where it lies below
    FLAT, else 'undecided'."""
    if found.low > 0 or found.high < 0:
        return "rising" if found.low > 0 else "falling"
    return "flattened" if found.high < FLAT else "undecided"


def plot(curves: dict[str, list[pd.DataFrame]]) -> Figure:
    figure = Figure(figsize=(15, 4.2), layout="constrained")
    FigureCanvasAgg(figure)
    panels = figure.subplots(1, 3)
    agreement = "validation agreement with the expert"
    for axes, column, x, ylabel in zip(panels, ("eval_agreement", "eval_agreement", "return_mean"),
                                      ("iteration", "decisions", "iteration"),
                                      (agreement, agreement, "discriminator return (mean)"), strict=True):
        for name, runs in curves.items():
            series = across_seeds(runs, column)
            line, = axes.plot(series[x], series["mean"], marker="o", markersize=3,
                              label=f"N = {label(name)} ({len(runs)} seed{'s' * (len(runs) > 1)})")
            axes.fill_between(series[x], series["low"], series["high"], color=line.get_color(), alpha=0.15)
        axes.set(xlabel="training iteration" if x == "iteration" else "environment decisions", ylabel=ylabel)
        axes.grid(alpha=0.3)
    panels[1].set_xscale("log")
    panels[1].xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))  # 10k, 20k, 50k, 100k, ...
    panels[1].xaxis.set_major_formatter(EngFormatter())
    panels[1].xaxis.set_minor_formatter(NullFormatter())
    top = max(0.3, *(run["eval_agreement"].max() for runs in curves.values() for run in runs))
    for axes in panels[:2]:
        axes.set_ylim(0, min(1.0, 1.15 * top))
    panels[0].legend(fontsize="small")
    return figure


def main(out: Path, names: list[str]) -> None:
    curves = {name: runs for name in names if (runs := logs(out, name))}
    print("| N | seeds | iterations | decisions per iteration | wall time per iteration [s] | first validation "
          f"agreement (mean over seeds) | mean of the last {LAST} validations (mean, range over seeds) | trend of "
          f"agreement over the last half of validations, per {TREND_PER} iterations (each seed) | weights moved / "
          "noise's wander (each seed) |")
    print("|---:|---:|---:|---:|---:|---:|---|---|---|")
    costs = []
    for name, runs in curves.items():
        steps = np.mean([run["env_steps"].mean() for run in runs])
        seconds = min(run["wall_time_s"].mean() for run in runs)  # the least disturbed run
        if name == f"n{size_of(name)}":  # the cost's straight line: one-ego runs
            costs.append((size_of(name), steps, seconds))
        validations = [run["eval_agreement"].dropna() for run in runs]
        first = np.mean([values.iloc[0] for values in validations])
        last = [values.iloc[-LAST:].mean() for values in validations]
        trends = "; ".join(f"{found.format(3, signed=True)} {trend_word(found)}"
                           for found in map(trend, runs))
        wanders = ", ".join(f"{wander(run.attrs['folder']).ratio:.2f}" for run in runs)
        print(f"| {label(name)} | {len(runs)} | {min(len(run) for run in runs)} | {steps:,.0f} | {seconds:.1f} | "
              f"{first:.3f} | {np.mean(last):.3f} ({min(last):.3f}-{max(last):.3f}) | {trends} | {wanders} |")
    if len(costs) >= 2 and not any(size_of(name) == PROJECTED for name in curves):
        sizes_run, steps, seconds = (np.array(column, dtype=float) for column in zip(*costs, strict=True))
        projected = [np.polyval(np.polyfit(sizes_run, values, 1), PROJECTED) for values in (steps, seconds)]
        print(f"| {PROJECTED} (projected) | - | - | {projected[0]:,.0f} | {projected[1]:.1f} | not run | not run | - "
              "| - |")
    plot(curves).savefig(out / "directions.png", dpi=120)


@click.command(help=__doc__)
@click.argument("out", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("series", nargs=-1)
def cli(out: Path, series: tuple[str, ...]) -> None:
    main(out, list(series) or series_found(out))


if __name__ == "__main__":
    cli()
