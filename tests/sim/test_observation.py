import numpy as np

from sumo_rail.config import Config
from sumo_rail.sim.observation import build_observation, observation_names, observation_space


def test_layout_names_match_space_and_vector():
    config = Config()
    names = observation_names(config)
    space = observation_space(config)
    assert len(names) == space.shape[0] == 2 * 24 + 2 + 5 + 1
    assert names[0] == "lidar_distance_00" and names[24] == "lidar_relative_speed_00"
    assert names[-1] == "lane_change_in_progress"
    observation = build_observation(config, np.full(24, 50.0), np.full(24, -100.0), 20.0, 10.0, 3, True)
    assert observation.dtype == np.float32 and space.contains(observation)
    assert observation[0] == np.float32(0.5)
    assert observation[24] == np.float32(-1.0)
    assert observation[names.index("cruise_set_point")] == 0.0
    assert observation[names.index("lane_0"):names.index("lane_4") + 1].tolist() == [0, 0, 0, 1, 0]
    assert observation[-1] == 1.0


def test_lane_one_hot_follows_lane_count():
    config = Config.from_dict({"scenario": {"lanes": 3}})
    assert observation_space(config).shape == (2 * 24 + 2 + 3 + 1,)
