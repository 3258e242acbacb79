"""What a policy would do on a demonstrations file's states: its mean action probabilities (softmax of its logits),
how often each action is its argmax (what `evaluate --policy` drives), and the share of states where it gives the
two lane changes together more than 0.2. Prints Markdown.

Usage: python experiments/policy_actions.py DEMOS.parquet POLICY.npz [POLICY.npz ...]
"""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from sumo_rail.drivers.policies import load_policy
from sumo_rail.runners.tables import read_demonstrations
from sumo_rail.sim.actions import Action

NAMES = [action.name.lower() for action in Action]


def main(demos_path: str, *policy_paths: str) -> None:
    rows = []
    for path in policy_paths:
        policy, _ = load_policy(Path(path))
        demos = read_demonstrations(Path(demos_path), policy.shape.observation_size)
        probabilities = policy.probabilities(demos.observations)
        argmax = np.bincount(probabilities.argmax(axis=1), minlength=len(NAMES)) / len(probabilities)
        lane_change = float((probabilities[:, [Action.LANE_LEFT, Action.LANE_RIGHT]].sum(axis=1) > 0.2).mean())
        rows.append((path, probabilities.mean(axis=0), argmax, lane_change, len(probabilities)))
    print(f"{rows[0][4]} states of {demos_path}\n")
    print("| policy | mean probability (" + ", ".join(NAMES) + ") | argmax share (" + ", ".join(NAMES)
          + ") | states with P(lane change) > 0.2 |")
    print("|---|---|---|---|")
    for path, mean, argmax, lane_change, _ in rows:
        print(f"| {path} | {', '.join(f'{value:.3f}' for value in mean)} | "
              f"{', '.join(f'{value:.3f}' for value in argmax)} | {lane_change:.3f} |")


@click.command(help=__doc__)
@click.argument("demos_path", type=click.Path(exists=True, dir_okay=False))
@click.argument("policy_paths", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False))
def cli(demos_path: str, policy_paths: tuple[str, ...]) -> None:
    main(demos_path, *policy_paths)


if __name__ == "__main__":
    cli()
