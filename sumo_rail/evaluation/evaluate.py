"""Evaluate drivers (the expert, built-in drivers, saved policies) on the same seeds; metrics and their summary."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from sumo_rail.config import Config
from sumo_rail.datasets import write_parquet
from sumo_rail.drivers.expert import STYLES
from sumo_rail.drivers.policies import PolicyFileError, load_policy
from sumo_rail.runners.backends import RolloutBackend
from sumo_rail.runners.rollout import DriverSpec, EpisodeTask, ExpertDriver, KeepDriver, PolicyDriver, RandomDriver
from sumo_rail.runners.tables import EPISODE_METRICS, METRIC_COLUMNS, metrics_table, provenance
from sumo_rail.sim.observation import observation_names

SUMMARY_METRICS = ("average_speed_kmh", "overtakes", "lane_changes", "longitudinal_reward", "lateral_reward",
                   "collisions", "hard_braking", "invalid_actions", "distance_m", "steps")
"""Rows of the printed summary (the paper's metrics first)."""


def parse_driver(text: str, config: Config, default_style: str) -> DriverSpec:
    """'expert', 'expert:STYLE', 'keep', 'random', or the path of a saved policy file (named by `policy_name`)."""
    name, _, style = text.partition(":")
    if name == "expert":
        style = style or default_style
        if style not in STYLES:
            raise ValueError(f"unknown expert style {style!r}; known styles: {', '.join(sorted(STYLES))}")
        return ExpertDriver(style)
    if text == "keep":
        return KeepDriver()
    if text == "random":
        return RandomDriver()
    policy, metadata = load_policy(Path(text))
    expected = observation_names(config)
    if policy.shape.observation_size != len(expected):
        raise PolicyFileError(f"policy {text} expects {policy.shape.observation_size} observations, the "
                              f"environment gives {len(expected)}")
    stored = metadata.get("observation_names")
    if stored is not None and list(stored) != expected:
        raise PolicyFileError(f"policy {text} was trained on a different observation layout than this environment's")
    return PolicyDriver(policy, name=policy_name(Path(text)))


def policy_name(path: Path) -> str:
    """A policy file's name in tables: RUN/STEM for a file of a training run folder (it holds run.json), so
    runs/a/policy_bc.npz and runs/b/policy_bc.npz stay apart; the file's stem otherwise."""
    return f"{path.parent.resolve().name}/{path.stem}" if (path.parent / "run.json").is_file() else path.stem


def evaluate(drivers: Sequence[DriverSpec], config: Config, seeds: Sequence[int], backend: RolloutBackend,
             on_episode: Callable[[int, Any], None] | None = None) -> pd.DataFrame:
    """Every driver on every seed; one row per episode (METRIC_COLUMNS), drivers in the given order."""
    names = unique_names(drivers)
    tasks = [EpisodeTask(config, driver, seed) for driver in drivers for seed in seeds]
    results = backend.run(tasks, on_result=on_episode)
    rows = [{"policy": names[index // len(seeds)], "episode": index % len(seeds), **result.metrics}
            for index, result in enumerate(results)]
    return pd.DataFrame(rows, columns=list(METRIC_COLUMNS))


def unique_names(drivers: Sequence[DriverSpec]) -> list[str]:
    """Driver names, suffixed with #2, #3... where two drivers share a name."""
    names: list[str] = []
    for driver in drivers:
        name, count = driver.name, 1
        while name in names:
            count += 1
            name = f"{driver.name}#{count}"
        names.append(name)
    return names


def write_metrics(metrics: pd.DataFrame, config: Config, seed: int, out: Path, **extra: Any) -> None:
    """The metrics table with provenance, atomically."""
    write_parquet(metrics_table(metrics.to_dict("records")), out, provenance(EPISODE_METRICS, config, seed, **extra))


def summary_table(metrics: pd.DataFrame) -> str:
    """Rows: metrics; columns: drivers; cells: mean +- std over episodes (the paper's table layout)."""
    drivers = list(dict.fromkeys(metrics["policy"]))
    grouped = metrics.groupby("policy", sort=False)
    cells = {driver: [] for driver in drivers}
    for metric in SUMMARY_METRICS:
        means, stds = grouped[metric].mean(), grouped[metric].std(ddof=0)
        for driver in drivers:
            cells[driver].append(f"{means[driver]:.2f} +- {stds[driver]:.2f}")
    table = pd.DataFrame(cells, index=[*SUMMARY_METRICS])
    episodes = grouped.size()
    header = ", ".join(f"{driver}: {episodes[driver]} episodes" for driver in drivers)
    return f"{header}\n{table.to_string()}"
