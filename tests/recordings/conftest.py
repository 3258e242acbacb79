"""A small scene of SUMO's own drivers, shared by the replay and seat tests."""

from __future__ import annotations

import pandas as pd
import pytest

from sumo_rail.config import Config
from sumo_rail.recordings.sumo_drivers import SumoDriversSettings, record_sumo_drivers

SCENE_CONFIG = {"scenario": {"length_m": 1000.0, "lanes": 3, "flow_veh_per_h": 3000.0, "warmup_s": 30.0}}


@pytest.fixture(scope="session")
def drivers_scene(tmp_path_factory):
    """Three lanes, 1 km, 30 s of SUMO's drivers; the first track cut at 5 s, so that vehicle leaves mid-road."""
    folder = tmp_path_factory.mktemp("drivers") / "scene"
    record_sumo_drivers(SumoDriversSettings(out=folder, seed=4, duration_s=30.0),
                        Config.from_dict(SCENE_CONFIG))
    tracks = pd.read_parquet(folder / "tracks.parquet")
    first = tracks["vehicle_id"].iloc[0]
    tracks = tracks[(tracks["vehicle_id"] != first) | (tracks["time_s"] <= tracks["time_s"].min() + 5.0)]
    tracks.to_parquet(folder / "tracks.parquet", index=False)
    return folder
