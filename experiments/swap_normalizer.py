"""A policy with one policy file's weights and another's observation normaliser (for the ablation "BC's weights
with the normaliser RAIL ends with": what the normaliser's drift alone does).

Usage: python experiments/swap_normalizer.py WEIGHTS.npz NORMALIZER.npz OUT.npz
"""

from __future__ import annotations

from pathlib import Path

import click

from sumo_rail.drivers.policies import Policy, load_policy, save_policy


def main(weights: Path, normalizer: Path, out: Path) -> None:
    source, metadata = load_policy(weights)
    statistics, _ = load_policy(normalizer)
    swapped = Policy(source.shape, source.parameters, statistics.observation_mean, statistics.observation_std)
    save_policy(swapped, out, {**metadata, "weights_from": str(weights), "normalizer_from": str(normalizer)})


@click.command(help=__doc__)
@click.argument("weights", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.argument("normalizer", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.argument("out", type=click.Path(dir_okay=False, path_type=Path))
def cli(weights: Path, normalizer: Path, out: Path) -> None:
    main(weights, normalizer, out)


if __name__ == "__main__":
    cli()
