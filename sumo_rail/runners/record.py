"""Record an expert's demonstrations (any driver): episodes on a backend, one Parquet row per decision."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

from sumo_rail.config import Config
from sumo_rail.datasets import write_parquet
from sumo_rail.drivers.expert import STYLES
from sumo_rail.runners.backends import RolloutBackend
from sumo_rail.runners.dart import ActionNoise
from sumo_rail.runners.rollout import DriverSpec, EpisodeGroupTask, ExpertDriver, shared_groups
from sumo_rail.runners.tables import DEMONSTRATIONS, demonstrations_table, provenance
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.observation import observation_space


def record_demonstrations(config: Config, expert: DriverSpec, name: str, seed: int, episodes: int,
                          backend: RolloutBackend, out: Path, on_episode: Callable[[int, Any], None] | None = None,
                          egos: int = 1, noise: ActionNoise | None = None) -> list[dict[str, Any]]:
    """Run `episodes` episodes of `expert` (seeds from `seed`, recording class), `egos` at a time in one simulation
    (`EpisodeGroupTask`, seeded by its group's first seed: the metadata's `egos`, `requested_episodes` and
    `simulation_seeds`), and write them to `out`, its metadata naming the expert as `name` (a style or a policy
    file, as `experts.resolve_expert` reads it); returns metrics. An ego that found no room on the road is left out
    (its seed is missing from the metadata's episode_seeds). With `noise` (DART) each ego's car executes noisy
    actions, the records keep the expert's, and the metadata's `dart` says how."""
    groups = shared_groups(episode_seeds(Purpose.RECORD, seed, episodes), egos)
    shared = backend.run([EpisodeGroupTask(config, expert, group, record=True, noise=noise) for group in groups],
                         on_result=on_episode)
    results = [result for group in shared for result in group if result is not None]
    seeds = [result.metrics["seed"] for result in results]
    table = demonstrations_table(results, seeds, observation_space(config).shape[0])
    style = ({"style": expert.style, "style_parameters": dataclasses.asdict(STYLES[expert.style])}
             if isinstance(expert, ExpertDriver) else {})
    write_parquet(table, out, provenance(DEMONSTRATIONS, config, seed, driver=expert.name, expert=name, **style,
                                         episodes=len(results), episode_seeds=seeds, egos=egos,
                                         requested_episodes=episodes,
                                         simulation_seeds=[group[0] for group in groups],
                                         **({} if noise is None else {"dart": noise.provenance()})))
    return [result.metrics for result in results]
