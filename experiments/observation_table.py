"""The tables of specs/observation_study.toml: per design, BC's held-out accuracy on demonstrations and the
on-policy agreement with the expert of BC (round 0) and of each DAgger round on validation episodes (point
estimates on the rounds' few episodes), then the final paired evaluation of BC and DAgger's last policy on the
same validation episodes, with 95% intervals, and each design's difference to the first design's on those episodes
(pairs are episodes with the same seed and warm state).

Usage: python experiments/observation_table.py OUT_DIR DESIGN [DESIGN ...] (prints Markdown; writes the agreement
per round of every design to OUT_DIR/agreement_by_round.png). Reads each design's DAgger log from
DESIGN/dagger/log.parquet or its committed copy DESIGN/dagger_log.parquet; the final tables need
DESIGN/validation.parquet and leave out a design without it (docs/results/observation_study commits only evaluate's
printout, validation.txt).
"""

from __future__ import annotations

from pathlib import Path

import click
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from sumo_rail.config import Config
from sumo_rail.evaluation.statistics import interval, paired_difference
from sumo_rail.evaluation.summary import measure_samples
from sumo_rail.sim.observation import observation_space

MEASURES = ("agreement", "lane_change_recall", "lane_change_precision")
# Each design's settings, as specs/observation_study.toml sets them (the observation size follows from them).
DESIGN_SETTINGS: dict[str, dict[str, dict[str, int]]] = {
    "lidar24": {}, "lidar72": {"lidar": {"beams": 72}}, "lidar24_lanes": {"observation": {"lane_block": 1}},
    "lidar24_sensor_expert": {"expert": {"view_range_m": 100}},
    "lidar24_lanes_sensor_expert": {"observation": {"lane_block": 1}, "expert": {"view_range_m": 100}}}


def dagger_log(folder: Path) -> pd.DataFrame:
    """A design's DAgger log: the run's own (dagger/log.parquet) or the committed copy (dagger_log.parquet)."""
    path = folder / "dagger" / "log.parquet"
    return pd.read_parquet(path if path.is_file() else folder / "dagger_log.parquet")


def final_samples(path: Path) -> tuple[dict, dict]:
    """The per-episode measure samples of BC and of DAgger's last policy in a final evaluation, in seed order."""
    metrics = pd.read_parquet(path)
    return tuple(measure_samples(metrics[metrics["policy"].str.endswith(stem)].sort_values("seed"))
                 for stem in ("/policy_bc", "/policy_latest"))


def main(out: Path, designs: list[str]) -> None:
    logs = {design: dagger_log(out / design) for design in designs}
    rounds = max(len(log) for log in logs.values())
    print("| design | observation size | BC held-out accuracy | BC agreement (lane-change recall) | "
          + " | ".join(f"DAgger round {r} agreement (recall)" for r in range(1, rounds)) + " |")
    print("|---|---:|---:|---|" + "---|" * (rounds - 1))
    for design, log in logs.items():
        size = observation_space(Config().with_overrides(DESIGN_SETTINGS[design])).shape[0]
        cells = [f"{row.eval_agreement:.3f} ({row.eval_lane_change_recall:.2f})" for row in log.itertuples()]
        print(f"| {design} | {size} | {log['bc_holdout_accuracy'].iloc[0]:.3f} | " + " | ".join(cells) + " |")
    finals = {design: final_samples(out / design / "validation.parquet") for design in designs
              if (out / design / "validation.parquet").is_file()}
    if finals:
        print("\n| design | measure | BC | DAgger, last round | DAgger - BC (paired) |")
        print("|---|---|---|---|---|")
    for design, (bc, dagger) in finals.items():
        for measure in MEASURES:
            print(f"| {design} | {measure} | {interval(bc[measure]).format(3)} | "
                  f"{interval(dagger[measure]).format(3)} | "
                  f"{paired_difference(dagger[measure], bc[measure]).format(3, signed=True)} |")
    baseline = designs[0]
    if baseline in finals:
        print(f"\n| design | measure | BC - {baseline}'s BC (paired) | DAgger - {baseline}'s DAgger (paired) |")
        print("|---|---|---|---|")
        for design, samples in list(finals.items())[1:]:
            for measure in MEASURES:
                print(f"| {design} | {measure} | " + " | ".join(
                    paired_difference(mine[measure], theirs[measure]).format(3, signed=True)
                    for mine, theirs in zip(samples, finals[baseline], strict=True)) + " |")
    plot_rounds(logs).savefig(out / "agreement_by_round.png", dpi=120)


def plot_rounds(logs: dict[str, pd.DataFrame]) -> Figure:
    """On-policy agreement (left) and lane-change recall (right) against DAgger round (0: BC), one line a design."""
    figure = Figure(figsize=(10, 4), layout="constrained")
    FigureCanvasAgg(figure)
    for axes, column, label in zip(figure.subplots(1, 2), ("eval_agreement", "eval_lane_change_recall"),
                                   ("on-policy agreement", "lane-change recall"), strict=True):
        for design, log in logs.items():
            axes.plot(range(len(log)), log[column], marker="o", label=design)
        axes.set(xlabel="DAgger round (0: BC)", ylabel=label, ylim=(0, 1))
        axes.xaxis.set_major_locator(MaxNLocator(integer=True))
        axes.grid(alpha=0.3)
    axes.legend(fontsize="small")
    return figure


@click.command(help=__doc__)
@click.argument("out", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("designs", nargs=-1, required=True)
def cli(out: Path, designs: tuple[str, ...]) -> None:
    main(out, list(designs))


if __name__ == "__main__":
    cli()
