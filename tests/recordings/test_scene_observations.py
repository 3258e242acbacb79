"""The env's observation computed from a recorded scene's vehicles at an instant."""

from __future__ import annotations

import numpy as np
import pytest

from sumo_rail.config import Config
from sumo_rail.recordings.road import ROAD_EDGE, build_road
from sumo_rail.recordings.scene_observations import observe, scene_road
from sumo_rail.sim.ego import CONTEXT_MARGIN_M
from sumo_rail.sim.observation import observation_names

CONFIG = Config.from_dict({"scenario": {"lanes": 3}, "observation": {"lane_block": 1}})


def test_a_long_vehicle_whose_front_is_beyond_the_lidar_range_is_seen_by_its_rear(tmp_path):
    """The env's context subscription reaches `CONTEXT_MARGIN_M` beyond the LIDAR range, so that a truck whose front
    is out of range but whose rear is in it is seen: so does the scene's."""
    range_m = CONFIG.lidar.range_m
    truck_front_m, truck_length_m, car_length_m = 100.0 + range_m + 5.0, 16.5, 4.5
    assert range_m < truck_front_m - 100.0 <= range_m + CONTEXT_MARGIN_M
    build_road([3.2, 3.2, 3.2], 2000.0, tmp_path / "road.net.xml")  # lanes' centres at y = -8, -4.8, -1.6
    road = scene_road(tmp_path / "road.net.xml")
    ids = np.array(["car", "truck"])
    values = {"x_m": np.array([100.0, truck_front_m]), "y_m": np.array([-4.8, -4.8]),
              "speed_mps": np.array([25.0, 25.0]), "lane_position_m": np.array([100.0, truck_front_m]),
              "heading_deg": np.array([90.0, 90.0]), "length_m": np.array([car_length_m, truck_length_m]),
              "width_m": np.array([1.8, 2.5]), "edge": np.array([ROAD_EDGE, ROAD_EDGE])}
    observation = observe(CONFIG, road, ids, values, np.array([1, 1]), "car", 25.0)
    names = observation_names(CONFIG)
    # beam 0 looks ahead from the car's centre to the truck's rear; the lane block's gap is bumper to bumper
    rear_m = truck_front_m - truck_length_m
    assert observation[names.index("lidar_distance_00")] * range_m == pytest.approx(rear_m - (100.0 - 2.25), abs=1e-3)
    assert observation[names.index("own_lane_front_gap")] * range_m == pytest.approx(rear_m - 100.0, abs=1e-3)
