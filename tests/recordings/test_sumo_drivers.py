"""SUMO's own drivers written as a scene folder: schema, both car-following models, trucks, lane changes, split."""

from __future__ import annotations

import json

import pandas as pd

from sumo_rail.config import ScenarioConfig
from sumo_rail.recordings.scene import TRACK_COLUMNS
from sumo_rail.recordings.sumo_drivers import drive, split_by_vehicle, write_scene

SCENARIO = ScenarioConfig(length_m=600.0, lanes=3, flow_veh_per_h=5000.0)  # above one arrival a second


def test_scene_folder_holds_tracks_split_and_meta(tmp_path):
    meta = write_scene(tmp_path / "scene", SCENARIO, duration_s=40.0, traffic_seeds=[1, 2])
    tracks = pd.read_parquet(tmp_path / "scene" / "tracks.parquet")
    assert tuple(tracks.columns) == TRACK_COLUMNS
    assert {"passenger", "truck"} <= set(tracks["vehicle_class"])
    assert tracks["vehicle_id"].str.startswith("s1_").any() and tracks["vehicle_id"].str.startswith("s2_").any()
    assert tracks["lane"].between(0, SCENARIO.lanes - 1).all()
    assert (tracks.groupby("vehicle_id")["lane"].nunique() > 1).any()  # somebody changed lanes
    split = pd.read_parquet(tmp_path / "scene" / "split.parquet")
    assert set(split["vehicle_id"]) == set(tracks["vehicle_id"])
    assert json.loads((tmp_path / "scene" / "scene.json").read_text())["format"] == meta.format == "sumo"
    assert (tmp_path / "scene" / "road.net.xml").exists()


def test_same_seed_same_tracks():
    first, second = drive(SCENARIO, 20.0, 3), drive(SCENARIO, 20.0, 3)
    pd.testing.assert_frame_equal(first, second)


def test_split_covers_every_vehicle_once():
    split = split_by_vehicle([str(i) for i in range(50)], 0)
    assert sorted(split["vehicle_id"]) == sorted(str(i) for i in range(50))
    assert split["split"].value_counts().to_dict() == {"train": 30, "validation": 10, "test": 10}
