"""Where do learners disagree with their expert? For each method of evaluations' per-decision files (its training
seeds pooled: `dagger_s0/policy_latest` and `dagger_s1/...` are one method), the shares of its decisions where it
and where the expert asked (at the same states) would keep, the share where its action differs from the expert's,
and how those disagreements split: the expert keeps and the learner changes its speed or
asks for a lane change, the expert changes speed and the learner keeps or asks for a lane change, the expert asks for
a lane change and the learner does anything else. Prints Markdown.

Usage: python experiments/disagreements.py EVALUATION.decisions.parquet [...]
"""

from __future__ import annotations

import re

import click
import numpy as np
import pandas as pd

from sumo_rail.sim.actions import Action

SPEED = [Action.ACCELERATE, Action.DECELERATE]
LANE = [Action.LANE_LEFT, Action.LANE_RIGHT]
KINDS = {
    "expert keeps, learner changes speed": lambda expert, learner: (expert == Action.KEEP) & np.isin(learner, SPEED),
    "expert keeps, learner changes lane": lambda expert, learner: (expert == Action.KEEP) & np.isin(learner, LANE),
    "expert changes speed, learner keeps": lambda expert, learner: np.isin(expert, SPEED) & (learner == Action.KEEP),
    "expert changes speed, learner changes lane": lambda expert, learner: np.isin(expert, SPEED) & np.isin(learner,
                                                                                                         LANE),
    "expert changes lane, learner does not": lambda expert, learner: np.isin(expert, LANE),
}


def method_name(policy: str) -> str:
    """`dagger_s1/policy_latest` -> `dagger`: a driver's name without its training seed and file."""
    return re.sub(r"_s\d+$", "", policy.split("/")[0])


def disagreement_kinds(decisions: pd.DataFrame) -> pd.DataFrame:
    """One row per method other than the expert: decisions, the shares where it and the expert keep, the share in
    disagreement and each kind's share of the disagreements (the kinds are exclusive; what none covers, such as
    accelerate against decelerate, is `other`)."""
    learners = decisions[~decisions["policy"].str.startswith("expert")]
    rows = []
    for method, driver in learners.groupby(learners["policy"].map(method_name), sort=False):
        differ = driver[driver["action"] != driver["expert_action"]]
        expert, learner = differ["expert_action"].to_numpy(), differ["action"].to_numpy()
        shares = {kind: float(rule(expert, learner).mean()) for kind, rule in KINDS.items()}
        rows.append({"method": method, "decisions": len(driver),
                     "learner keeps": (driver["action"] == Action.KEEP).mean(),
                     "expert keeps": (driver["expert_action"] == Action.KEEP).mean(),
                     "disagreement": len(differ) / len(driver),
                     **shares, "other": 1.0 - sum(shares.values())})
    return pd.DataFrame(rows)


def main(*paths: str) -> None:
    table = disagreement_kinds(pd.concat([pd.read_parquet(path) for path in paths]))
    print("Share of decisions in disagreement with the expert, and how they split (shares of the disagreements)\n")
    print("| " + " | ".join(table.columns) + " |")
    print("|---|" + "---:|" * (len(table.columns) - 1))
    for row in table.itertuples(index=False):
        print("| " + " | ".join(f"{value:.3f}" if isinstance(value, float) else str(value) for value in row) + " |")


@click.command(help=__doc__)
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False))
def cli(paths: tuple[str, ...]) -> None:
    main(*paths)


if __name__ == "__main__":
    cli()
