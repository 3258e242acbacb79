"""The Parquet tables the runners write and the learners read: demonstrations (one row per decision) and
episode metrics (one row per episode), with their schemas, provenance and validation on read."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from sumo_rail.action_config import ActionConfig
from sumo_rail.bounds import ConfigError
from sumo_rail.config import Config
from sumo_rail.datasets import FORMAT_VERSION, DatasetError, describe, read_metadata, read_table, versions
from sumo_rail.runners.rollout import ACTION_COLUMNS, EpisodeResult
from sumo_rail.sim import user_network
from sumo_rail.sim.actions import action_count
from sumo_rail.sim.observation import observation_names

DEMONSTRATIONS = "demonstrations"
EPISODE_METRICS = "episode_metrics"
ACTION_TYPE = pa.int16()
"""The Arrow type of an action column: it holds every interface's actions (the acceleration interface's finest bins
give 843; int8 stops at 127)."""
ROAD_FILES = "road_files"
"""The provenance entry holding a user's network and traffic file: their sha256 by absolute path (kind network)."""


def provenance(kind: str, config: Config, seed: int, **extra: Any) -> dict[str, Any]:
    """The metadata stored with every output table (on a user's network, its files' content hashes: `ROAD_FILES`)."""
    road = user_network.road_files(config.scenario)
    return {"kind": kind, "format_version": FORMAT_VERSION, "seed": seed, "config": config.to_dict(),
            "observation_names": observation_names(config), "versions": versions(),
            **({ROAD_FILES: road} if road else {}), **extra}


def interface_mismatch(path: Path, metadata: dict[str, Any], interface: ActionConfig) -> None:
    """A DatasetError when the demonstrations at `path` (their `metadata`) were recorded with another action interface
    than `interface`."""
    recorded = demonstrations_interface(metadata)
    if not recorded.same_space(interface):
        raise DatasetError(f"{path} holds demonstrations of the {_interface_words(recorded)}, this run uses the "
                           f"{_interface_words(interface)}: record them again, or set [actions] as they were")


def _interface_words(actions: ActionConfig) -> str:
    """An action interface in words: "paper interface" or "acceleration interface (-6 to 3 m/s^2 in 0.25 bins)"."""
    if actions.interface == "paper":
        return "paper interface"
    return (f"acceleration interface ({actions.acceleration_min_mps2:g} to {actions.acceleration_max_mps2:g} m/s^2 in "
            f"{actions.acceleration_bin_mps2:g} bins)")


def demonstrations_table(results: Sequence[EpisodeResult], seeds: Sequence[int], observation_size: int) -> pa.Table:
    """One row per decision of recorded episodes, in episode order."""
    columns: dict[str, list[np.ndarray]] = {}
    for episode, (result, seed) in enumerate(zip(results, seeds, strict=True)):
        if result.steps is None:
            raise ValueError("demonstrations need recorded episodes (record=True)")
        count = len(result.steps["action"])
        per_episode = {"episode": np.full(count, episode), "step": np.arange(count),
                       "episode_seed": np.full(count, seed), **result.steps,
                       "terminated": np.full(count, bool(result.metrics["terminated"])),
                       "truncated": np.full(count, bool(result.metrics["truncated"])),
                       "termination": np.full(count, result.metrics["termination"] or "", dtype=object)}
        for name, values in per_episode.items():
            columns.setdefault(name, []).append(values)
    data = {name: np.concatenate(parts) for name, parts in columns.items()}
    return demonstrations_from_columns(data, data.pop("observation"), observation_size)


def demonstrations_from_columns(data: dict[str, np.ndarray], observations: np.ndarray,
                                observation_size: int) -> pa.Table:
    """The demonstrations table of every column of DEMONSTRATION_COLUMNS but the observation (`data`) and the
    observations, shape (N, `observation_size`)."""
    arrays = {name: pa.array(data[name], type=kind) for name, kind in _DEMONSTRATION_SCALARS.items()}
    arrays["observation"] = pa.FixedSizeListArray.from_arrays(pa.array(observations.astype(np.float32).ravel()),
                                                              observation_size)
    return pa.table({name: arrays[name] for name in DEMONSTRATION_COLUMNS})


_DEMONSTRATION_SCALARS: dict[str, pa.DataType] = {
    "episode": pa.int32(), "step": pa.int32(), "episode_seed": pa.int64(), "action": ACTION_TYPE,
    "reward": pa.float64(), "reward_longitudinal": pa.float64(), "reward_lateral": pa.float64(),
    "reward_collision": pa.float64(), "speed_mps": pa.float64(), "lane": pa.int8(), "position_m": pa.float64(),
    "set_point_mps": pa.float64(), "lane_change_in_progress": pa.bool_(), "terminated": pa.bool_(),
    "truncated": pa.bool_(), "termination": pa.string(),
}
DEMONSTRATION_COLUMNS = ("episode", "step", "episode_seed", "observation", *list(_DEMONSTRATION_SCALARS)[3:])

