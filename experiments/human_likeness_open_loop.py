"""Open-loop human-likeness (docs/results.md, "Learning from recorded drivers"): BC trained on the recorded drivers
of a scene's train split, asked at every decision of the held-out (test) drivers what it would do, against the
action read off their tracks; beside it the always-keep baseline (the majority action). Each BC seed is paired with
the baseline vehicle by vehicle (experiments/seeded.py's pooling over training seeds).

    python experiments/human_likeness_open_loop.py train OUT_DIR TAG [TAG ...]   # BC x 3 seeds, writes counts
    python experiments/human_likeness_open_loop.py table COUNTS.parquet           # the table, from the counts

`train` reads OUT_DIR/train_tTAG.parquet and OUT_DIR/test_tTAG.parquet (sumo-rail recorded-demos) and writes
OUT_DIR/open_loop.parquet: per scene, driver and test vehicle, its decisions, the agreed ones, its read lane changes
and the agreed ones among them.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import click
import numpy as np
import pandas as pd
import pyarrow as pa

from sumo_rail.datasets import write_parquet
from sumo_rail.drivers.policies import PolicyShape
from sumo_rail.evaluation.statistics import seeded_interval
from sumo_rail.learning.bc import IMITATION_BC, behaviour_cloning
from sumo_rail.runners.tables import read_demonstrations
from sumo_rail.sim.actions import Action

SEEDS = (0, 1, 2)
LANE_CHANGES = (Action.LANE_LEFT, Action.LANE_RIGHT)


def counts(tag: str, driver: str, episodes: np.ndarray, read: np.ndarray, chosen: np.ndarray) -> pd.DataFrame:
    """Per test vehicle (an episode of the test demonstrations): decisions, agreed, read lane changes, agreed ones."""
    frame = pd.DataFrame({"episode": episodes, "agreed": chosen == read, "lane_change": np.isin(read, LANE_CHANGES)})
    frame["lane_change_agreed"] = frame["agreed"] & frame["lane_change"]
    grouped = frame.groupby("episode").agg(decisions=("agreed", "size"), agreed=("agreed", "sum"),
                                           lane_changes=("lane_change", "sum"),
                                           lane_changes_agreed=("lane_change_agreed", "sum")).reset_index()
    return grouped.assign(scene=tag, driver=driver)


def train(out: Path, tags: list[str]) -> None:
    rows = []
    for tag in tags:
        demos = read_demonstrations(out / f"train_t{tag}.parquet")
        test = read_demonstrations(out / f"test_t{tag}.parquet")
        shape = PolicyShape("mlp", demos.observations.shape[1])
        rows.append(counts(tag, "keep", test.episodes, test.actions, np.zeros_like(test.actions)))
        for seed in SEEDS:
            policy, _ = behaviour_cloning(demos, shape, dataclasses.replace(IMITATION_BC, seed=seed))
            chosen = np.argmax(policy.logits(test.observations), axis=1)
            rows.append(counts(tag, f"bc_s{seed}", test.episodes, test.actions, chosen))
    table = pd.concat(rows, ignore_index=True)
    metadata = {"kind": "human_likeness_open_loop", "scenes": tags, "seeds": list(SEEDS),
                "bc": dataclasses.asdict(IMITATION_BC)}
    write_parquet(pa.Table.from_pandas(table, preserve_index=False), out / "open_loop.parquet", metadata)


def sample(frame: pd.DataFrame, numerator: str, denominator: str) -> tuple[np.ndarray, np.ndarray]:
    ordered = frame.sort_values(["scene", "episode"])
    return ordered[numerator].to_numpy(float), ordered[denominator].to_numpy(float)


def table(path: Path) -> None:
    frame = pd.read_parquet(path)
    keep = frame[frame["driver"] == "keep"]
    bc = [frame[frame["driver"] == f"bc_s{seed}"] for seed in SEEDS]
    scenes = sorted(frame["scene"].unique())
    print(f"{len(scenes)} scenes of SUMO's drivers (seeds {', '.join(scenes)}), {len(keep)} held-out drivers, "
          f"{int(keep['decisions'].sum())} decisions ({int(keep['lane_changes'].sum())} read lane changes); "
          f"BC with training seeds {', '.join(map(str, SEEDS))}\n")
    print("| driver | agreement with the held-out drivers' read actions | lane-change recall |")
    print("|---|---|---|")
    for label, runs in (("always keep", [keep] * len(SEEDS)), ("BC", bc)):
        cells = [seeded_interval([sample(run, num, den) for run in runs], share=True).format(3)
                 for num, den in (("agreed", "decisions"), ("lane_changes_agreed", "lane_changes"))]
        print(f"| {label} | {cells[0]} | {cells[1]} |")
    cells = [seeded_interval([sample(run, num, den) for run in bc],
                             [sample(keep, num, den)] * len(SEEDS), share=True).format(3, signed=True)
             for num, den in (("agreed", "decisions"), ("lane_changes_agreed", "lane_changes"))]
    print(f"| BC minus always keep (paired by vehicle) | {cells[0]} | {cells[1]} |")


@click.group(help=__doc__)
def cli() -> None:
    pass


@cli.command("train")
@click.argument("out", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("tags", nargs=-1, required=True)
def train_command(out: Path, tags: tuple[str, ...]) -> None:
    train(out, list(tags))


@cli.command("table")
@click.argument("path", type=click.Path(exists=True, dir_okay=False, path_type=Path))
def table_command(path: Path) -> None:
    table(path)


if __name__ == "__main__":
    cli()
