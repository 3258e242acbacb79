"""How much one ARS step size moves a policy: the share of demonstrated states whose decision changes.

For each run folder (made by `sumo-rail train ... --set rail.step_size=ALPHA --iterations K`), compares the policy
after K iterations (policy_latest.npz) with the BC policy it started from (policy_bc.npz), on the observations of
the demonstrations: the share of decisions that differ, the share that differ when only the weights moved (the end
weights with BC's observation normaliser; with --set rail.freeze_normalizer=false RAIL also merges its rollouts into
it) and the largest parameter change. Prints Markdown.

Usage: python experiments/step_size_effect.py DEMOS.parquet RUN [RUN ...]
"""

from __future__ import annotations

import json
from pathlib import Path

import click
import numpy as np
import pandas as pd

from sumo_rail.drivers.policies import Policy, load_policy
from sumo_rail.runners.tables import read_demonstrations


def changed_decisions(run: Path, observations: np.ndarray) -> tuple[float, float, float]:
    """(share of observations whose argmax differs after training, the same with BC's normaliser kept, largest
    absolute parameter change)."""
    start, _ = load_policy(run / "policy_bc.npz")
    end, _ = load_policy(run / "policy_latest.npz")
    weights_only = Policy(end.shape, end.parameters, start.observation_mean, start.observation_std)
    before = np.argmax(start.logits(observations), axis=1)
    return (float((np.argmax(end.logits(observations), axis=1) != before).mean()),
            float((np.argmax(weights_only.logits(observations), axis=1) != before).mean()),
            float(np.abs(end.parameters - start.parameters).max()))


def main(demos_path: str, *runs: str) -> None:
    observations = read_demonstrations(Path(demos_path)).observations
    print("| step size | directions | iterations | decisions changed | by the weights alone | largest weight change |")
    print("|---:|---:|---:|---:|---:|---:|")
    for run in map(Path, runs):
        settings = json.loads((run / "run.json").read_text())["settings"]["rail"]
        iterations = len(pd.read_parquet(run / "log.parquet", columns=["iteration"]))
        share, by_weights, largest = changed_decisions(run, observations)
        print(f"| {settings['step_size']} | {settings['directions']} | {iterations} | {share:.2%} | {by_weights:.2%} "
              f"| {largest:.1e} |")


@click.command(help=__doc__)
@click.argument("demos_path", type=click.Path(exists=True, dir_okay=False))
@click.argument("runs", nargs=-1, required=True, type=click.Path(exists=True, file_okay=False))
def cli(demos_path: str, runs: tuple[str, ...]) -> None:
    main(demos_path, *runs)


if __name__ == "__main__":
    cli()
