import duckdb
import numpy as np
import pandas as pd
import polars as pl
import pyarrow.parquet as pq
import pytest
from reliability import assert_refuses_missing_and_garbage

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError, read_metadata, sumo_version, write_parquet
from sumo_rail.runners import tables
from sumo_rail.runners.rollout import ACTION_COLUMNS, EpisodeResult
from sumo_rail.runners.tables import demonstrations_table, provenance, read_demonstrations

CONFIG = Config()
SIZE = 56


def fake_episode(steps: int, seed: int, collided: bool = False) -> EpisodeResult:
    rng = np.random.default_rng(seed)
    columns = {
        "observation": rng.random((steps, SIZE)).astype(np.float32), "action": rng.integers(0, 5, steps),
        "reward": rng.random(steps), "reward_longitudinal": rng.random(steps), "reward_lateral": np.zeros(steps),
        "reward_collision": np.zeros(steps), "speed_mps": rng.random(steps) * 30, "lane": rng.integers(0, 5, steps),
        "position_m": np.arange(steps) * 15.0, "set_point_mps": np.full(steps, 30.0),
        "lane_change_in_progress": np.zeros(steps, dtype=bool),
    }
    metrics = {"terminated": collided, "truncated": not collided,
               "termination": "collision" if collided else "time_limit"}
    return EpisodeResult(metrics, columns)


def write_demos(path, episodes=((4, 1), (3, 2, True))):
    results = [fake_episode(*spec) for spec in episodes]
    seeds = [spec[1] for spec in episodes]
    table = demonstrations_table(results, seeds, SIZE)
    write_parquet(table, path, provenance(tables.DEMONSTRATIONS, CONFIG, 7, style="calm"))
    return results


def test_demonstrations_round_trip_with_provenance(tmp_path):
    path = tmp_path / "demos.parquet"
    results = write_demos(path)
    demos = read_demonstrations(path, observation_size=SIZE)
    assert demos.observations.shape == (7, SIZE) and demos.observations.dtype == np.float32
    assert np.array_equal(demos.observations[4:], results[1].steps["observation"])
    assert np.array_equal(demos.actions, np.concatenate([r.steps["action"] for r in results]))
    assert demos.episodes.tolist() == [0, 0, 0, 0, 1, 1, 1]
    metadata = read_metadata(path)
    assert metadata["seed"] == 7 and metadata["style"] == "calm" and metadata["config"] == CONFIG.to_dict()
    assert len(metadata["observation_names"]) == SIZE
    assert metadata["versions"]["sumo"] == sumo_version()
    assert set(metadata["versions"]) >= {"sumo_rail", "numpy", "pyarrow", "torch", "numba", "gymnasium",
                                         "stable_baselines3", "python"}  # the dev install has Stable-Baselines3
    table = pq.read_table(path)
    assert table.column_names == list(tables.DEMONSTRATION_COLUMNS)
    assert table.column("terminated").to_pylist() == [False] * 4 + [True] * 3
    assert table.column("termination").to_pylist() == ["time_limit"] * 4 + ["collision"] * 3
    assert table.column("step").to_pylist() == [0, 1, 2, 3, 0, 1, 2]


def test_demonstrations_are_readable_by_pandas_polars_and_duckdb(tmp_path):
    path = tmp_path / "demos.parquet"
    write_demos(path)
    frame = pd.read_parquet(path)
    assert len(frame) == 7 and len(frame["observation"][0]) == SIZE
    polars_frame = pl.read_parquet(path)
    assert polars_frame.height == 7 and polars_frame["observation"].dtype.size == SIZE
    count, first = duckdb.sql(f"SELECT count(*), min(episode_seed) FROM read_parquet('{path}')").fetchall()[0]
    assert (count, first) == (7, 1)


def test_metrics_table_holds_every_metric_column():
    row = {name: 0 for name in tables.METRIC_COLUMNS} | {"policy": "x", "termination": "end_of_road",
                                                           "terminated": False, "truncated": True}
    table = tables.metrics_table([row, row])
    assert table.num_rows == 2 and set(ACTION_COLUMNS) <= set(table.column_names)


def test_bad_demonstration_files_give_one_sentence_errors(tmp_path):
    assert_refuses_missing_and_garbage(read_demonstrations, DatasetError, tmp_path, ".parquet",
                                       b"PAR1 this is not parquet", "not a readable Parquet")
    foreign = tmp_path / "foreign.parquet"
    pd.DataFrame({"a": [1]}).to_parquet(foreign)
    with pytest.raises(DatasetError, match="not written by sumo-rail"):
        read_demonstrations(foreign)
    good = tmp_path / "good.parquet"
    write_demos(good)
    with pytest.raises(DatasetError, match="size 56, the environment gives 60: the lane count"):
        read_demonstrations(good, observation_size=60)
    metrics = tmp_path / "metrics.parquet"
    row = {name: 0 for name in tables.METRIC_COLUMNS} | {"policy": "x", "termination": "", "terminated": False,
                                                           "truncated": False}
    write_parquet(tables.metrics_table([row]), metrics, provenance(tables.EPISODE_METRICS, CONFIG, 0))
    with pytest.raises(DatasetError, match="not demonstrations"):
        read_demonstrations(metrics)
