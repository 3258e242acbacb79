"""The one trajectory record: a scene at an instant (`SceneSnapshot`), a vehicle's point in it with its gap to its
leader, and the tables and pasts demonstrations, seats and evaluations make of such points."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from sumo_rail.evaluation.scene_evaluation import human_track
from sumo_rail.recordings.road import build_road
from sumo_rail.recordings.scene_observations import SceneFrames, scene_road
from sumo_rail.recordings.seats import Seat
from sumo_rail.recordings.trajectory import TRAJECTORY_COLUMNS, track_past, trajectory_frame


def tracks() -> pd.DataFrame:
    """At 10 Hz for 1 s: "a" behind "b" in lane 0 (b's rear 15.5 m ahead of a's front), "c" alone in lane 1."""
    rows = []
    for k in range(11):
        for vehicle, lane, front in (("a", 0, 10.0), ("b", 0, 30.0), ("c", 1, 20.0)):
            x = front + 20.0 * k / 10
            rows.append({"vehicle_id": vehicle, "time_s": k / 10, "x_m": x, "y_m": -1.6 - 3.2 * (1 - lane),
                         "heading_deg": 90.0, "speed_mps": 20.0, "acceleration_mps2": 0.1 * k, "edge": "road",
                         "lane": lane, "lane_position_m": x, "length_m": 4.5, "width_m": 1.8,
                         "vehicle_class": "passenger"})
    return pd.DataFrame(rows)


def test_a_snapshot_gives_each_vehicle_as_a_named_point_with_its_leader_gap():
    snapshot = SceneFrames(tracks(), 10.0).at(0.25)  # between two frames: interpolated
    row = snapshot.row("a")
    assert row is not None and snapshot.row("nobody") is None
    point = snapshot.point(row, 0.25)
    assert point._fields == TRAJECTORY_COLUMNS and point.lane == 0 and point.time_s == 0.25
    assert point[1:6] == pytest.approx((15.0, -4.8, 20.0, 0, 15.0))
    assert math.isnan(point.gap_m)  # not measured unless asked
    assert snapshot.leader_gap_m(row) == pytest.approx(30.0 - 4.5 - 10.0)
    c_row = snapshot.row("c")
    assert c_row is not None and snapshot.leader_gap_m(c_row) == math.inf


def test_a_seats_human_track_is_its_points_with_the_gaps_in_range(tmp_path):
    frames = SceneFrames(tracks(), 10.0)
    build_road([3.2, 3.2], 100.0, tmp_path / "road.net.xml")
    road = scene_road(tmp_path / "road.net.xml")
    human = human_track(frames, Seat("scene", "a", 0.2), 0.3, 5, road, ("road",), 100.0)  # the track ends at 1.0 s
    assert tuple(human.columns) == TRAJECTORY_COLUMNS == ("time_s", "x_m", "y_m", "speed_mps", "lane",
                                                         "lane_position_m", "gap_m")
    assert human["time_s"].tolist() == pytest.approx([0.2, 0.5, 0.8])
    assert human["gap_m"].tolist() == pytest.approx([15.5] * 3)
    assert human["lane_position_m"].tolist() == pytest.approx([14.0, 20.0, 26.0])
    alone = human_track(frames, Seat("scene", "c", 0.2), 0.3, 5, road, ("road",), 100.0)
    assert alone["gap_m"].isna().all()
    beyond = human_track(frames, Seat("scene", "a", 0.2), 0.3, 5, road, ("road",), 15.0)
    assert beyond["gap_m"].isna().all()  # beyond the range
    assert trajectory_frame([]).columns.tolist() == list(TRAJECTORY_COLUMNS)


def test_a_tracks_rows_are_its_past():
    rows = tracks()
    past = track_past(rows[rows["vehicle_id"] == "b"])
    assert past.time_s == pytest.approx([k / 10 for k in range(11)])
    assert past.acceleration_mps2 == pytest.approx([0.1 * k for k in range(11)])
    assert past.lane == [0.0] * 11 and np.allclose(past.speed_mps, 20.0)


def test_between_frames_only_a_vehicle_in_the_next_frame_moves_and_its_heading_turns_the_short_way():
    """Interpolation links each vehicle to its own row in the next frame: "b" leaves after frame 3 and is back at
    frame 5 (not interpolated between 3 and 4, nor 4 and 5), "d" enters at frame 4, "a"'s heading crosses north."""
    rows = tracks()
    rows = rows[~((rows["vehicle_id"] == "b") & (rows["time_s"].round(1) == 0.4))]
    rows.loc[rows["vehicle_id"] == "a", "heading_deg"] = (350.0 + 5.0 * np.arange(11)) % 360.0
    entering = rows[(rows["vehicle_id"] == "c") & (rows["time_s"] >= 0.35)].assign(vehicle_id="d", lane=0)
    frames = SceneFrames(pd.concat([rows, entering]).sample(frac=1.0, random_state=1), 10.0)
    snapshot = frames.at(0.35)
    a, b, d = (snapshot.row(vehicle) for vehicle in "abd")
    assert a is not None and b is not None and d is None
    assert snapshot.values["x_m"][a] == pytest.approx(17.0) and snapshot.values["x_m"][b] == pytest.approx(36.0)
    assert frames.at(0.15).values["heading_deg"][a] == pytest.approx(357.5)  # 355 to 0 degrees
    after = frames.at(0.45)
    assert after.row("b") is None and after.values["x_m"][after.row("d")] == pytest.approx(29.0)
    with pytest.raises(ValueError):  # the frames' own values are handed out read-only, never to be changed
        frames.at(0.4).values["length_m"][0] = 1.0


@pytest.mark.parametrize("order", ["by vehicle", "by time"])
def test_a_scenes_track_is_its_vehicles_rows_in_time_order_however_the_table_is_ordered(order, tmp_path):
    """`Scene.track` finds a vehicle's rows once (a slice where they are together, as the writers write them)."""
    from sumo_rail.datasets import DatasetError
    from sumo_rail.recordings.scene import Scene, SceneMeta

    rows = tracks().sort_values(["vehicle_id", "time_s"] if order == "by vehicle" else ["time_s", "vehicle_id"],
                                ignore_index=True)
    scene = Scene(tmp_path, SceneMeta("sumo", 10.0, "road.net.xml", 2), rows, pd.DataFrame(), tmp_path / "net")
    for vehicle in "abc":
        expected = rows[rows["vehicle_id"] == vehicle].sort_values("time_s")
        pd.testing.assert_frame_equal(scene.track(vehicle), expected)
    with pytest.raises(DatasetError, match="has no vehicle 'nobody'"):
        scene.track("nobody")
