"""Behaviour cloning's training and held-out accuracy against its epochs, for demonstration files of different
sizes (two-layer policy, train's class balance; the held-out episodes are BC's own split). Shows whether a fixed
number of epochs trains BC on a few episodes: each epoch is a pass over the data, so fewer episodes mean fewer
gradient steps. Prints a Markdown table.

Usage: python experiments/bc_epochs.py EPOCHS[,EPOCHS...] DEMOS.parquet [DEMOS.parquet ...]
"""

from __future__ import annotations

import math
from pathlib import Path

import click

from sumo_rail.drivers.policies import PolicyShape
from sumo_rail.learning.bc import BcSettings, behaviour_cloning
from sumo_rail.runners.tables import read_demonstrations


def main(epochs: list[int], paths: list[Path]) -> None:
    print("| demonstrations | episodes | training decisions | epochs | gradient steps | training accuracy | "
          "held-out accuracy |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for path in paths:
        demos = read_demonstrations(path)
        shape = PolicyShape("mlp", demos.observations.shape[1], 10)
        for count in epochs:
            settings = BcSettings(epochs=count)  # train's other BC settings
            _, report = behaviour_cloning(demos, shape, settings)
            steps = count * math.ceil(report.train_rows / settings.batch_size)
            held_out = "n/a" if report.holdout_accuracy is None else f"{report.holdout_accuracy:.3f}"
            print(f"| {path.name} | {len(set(demos.episodes))} | {report.train_rows:,} | {count} | {steps:,} | "
                  f"{report.train_accuracy:.3f} | {held_out} |")


def _epochs(context: click.Context, parameter: click.Parameter, value: str) -> list[int]:
    try:
        return [int(count) for count in value.split(",")]
    except ValueError:
        raise click.BadParameter(f"{value!r} is not a comma-separated list of whole numbers") from None


@click.command(help=__doc__)
@click.argument("epochs", callback=_epochs)
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path))
def cli(epochs: list[int], paths: tuple[Path, ...]) -> None:
    main(epochs, list(paths))


if __name__ == "__main__":
    cli()
