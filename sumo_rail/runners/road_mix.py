"""A mix of roads for one training run: DAgger's rounds (`dagger --roads`) and RAIL's rollouts (`train --roads`)
take several roads (scenario kinds) in turn, each the configured road with only `scenario.kind` replaced."""

from __future__ import annotations

from collections.abc import Sequence

from sumo_rail.config import Config, ConfigError
from sumo_rail.sim.observation import observation_space


def road_configs(config: Config, roads: Sequence[str]) -> list[Config]:
    """The config of each road of `roads`, in order (`config` alone when there is none); ConfigError for an unknown
    road, a road the config's feature settings do not fit, or one whose observation size differs from `config`'s
    (a learner reads one observation layout)."""
    if not roads:
        return [config]
    size = observation_space(config).shape[0]
    configs = []
    for road in roads:
        road_config = config.with_overrides({"scenario": {"kind": road}})
        found = observation_space(road_config).shape[0]
        if found != size:
            raise ConfigError(f"road {road!r} gives {found} observation values, the configured road {size}")
        configs.append(road_config)
    return configs

