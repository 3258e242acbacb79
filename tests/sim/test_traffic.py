import numpy as np
import pytest
from scenes import EGO_FRONT, view

from sumo_rail.config import Config
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observation import observation_names, observation_space
from sumo_rail.sim.traffic import lane_block, within


def test_lane_block_reads_gaps_and_relative_speeds_per_lane():
    traffic = view([(1, 1040.0, 4.5, 20.0), (1, 970.0, 12.0, 30.0), (2, 1300.0, 4.5, 30.0), (2, 980.0, 4.5, 28.0)],
                   lane=1, speed=25.0)
    block = lane_block(traffic, range_m=100.0, v_max_mps=33.33).reshape(3, 4)
    right, own, left = block
    assert own == pytest.approx([(1040 - 4.5 - EGO_FRONT) / 100, (20 - 25) / 33.33,
                                 (EGO_FRONT - 4.5 - 970) / 100, (30 - 25) / 33.33], abs=1e-6)
    assert right.tolist() == [1.0, 0.0, 1.0, 0.0]                     # empty lane: free to r_max
    assert left[0] == 1.0 and left[1] == 0.0                          # leader beyond range: not seen
    assert left[2] == pytest.approx((EGO_FRONT - 4.5 - 980) / 100, abs=1e-6)
    leftmost = lane_block(view([], lane=4), 100.0, 33.33).reshape(3, 4)
    assert leftmost[2].tolist() == [0.0, 0.0, 0.0, 0.0]               # no lane there: blocked


def test_within_drops_vehicles_beyond_the_range_only():
    traffic = view([(1, 1040.0, 4.5, 20.0), (2, 1150.0, 4.5, 30.0), (0, 890.0, 4.5, 30.0)])
    near = within(traffic, 100.0)
    assert near.neighbours.ids == ("v0",) and within(traffic, 200.0) is traffic


def test_observation_with_the_lane_block_is_self_describing(small_config):
    config = small_config.with_overrides({"observation": {"lane_block": 1}})
    names = observation_names(config)
    assert len(names) == len(observation_names(small_config)) + 12 == observation_space(config).shape[0]
    assert names[-12:-8] == ["right_lane_front_gap", "right_lane_front_relative_speed", "right_lane_rear_gap",
                             "right_lane_rear_relative_speed"]
    env = HighwayEnv(config)
    try:
        observation, _ = env.reset(seed=3)
        assert observation.shape == (len(names),) and env.observation_space.contains(observation)
        for _ in range(5):
            observation, *_ = env.step(0)
        expected = lane_block(env.traffic, config.lidar.range_m, config.env.v_max_mps)
        assert np.array_equal(observation[-12:], expected)
    finally:
        env.close()
    with pytest.raises(Exception, match=r"observation\.lane_block must be 0 or 1"):
        Config.from_dict({"observation": {"lane_block": 2}})