_METRIC_TYPES: dict[str, pa.DataType] = {
    "policy": pa.string(), "episode": pa.int32(), "seed": pa.int64(), "steps": pa.int32(),
    "simulated_s": pa.float64(), "distance_m": pa.float64(), "average_speed_kmh": pa.float64(),
    "overtakes": pa.int32(), "overtaken": pa.int32(), "lane_changes": pa.int32(),
    "longitudinal_reward": pa.float64(), "lateral_reward": pa.float64(), "collisions": pa.int32(),
    "hard_braking": pa.int32(), "teleports": pa.int32(), "invalid_actions": pa.int32(), "merges": pa.int32(),
    "merge_time_s": pa.float64(), "missed_exits": pa.int32(), "lane_end_stops": pa.int32(),
    **{name: pa.int32() for name in ACTION_COLUMNS},
    "termination": pa.string(), "terminated": pa.bool_(), "truncated": pa.bool_(),
}
METRIC_COLUMNS = tuple(_METRIC_TYPES)


def metrics_table(rows: Sequence[dict[str, Any]], extra_types: dict[str, pa.DataType] | None = None) -> pa.Table:
    """One row per evaluated episode; each row holds every column of METRIC_COLUMNS and of `extra_types`."""
    types = {**_METRIC_TYPES, **(extra_types or {})}
    return pa.table({name: pa.array([row[name] for row in rows], type=kind) for name, kind in types.items()})


@dataclass(frozen=True)
class Demonstrations:
    """State-action pairs of recorded episodes."""

    observations: np.ndarray
    """Shape (N, n) float32."""
    actions: np.ndarray
    """Shape (N,) int64."""
    episodes: np.ndarray
    """Episode index of each row, shape (N,)."""
    metadata: dict[str, Any]


FAILURES = ("collision", "missed_exit", "lane_end")
"""The `termination` of a failed episode: a collision, a missed exit, a stop at a lane's end."""


def demonstrations_interface(metadata: dict[str, Any]) -> ActionConfig:
    """The action interface demonstrations were recorded with (their config's [actions]; the paper's in files written
    before the section existed); a DatasetError when it is not one."""
    section = (metadata.get("config") or {}).get("actions", {})
    try:
        return Config.from_dict({"actions": section}).actions
    except ConfigError as error:
        raise DatasetError(f"demonstrations with an impossible action interface: {error}") from error


def read_demonstrations(path: Path, observation_size: int | None = None, include_failed: bool = True,
                        interface: ActionConfig | None = None) -> Demonstrations:
    """Read and validate a demonstrations file; `observation_size` checks it against an environment, `interface`
    against a run's action interface (a file of the other interface is a DatasetError; without it, the file's own
    bounds its actions). Without `include_failed`, the episodes whose `termination` is a failure (`FAILURES`) are
    left out (a file written before that column counts as not failed); a DatasetError when that leaves none."""
    path = Path(path)
    metadata = read_metadata(path)
    if metadata.get("kind") != DEMONSTRATIONS:
        raise DatasetError(f"{path} holds {metadata.get('kind')!r} data, not demonstrations")
    if interface is not None:
        interface_mismatch(path, metadata, interface)
    recorded = demonstrations_interface(metadata)
    needed = ["episode", "observation", "action"]
    missing = [name for name in needed if name not in pq.read_schema(path).names]
    if missing:
        raise DatasetError(f"{path} lacks the demonstrations column(s) {', '.join(missing)}")
    table = read_table(path, columns=needed)
    observation_type = table.schema.field("observation").type
    if not pa.types.is_fixed_size_list(observation_type):
        raise DatasetError(f"{path} has no fixed-size observation column")
    size = observation_type.list_size
    if observation_size is not None and size != observation_size:
        raise DatasetError(f"{path} has observations of size {size}, the environment gives {observation_size}: the "
                           f"lane count or the observation settings they were recorded with differ from this run's")
    if table.num_rows == 0:
        raise DatasetError(f"{path} holds no demonstrations")
    if not all(pa.types.is_integer(table.schema.field(name).type) for name in ("episode", "action")):
        raise DatasetError(f"{path} has non-integer episode or action columns")
    try:
        observations = table.column("observation").combine_chunks().flatten().to_numpy().reshape(-1, size)
        actions = table.column("action").to_numpy().astype(np.int64)
    except (pa.ArrowException, ValueError) as error:  # nulls, observation lists of other lengths
        raise DatasetError(f"{path} has missing or misshapen observations or actions ({describe(error)})") from error
    if not np.isfinite(observations).all():
        raise DatasetError(f"{path} has non-finite observations")
    count = action_count(recorded)
    if actions.min() < 0 or actions.max() >= count:
        raise DatasetError(f"{path} has actions outside 0..{count - 1}")
    episodes = table.column("episode").to_numpy()
    failed = np.isin(episodes, failed_episodes(path)) if not include_failed else np.zeros(len(episodes), bool)
    if failed.all():
        raise DatasetError(f"every episode in {path} failed (a collision or a route failure); pass "
                           f"--include-failed-demos to learn from them")
    return Demonstrations(observations[~failed], actions[~failed], episodes[~failed], metadata)


def failed_episodes(path: Path) -> np.ndarray:
    """The episode numbers of a demonstrations file whose `termination` is a failure (`FAILURES`); none in a file
    written before that column."""
    if "termination" not in pq.read_schema(path).names:
        return np.zeros(0, dtype=np.int64)
    table = read_table(path, columns=["episode", "termination"])
    failed = np.isin(table.column("termination").to_numpy(zero_copy_only=False).astype(str), FAILURES)
    return np.unique(table.column("episode").to_numpy()[failed])


