"""The observation's history block: the ego's own speed, acceleration and lanes moved, k seconds back."""

from __future__ import annotations

import numpy as np
import pytest

from sumo_rail.sim.ego_past import ACCELERATION_SCALE_MPS2, EgoPast
from sumo_rail.sim.env import HighwayEnv


def test_values_between_known_instants_are_interpolated_and_the_lane_is_the_earlier_instants():
    past = EgoPast(np.array([0.0, 0.5, 1.0, 1.5]), np.array([20.0, 21.0, 22.0, 23.0]), np.array([2.0, 2.0, 2.0, 0.0]),
                   np.array([1, 1, 2, 2]))
    block = past.block(now_s=2.25, lane=2, seconds=2, v_max_mps=30.0)
    assert block[0] == pytest.approx(22.5 / 30.0)  # 1.25 s: between 1.0 and 1.5
    assert block[1] == pytest.approx(1.0 / ACCELERATION_SCALE_MPS2)
    assert block[2] == 0.0  # in lane 2 since 1.0 s
    assert block[3] == pytest.approx(20.5 / 30.0)  # 0.25 s
    assert block[5] == -1.0  # lane 1 then, lane 2 now: it moved left


def test_before_the_first_known_instant_the_first_is_repeated_and_values_are_clipped():
    past = EgoPast()
    past.record(10.0, 80.0, -20.0, 0)
    past.record(10.0, 99.0, 0.0, 3)  # an instant already known changes nothing
    block = past.block(now_s=10.0, lane=3, seconds=2, v_max_mps=30.0)
    np.testing.assert_array_equal(block, np.array([2.0, -1.0, -1.0] * 2, dtype=np.float32))
    assert not EgoPast().block(now_s=0.0, lane=0, seconds=3, v_max_mps=30.0).any()


def test_the_episodes_history_shows_the_egos_own_speeds(small_config):
    config = small_config.with_overrides({"observation": {"history": 2}})
    env = HighwayEnv(config=config)
    try:
        observation, info = env.reset(seed=2)
        assert observation.shape == env.observation_space.shape == (56 + 6,)
        assert observation[-6] == observation[-3] == pytest.approx(info["speed_mps"] / 33.33, abs=1e-6)
        speeds = [info["speed_mps"]]
        for _ in range(4):  # 2 s of decisions every 0.5 s
            observation, _, _, _, info = env.step(1)
            speeds.append(info["speed_mps"])
        assert observation[-6] == pytest.approx(speeds[-3] / 33.33, abs=1e-6)  # 1 s back
        assert observation[-3] == pytest.approx(speeds[-5] / 33.33, abs=1e-6)  # 2 s back
    finally:
        env.close()
