import numpy as np
import pytest
from scenes import EGO_FRONT, view

from sumo_rail.config import Config
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observation import observation_names, observation_space
from sumo_rail.sim.traffic import ego_leader_gap_m, lane_block, lane_gaps, within


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


def lane_block_per_lane(traffic, range_m, v_max_mps):
    """The lane block as it was computed before it was vectorised: `lane_gaps` lane by lane, in Python floats."""
    block = np.zeros((3, 4), dtype=np.float32)
    ego = traffic.ego
    for row, lane in enumerate((ego.lane - 1, ego.lane, ego.lane + 1)):
        if not 0 <= lane < traffic.lanes:
            continue
        gaps = lane_gaps(traffic, lane)
        for column, (gap, speed) in enumerate(((gaps.front_gap_m, gaps.front_speed_mps),
                                               (gaps.rear_gap_m, gaps.rear_speed_mps))):
            seen = gap <= range_m
            block[row, 2 * column] = min(max(gap, 0.0) / range_m, 1.0) if seen else 1.0
            block[row, 2 * column + 1] = min(max((speed - ego.speed_mps) / v_max_mps, -1.0), 1.0) if seen else 0.0
    return block.ravel()


def test_lane_block_is_the_per_lane_computation_bit_for_bit_on_random_scenes():
    rng = np.random.default_rng(35)
    for _ in range(3000):
        count = int(rng.integers(0, 25))
        lanes = int(rng.integers(1, 6))
        positions = EGO_FRONT + rng.uniform(-140.0, 140.0, count)
        if count and rng.random() < 0.3:  # equal positions: the first of equals is the nearest, as in lane_gaps
            positions[rng.integers(0, count, count // 2)] = positions[0]
        others = [(int(rng.integers(-1, lanes + 1)), float(position), float(rng.choice([4.5, 7.5, 12.0, 16.5])),
                   float(rng.uniform(0.0, 40.0))) for position in positions]
        traffic = view(others, lane=int(rng.integers(-1, lanes)), speed=float(rng.uniform(0.0, 40.0)), lanes=lanes)
        if count and rng.random() < 0.2:  # a vehicle on a road not linked to the route: placed at -inf, lane -1000
            traffic.neighbours.lane_position_m[0], traffic.neighbours.lane[0] = -np.inf, -1000
        range_m, v_max_mps = float(rng.choice([50.0, 100.0, 120.0])), float(rng.choice([33.33, 36.0]))
        expected = lane_block_per_lane(traffic, range_m, v_max_mps)
        actual = lane_block(traffic, range_m, v_max_mps)
        assert actual.dtype == np.float32 and actual.tobytes() == expected.tobytes()


def test_the_leader_gap_of_rows_is_the_lane_gaps_front_gap_bit_for_bit():
    """The seat evaluation's one gap to the leader (`leader_gap_m`, here on the ego and its neighbours) is what
    `lane_gaps` finds ahead of the ego in its lane, to the bit, with equal positions and lanes nobody is in."""
    rng = np.random.default_rng(52)
    for _ in range(2000):
        count = int(rng.integers(0, 20))
        positions = EGO_FRONT + rng.uniform(-140.0, 140.0, count)
        if count and rng.random() < 0.3:
            positions[rng.integers(0, count, count // 2)] = positions[0]
        others = [(int(rng.integers(0, 3)), float(position), float(rng.choice([4.5, 7.5, 16.5])), 30.0)
                  for position in positions]
        traffic = view(others, lane=int(rng.integers(0, 3)), speed=25.0, lanes=3)
        assert ego_leader_gap_m(traffic) == lane_gaps(traffic, traffic.ego.lane).front_gap_m


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
