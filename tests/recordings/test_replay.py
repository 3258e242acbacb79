"""Non-reactive replay puts every recorded vehicle where the recording has it, entering and leaving as recorded."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from sumo_rail.config import Config
from sumo_rail.recordings.replay import ScenePlayer
from sumo_rail.recordings.sumo_drivers import SumoDriversSettings, record_sumo_drivers


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    folder = tmp_path_factory.mktemp("replay") / "scene"
    config = Config.from_dict({"scenario": {"length_m": 1000.0, "lanes": 3, "flow_veh_per_h": 3000.0}})
    record_sumo_drivers(SumoDriversSettings(out=folder, seed=4, duration_s=30.0, warmup_s=30.0), config)
    tracks = pd.read_parquet(folder / "tracks.parquet")
    first = tracks["vehicle_id"].iloc[0]  # leaves mid-road, at 5 s: the replay must take it away
    tracks = tracks[(tracks["vehicle_id"] != first) | (tracks["time_s"] <= tracks["time_s"].min() + 5.0)]
    tracks.to_parquet(folder / "tracks.parquet", index=False)
    return folder


def test_replayed_positions_are_the_recorded_ones(scene):
    player = ScenePlayer(scene)
    try:
        for time_s in sorted(player.frames)[:200]:
            player.play(time_s)
            frame = player.frames[time_s].set_index("vehicle_id")
            positions = player.positions()
            assert set(positions) == set(frame.index)
            for vehicle, (x, y) in positions.items():
                assert np.hypot(x - frame.at[vehicle, "x_m"], y - frame.at[vehicle, "y_m"]) < 1e-3
    finally:
        player.close()
