"""Print the environment decisions a training run used (the sum of env_steps in its log.parquet), the budget GAIL is
given to match it.

Usage: python experiments/env_steps.py RUN_FOLDER/log.parquet
"""

from __future__ import annotations

import click
import pandas as pd


@click.command(help=__doc__)
@click.argument("path", type=click.Path(exists=True, dir_okay=False))
def cli(path: str) -> None:
    print(int(pd.read_parquet(path, columns=["env_steps"])["env_steps"].sum()))


if __name__ == "__main__":
    cli()
