"""Seats where traffic is established (`choose_seats`' `zone_m`, `evaluate-scene --zone-m`) and the seat's phase."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from recording_files import SCENE_SPEED
from sumo_rail_cli.main import cli

from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.scene_observations import scene_road
from sumo_rail.recordings.seats import choose_seats


def test_zone_0_keeps_todays_seats_and_reports_their_phase(drivers_scene):
    scene = read_scene(drivers_scene)
    seats = choose_seats(scene, "test", 5.0, 2.0, None, 0)
    assert seats == choose_seats(scene, "test", 5.0, 2.0, None, 0, zone_m=0.0) and len(seats) >= 3
    for seat in seats:
        track = scene.track(seat.vehicle)
        assert seat.start_s == pytest.approx(track["time_s"].iloc[0] + 2.0)  # lead_s into the track, as before
        assert seat.since_entry_s == pytest.approx(2.0)
        assert seat.entry_distance_m == pytest.approx(np.interp(seat.start_s, track["time_s"],
                                                                track["lane_position_m"]))


def test_a_zone_moves_each_seat_to_where_the_car_is_past_it_and_drops_cars_that_cannot_finish_before_the_end(
        drivers_scene):
    scene = read_scene(drivers_scene)
    road = scene_road(scene.network)
    length_m, zone_m = road.frame(road.route).length_m, 250.0
    today = choose_seats(scene, "test", 5.0, 2.0, None, 0)
    zoned = choose_seats(scene, "test", 5.0, 2.0, None, 0, zone_m=zone_m)
    assert zoned and {seat.vehicle for seat in zoned} <= {seat.vehicle for seat in today}
    assert any(seat.entry_distance_m < zone_m for seat in today)  # today's seats include the entry zone
    for seat in zoned:
        track = scene.track(seat.vehicle)
        times, along = track["time_s"].to_numpy(), track["lane_position_m"].to_numpy()
        assert seat.entry_distance_m >= zone_m and seat.since_entry_s >= 2.0 - 1e-9
        assert seat.start_s in times  # the first row past the zone
        earlier = times[(times < seat.start_s) & (times >= times[0] + 2.0 - 1e-9)]
        assert (np.interp(earlier, times, along) < zone_m).all()
        assert np.interp(seat.start_s + 5.0, times, along) <= length_m - zone_m  # the horizon ends before the exit
    assert not choose_seats(scene, "test", 5.0, 2.0, None, 0, zone_m=length_m / 2)  # no room between the zones


def test_evaluate_scene_reports_the_phase_and_names_the_zone_when_no_seat_fits(drivers_scene, tmp_path):
    out = tmp_path / "seats.parquet"
    args = [str(drivers_scene), "--set", "observation.lane_block=1", "--set", "scenario.lanes=3", "--policy", "keep",
            "--seats", "1", "--horizon-s", "5", "--lead-s", "2", "--mode", "non-reactive", *SCENE_SPEED]
    result = CliRunner().invoke(cli, ["evaluate-scene", *args, "--zone-m", "250", "--out", str(out)])
    assert result.exit_code == 0, result.output
    metrics = pd.read_parquet(out)
    assert (metrics["entry_distance_m"] >= 250.0).all() and (metrics["since_entry_s"] >= 2.0).all()
    result = CliRunner().invoke(cli, ["evaluate-scene", *args, "--zone-m", "600"])
    assert result.exit_code == 2 and "--zone-m 600 m past the road's start and before its end" in result.output
