"""Parquet tables (demonstrations, episode metrics): schemas, provenance, atomic writes, validation on read.

Every file carries JSON provenance under the Parquet schema metadata key `sumo_rail`: the table kind, the full
config, the seed, the observation layout and the versions of SUMO, sumo-rail, pyarrow, numpy and Python.
Nothing time-dependent is stored, so the same job writes the same bytes.
"""

from __future__ import annotations

import json
import os
import platform
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import metadata as package_metadata
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from sumo_rail.config import Config
from sumo_rail.network import sumo_version
from sumo_rail.observation import observation_names
from sumo_rail.rollout import ACTION_COLUMNS, EpisodeResult

METADATA_KEY = b"sumo_rail"
FORMAT_VERSION = 1
DEMONSTRATIONS = "demonstrations"
EPISODE_METRICS = "episode_metrics"


class DatasetError(ValueError):
    """A data file or output path a user supplied cannot be used (message is one sentence)."""


def versions() -> dict[str, str]:
    """Versions of what shapes the results."""
    return {"sumo": sumo_version(), "sumo_rail": package_metadata.version("sumo-rail"), "pyarrow": pa.__version__,
            "numpy": np.__version__, "python": platform.python_version()}


def provenance(kind: str, config: Config, seed: int, **extra: Any) -> dict[str, Any]:
    """The metadata stored with every output table."""
    return {"kind": kind, "format_version": FORMAT_VERSION, "seed": seed, "config": config.to_dict(),
            "observation_names": observation_names(config), "versions": versions(), **extra}


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
                       "truncated": np.full(count, bool(result.metrics["truncated"]))}
        for name, values in per_episode.items():
            columns.setdefault(name, []).append(values)
    data = {name: np.concatenate(parts) for name, parts in columns.items()}
    observations = data.pop("observation").astype(np.float32)
    arrays = {name: pa.array(data[name], type=kind) for name, kind in _DEMONSTRATION_SCALARS.items()}
    arrays["observation"] = pa.FixedSizeListArray.from_arrays(pa.array(observations.ravel()), observation_size)
    return pa.table({name: arrays[name] for name in DEMONSTRATION_COLUMNS})


_DEMONSTRATION_SCALARS: dict[str, pa.DataType] = {
    "episode": pa.int32(), "step": pa.int32(), "episode_seed": pa.int64(), "action": pa.int8(),
    "reward": pa.float64(), "reward_longitudinal": pa.float64(), "reward_lateral": pa.float64(),
    "reward_collision": pa.float64(), "speed_mps": pa.float64(), "lane": pa.int8(), "position_m": pa.float64(),
    "set_point_mps": pa.float64(), "lane_change_in_progress": pa.bool_(), "terminated": pa.bool_(),
    "truncated": pa.bool_(),
}
DEMONSTRATION_COLUMNS = ("episode", "step", "episode_seed", "observation", *list(_DEMONSTRATION_SCALARS)[3:])

_METRIC_TYPES: dict[str, pa.DataType] = {
    "policy": pa.string(), "episode": pa.int32(), "seed": pa.int64(), "steps": pa.int32(),
    "simulated_s": pa.float64(), "distance_m": pa.float64(), "average_speed_kmh": pa.float64(),
    "overtakes": pa.int32(), "overtaken": pa.int32(), "lane_changes": pa.int32(),
    "longitudinal_reward": pa.float64(), "lateral_reward": pa.float64(), "collisions": pa.int32(),
    "hard_braking": pa.int32(), "teleports": pa.int32(), "invalid_actions": pa.int32(),
    **{name: pa.int32() for name in ACTION_COLUMNS},
    "termination": pa.string(), "terminated": pa.bool_(), "truncated": pa.bool_(),
}
METRIC_COLUMNS = tuple(_METRIC_TYPES)


def metrics_table(rows: Sequence[dict[str, Any]]) -> pa.Table:
    """One row per evaluated episode; each row holds every column of METRIC_COLUMNS."""
    return pa.table({name: pa.array([row[name] for row in rows], type=kind) for name, kind in _METRIC_TYPES.items()})


def check_output_path(path: Path, overwrite: bool) -> None:
    """Fail before any work if `path` cannot be written (exists without `overwrite`, folder missing, read-only)."""
    path = Path(path)
    if path.is_dir():
        raise DatasetError(f"output {path} is a folder, not a file")
    if path.exists() and not overwrite:
        raise DatasetError(f"output {path} already exists; pass --overwrite to replace it")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise DatasetError(f"the folder of output {path} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise DatasetError(f"the folder of output {path} is not writable")


def write_parquet(table: pa.Table, path: Path, metadata: dict[str, Any]) -> None:
    """Write `table` with `metadata` to `path` atomically: a temporary file in the same folder, then rename."""
    path = Path(path)
    schema_metadata = {**(table.schema.metadata or {}), METADATA_KEY: json.dumps(metadata, sort_keys=True).encode()}
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        pq.write_table(table.replace_schema_metadata(schema_metadata), temporary)
        os.replace(temporary, path)
    except OSError as error:
        raise DatasetError(f"cannot write {path}: {error.strerror or error}") from error
    finally:
        temporary.unlink(missing_ok=True)


def read_metadata(path: Path) -> dict[str, Any]:
    """The sumo-rail provenance of a Parquet file written by this package."""
    schema = _read_schema(Path(path))
    raw = (schema.metadata or {}).get(METADATA_KEY)
    if raw is None:
        raise DatasetError(f"{path} has no sumo-rail metadata; it was not written by sumo-rail")
    try:
        return json.loads(raw)
    except json.JSONDecodeError as error:
        raise DatasetError(f"{path} has unreadable sumo-rail metadata ({error})") from error


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


def read_demonstrations(path: Path, observation_size: int | None = None) -> Demonstrations:
    """Read and validate a demonstrations file; `observation_size` checks it against an environment."""
    path = Path(path)
    metadata = read_metadata(path)
    if metadata.get("kind") != DEMONSTRATIONS:
        raise DatasetError(f"{path} holds {metadata.get('kind')!r} data, not demonstrations")
    try:
        table = pq.read_table(path, columns=["episode", "observation", "action"])
    except (pa.ArrowException, OSError) as error:
        raise DatasetError(f"{path} is not a readable demonstrations file ({error})") from error
    observation_type = table.schema.field("observation").type
    if not pa.types.is_fixed_size_list(observation_type):
        raise DatasetError(f"{path} has no fixed-size observation column")
    size = observation_type.list_size
    if observation_size is not None and size != observation_size:
        raise DatasetError(f"{path} has observations of size {size}, the environment gives {observation_size}")
    if table.num_rows == 0:
        raise DatasetError(f"{path} holds no demonstrations")
    observations = table.column("observation").combine_chunks().flatten().to_numpy().reshape(-1, size)
    actions = table.column("action").to_numpy().astype(np.int64)
    if actions.min() < 0 or actions.max() >= len(ACTION_COLUMNS):
        raise DatasetError(f"{path} has actions outside 0..{len(ACTION_COLUMNS) - 1}")
    return Demonstrations(observations, actions, table.column("episode").to_numpy(), metadata)


def _read_schema(path: Path) -> pa.Schema:
    if not path.is_file():
        raise DatasetError(f"file {path} does not exist")
    try:
        return pq.read_schema(path)
    except (pa.ArrowException, OSError) as error:
        raise DatasetError(f"{path} is not a readable Parquet file ({error})") from error
