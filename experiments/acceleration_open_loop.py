"""BC on the acceleration interface, open loop (docs/results.md, "Learning from recorded drivers: the acceleration
interface"): at every decision of the held-out drivers (recorded-demos of their split), the acceleration BC chooses
against the one read off the track, and how much of it is the last command shown in the observation: the share of
decisions that repeat it (the humans' own share beside it), and what BC chooses when the last command reads 0 m/s^2
(how a seat began before the seat showed its lead-in's last period), against the humans' share of 0 m/s^2.

    python experiments/acceleration_open_loop.py counts [--decodings D,D] [--runs GLOB] OUT.parquet RUNS_DIR DEMOS...
    python experiments/acceleration_open_loop.py table COUNTS.parquet

`counts` reads each DEMOS file (named acceleration_hH_SPLIT_tSCENE.parquet) with the BC policies of RUNS_DIR of the
same history (acceleration_hH_pP_sSEED/policy_bc.npz; with --runs, those matching GLOB) and writes, per demonstration
file, driver (the human or a BC run), decoding (how the BC policy's logits become its action, `actions.decoding`:
argmax unless --decodings names others) and held-out vehicle, its decisions and the counts the table pools
(`COLUMNS`).
"""

from __future__ import annotations

import re
from pathlib import Path

import click
import numpy as np
import pandas as pd
import pyarrow as pa

from sumo_rail.action_config import ActionConfig
from sumo_rail.datasets import read_metadata, write_parquet
from sumo_rail.drivers.policies import load_policy
from sumo_rail.evaluation.statistics import seeded_interval
from sumo_rail.runners.tables import read_demonstrations
from sumo_rail.sim.observation import acceleration_slot

DEMOS = re.compile(r"acceleration_(h\d+)_\w+_t\d+\.parquet")
RUN = re.compile(r"acceleration_(h\d+)_(p\d+)_s(\d+)")
COLUMNS = {"exact bin": ("exact", "decisions"), "mean |error| [m/s^2]": ("abs_error_mps2", "decisions"),
           "repeats the last command": ("repeats", "decisions"), "0 m/s^2": ("zero", "decisions"),
           "0 m/s^2 when the last command reads 0": ("zero_after_zero", "asked_after_zero")}
"""Table heading -> the (numerator, denominator) counts per vehicle: sums over its decisions."""


def accelerations(actions: np.ndarray, interface: ActionConfig) -> np.ndarray:
    """The acceleration [m/s^2] of each acceleration-interface action (its bin: `split_acceleration_action`)."""
    return interface.acceleration_mps2(np.asarray(actions) % interface.acceleration_bins)


def vehicle_counts(episodes: np.ndarray, read: np.ndarray, chosen: np.ndarray, shown: np.ndarray,
                   after_zero: np.ndarray) -> pd.DataFrame:
    """Per vehicle (episode), the `COLUMNS` counts of a driver choosing `chosen` [m/s^2] where the track reads `read`
    and the last command shown is `shown`, and `after_zero` where it is shown as 0 (NaN: not asked there)."""
    frame = pd.DataFrame({"episode": episodes, "decisions": 1, "exact": chosen == read,
                          "abs_error_mps2": np.abs(chosen - read), "repeats": np.isclose(chosen, shown),
                          "zero": chosen == 0.0, "zero_after_zero": after_zero == 0.0,
                          "asked_after_zero": ~np.isnan(after_zero)})
    return frame.groupby("episode").sum().reset_index()


