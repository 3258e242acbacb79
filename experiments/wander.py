"""How far ARS moved a run's weights, against how far a search without signal would have wandered: a
diagnostic of whether RAIL's steps follow the discriminator's reward or the returns' noise.

Usage: python experiments/wander.py RUN_DIR [RUN_DIR ...]   (prints each run's iterations, N, b, moved and ratio)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import click
import numpy as np

from sumo_rail.datasets import read_json_record
from sumo_rail.drivers.policies import load_policy
from sumo_rail.learning.rail.ars import NoiseAdaptation, ars_update
from sumo_rail.learning.rail.iteration import RailSettings

REPLICATES = 20
"""Simulated searches without signal that a run's distance is compared with."""


@dataclass(frozen=True)
class Wander:
    """How far a run's search moved its weights."""

    iterations: int
    settings: RailSettings
    moved: float
    """||theta_T - theta_0||: theta_0 is BC's weights, or zeros without BC."""
    ratio: float
    """moved over `noise_wander` of the same search: about 1 where the weights moved as far as a search without
    signal goes, and it stays so as T grows; a consistent drift makes it grow as sqrt(T)."""


def noise_wander(settings: RailSettings, size: int, iterations: int, seed: int = 0) -> float:
    """The root mean square of ||theta_T - theta_0|| over REPLICATES searches of `size` weights whose returns are
    independent standard normal draws whatever the directions (a search without signal), stepped by ARS's own
    `ars_update` with the run's N, b and alpha. Steps are alpha / (b sigma_R) times a sum of b terms (r+ - r-)
    delta, so such a search wanders about sqrt(2) alpha sqrt(T size / b), a little more as the top-b selection
    keeps the widest pairs."""
    rng = np.random.default_rng(seed)
    squares = []
    for _ in range(REPLICATES):
        theta = np.zeros(size, np.float32)
        for _ in range(iterations):
            deltas = rng.standard_normal((settings.directions, size), np.float32)
            plus, minus = rng.standard_normal((2, settings.directions))
            theta = ars_update(theta, deltas, plus, minus, settings.kept, settings.step_size).parameters
        squares.append(float(np.sum(theta.astype(float) ** 2)))
    return float(np.sqrt(np.mean(squares)))


def wander(folder: Path) -> Wander:
    """The search of the run in `folder` (run.json, policy_latest.npz and, with BC, policy_bc.npz)."""
    rail = read_json_record(folder / "run.json", "run record")["settings"]["rail"]
    settings = RailSettings(**{**rail, "noise": NoiseAdaptation(**rail["noise"])})
    policy, metadata = load_policy(folder / "policy_latest.npz")
    start = (load_policy(folder / "policy_bc.npz")[0].parameters if (folder / "policy_bc.npz").is_file()
             else np.zeros_like(policy.parameters))
    moved = float(np.linalg.norm(policy.parameters.astype(float) - start))
    iterations = int(metadata["iteration"])
    return Wander(iterations, settings, moved, moved / noise_wander(settings, policy.parameters.size, iterations))


def main(folders: list[Path]) -> None:
    print("| run | iterations | N | b | weights moved | moved / noise's wander |")
    print("|---|---:|---:|---:|---:|---:|")
    for folder in folders:
        found = wander(folder)
        print(f"| {folder} | {found.iterations} | {found.settings.directions} | {found.settings.kept} | "
              f"{found.moved:.2f} | {found.ratio:.2f} |")


@click.command(help=__doc__)
@click.argument("folders", nargs=-1, required=True, type=click.Path(exists=True, file_okay=False, path_type=Path))
def cli(folders: tuple[Path, ...]) -> None:
    main(list(folders))


if __name__ == "__main__":
    cli()
