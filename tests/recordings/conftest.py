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


@pytest.fixture(scope="module")
def scene_and_demos(tmp_path_factory):
    """The two-car scene (a car at 25 m/s for 2 s, then +2 m/s^2 for 2 s, behind a truck), all train, and its
    demonstrations on the acceleration interface (one per test module: a module may change its scene)."""
    from test_recorded_demos import invoke, two_car_scene

    folder = tmp_path_factory.mktemp("two_car")
    two_car_scene(folder / "scene")
    demos = folder / "demos.parquet"
    result = invoke("recorded-demos", str(folder / "scene"), "--set", "actions.interface=acceleration", "--out",
                    str(demos))
    assert result.exit_code == 0, result.output
    return folder / "scene", demos
