"""Record the expert's demonstrations: episodes on a backend, one Parquet row per decision."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

from sumo_rail.config import Config
from sumo_rail.datasets import write_parquet
from sumo_rail.drivers.expert import STYLES
from sumo_rail.runners.backends import RolloutBackend
from sumo_rail.runners.rollout import EpisodeTask, ExpertDriver
from sumo_rail.runners.tables import DEMONSTRATIONS, demonstrations_table, provenance
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.observation import observation_space


def record_demonstrations(config: Config, style: str, seed: int, episodes: int, backend: RolloutBackend, out: Path,
                          on_episode: Callable[[int, Any], None] | None = None) -> list[dict[str, Any]]:
    """Run `episodes` expert episodes (seeds from `seed`, recording class), write them to `out`; returns metrics."""
    if style not in STYLES:
        raise ValueError(f"unknown expert style {style!r}; known styles: {', '.join(sorted(STYLES))}")
    seeds = episode_seeds(Purpose.RECORD, seed, episodes)
    driver = ExpertDriver(style)
    results = backend.run([EpisodeTask(config, driver, s, record=True) for s in seeds], on_result=on_episode)
    table = demonstrations_table(results, seeds, observation_space(config).shape[0])
    write_parquet(table, out, provenance(DEMONSTRATIONS, config, seed, driver=driver.name, style=style,
                                         style_parameters=dataclasses.asdict(STYLES[style]), episodes=episodes,
                                         episode_seeds=seeds))
    return [result.metrics for result in results]