def counts(out: Path, runs: Path, demos: list[Path], decodings: list[str], pattern: str = "") -> None:
    rows = []
    for path in demos:
        history = DEMOS.fullmatch(path.name)[1]
        interface = ActionConfig(**read_metadata(path)["config"]["actions"])
        read = read_demonstrations(path, interface=interface)
        slot = read.metadata["observation_names"].index("last_acceleration")
        truth = accelerations(read.actions, interface)
        shown = interface.acceleration_mps2(np.round(read.observations[:, slot] * (interface.acceleration_bins - 1)))
        zeroed = read.observations.copy()
        zeroed[:, slot] = acceleration_slot(0.0, interface)
        rows.append(vehicle_counts(read.episodes, truth, truth, shown, np.where(shown == 0.0, truth, np.nan))
                    .assign(demos=path.name, driver="human"))
        for folder in sorted(runs.glob(f"acceleration_{history}_p*_s*")):
            if pattern and not folder.match(pattern):
                continue
            policy, _ = load_policy(folder / "policy_bc.npz")
            for decoding in decodings:
                chosen, after_zero = (accelerations(policy.decoded_by(decoding).acts(observations), interface)
                                      for observations in (read.observations, zeroed))
                rows.append(vehicle_counts(read.episodes, truth, chosen, shown, after_zero)
                            .assign(demos=path.name, driver=folder.name, decoding=decoding))
    write_parquet(pa.Table.from_pandas(pd.concat(rows, ignore_index=True), preserve_index=False), out,
                  {"kind": "acceleration_open_loop", "demos": [path.name for path in demos]})


def table(path: Path) -> None:
    frame = pd.read_parquet(path)
    if "decoding" not in frame:  # counted before the decoding existed: argmax
        frame = frame.assign(decoding="argmax")
    humans = frame[(frame["driver"] == "human") & frame["demos"].str.startswith("acceleration_h0_")]
    print(f"{len(humans)} held-out drivers, {int(humans['decisions'].sum())} decisions; each a share of the decisions "
          f"(mean |error| per decision; the last column's humans: their share of 0 m/s^2 after a period of 0), 95% "
          f"intervals over vehicles and training seeds\n")
    print("| driver | " + " | ".join(COLUMNS) + " |")
    print("|---|" + "---|" * len(COLUMNS))
    methods: dict[str, tuple[list[pd.DataFrame], list[pd.DataFrame] | None]] = {
        "humans (read off their tracks)": ([humans], None)}
    learners = frame[frame["driver"] != "human"]
    for (setting, decoding), runs in learners.groupby([learners["driver"].str.replace(r"_s\d+$", "", regex=True),
                                                       learners["decoding"]]):
        history, balance = RUN.fullmatch(f"{setting}_s0").groups()[:2]
        label = f"BC, history {history[1:]} s, balance {float('0.' + balance[1:]):g}"
        ordered = [run.sort_values(["demos", "episode"]) for _, run in runs.groupby("driver")]
        methods[label if decoding == "argmax" else f"{label}, {decoding} decoding"] = (ordered, None)
        if decoding != "argmax":  # paired by training seed and vehicle with the same policies' argmax
            methods[f"{label}, {decoding} - argmax"] = (ordered, methods[label][0])
    for label, (runs, argmax) in methods.items():
        cells = [seeded_interval(*[None if group is None else
                                   [(run[numerator].to_numpy(float), run[denominator].to_numpy(float))
                                    for run in group] for group in (runs, argmax)])
                 .format(2 if numerator == "abs_error_mps2" else 3)
                 for numerator, denominator in COLUMNS.values()]
        print(f"| {label} | " + " | ".join(cells) + " |")


@click.group(help=__doc__)
def cli() -> None:
    pass


@cli.command("counts")
@click.option("--decodings", default="argmax", show_default=True, help="Decodings, comma-separated.")
@click.option("--runs", default="", help="A glob of the run folders to count (default: all).")
@click.argument("out", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("runs_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("demos", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path))
def counts_command(decodings: str, runs: str, out: Path, runs_dir: Path, demos: tuple[Path, ...]) -> None:
    counts(out, runs_dir, list(demos), decodings.split(","), runs)


@cli.command("table")
@click.argument("path", type=click.Path(exists=True, dir_okay=False, path_type=Path))
def table_command(path: Path) -> None:
    table(path)


if __name__ == "__main__":
    cli()
