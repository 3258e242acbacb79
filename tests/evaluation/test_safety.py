import math

import libsumo
import numpy as np
import pytest
from scenes import two_vehicle_road, view

from sumo_rail.evaluation.safety import (
    HEADWAY_CAP_S,
    SAFETY_MEASURES,
    TTC_CAP_S,
    SafetyObserver,
    ego_time_headway,
    ego_time_to_collision,
    episode_measures,
    time_to_collision,
)
from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.simulation import EGO_ID


def test_time_to_collision_closes_the_gap_at_the_speed_difference():
    assert time_to_collision(30.0, 25.0, 20.0) == 6.0
    assert time_to_collision(30.0, 20.0, 25.0) == math.inf  # the leader pulls away
    assert time_to_collision(30.0, 20.0, 20.0) == math.inf
    assert time_to_collision(math.inf, 30.0, math.nan) == math.inf  # nobody there
    assert time_to_collision(-0.5, 20.0, 25.0) == 0.0  # touching already


def test_ego_ttc_is_the_smaller_of_its_leaders_and_its_followers_in_its_own_lane():
    # leader 20 m ahead closing at 4 m/s (5 s); follower 12 m behind closing at 6 m/s (2 s); left lane ignored
    traffic = view([(1, 1024.5, 4.5, 21.0), (1, 1000.0 - 4.5 - 12.0, 4.5, 31.0), (2, 1010.0, 4.5, 0.0)], speed=25.0)
    assert ego_time_to_collision(traffic) == pytest.approx(2.0)
    assert ego_time_headway(traffic) == pytest.approx(20.0 / 25.0)
    alone = view([], speed=25.0)
    assert ego_time_to_collision(alone) == math.inf and ego_time_headway(alone) == math.inf


def test_episode_measures_count_shares_below_each_threshold_and_cap_the_minima():
    readings = {"jerk_max_mps3": np.array([0.0, 4.0, 1.0, 0.0]), "jerk_mean_mps3": np.array([0.0, 2.0, 1.0, 1.0]),
                "cut_in_follower_accel_mps2": np.array([np.inf, -1.0, -3.5, np.inf]), "cut_ins": np.array([0, 1, 0, 0])}
    measures = episode_measures(np.array([5.0, 2.0, 1.0, math.inf]), np.array([2.0, 1.2, 0.8, math.inf]), 1, readings)
    assert list(measures) == list(SAFETY_MEASURES)
    assert measures == {"min_ttc_s": 1.0, "ttc_below_1_5s_share": 0.25, "ttc_below_3s_share": 0.5,
                        "min_headway_s": 0.8, "invalid_action_share": 0.25, "jerk_max_mps3": 4.0,
                        "jerk_mean_mps3": 1.0, "cut_ins": 1.0, "cut_in_follower_decel_mps2": 3.5}
    calm = episode_measures(np.array([math.inf, 40.0]), np.array([math.inf, math.inf]), 0)
    assert calm["min_ttc_s"] == TTC_CAP_S and calm["min_headway_s"] == HEADWAY_CAP_S
    assert calm["ttc_below_3s_share"] == 0.0 and calm["cut_in_follower_decel_mps2"] == 0.0  # no cut-in


def test_a_constant_speed_follow_in_sumo_gives_its_known_headway_and_ttc(small_config):
    """The ego at 30 m/s behind a leader at 26 m/s, both held at these speeds by SUMO, the gap 21 m at the first
    decision: the gap shrinks by 2 m every 0.5 s decision, so TTC = gap / 4 m/s and headway = gap / 30 m/s."""
    env = HighwayEnv(small_config)
    try:
        edge = two_vehicle_road(env, "leader", 1, 30.0, 26.0)
        lane, ego_front_m = 1, 400.0
        leader_front_m = ego_front_m + 23.0 + 4.5  # 23 m bumper to bumper, 2 m less after the first decision
        libsumo.vehicle.moveTo("leader", f"{edge}_{lane}", leader_front_m)
        libsumo.vehicle.moveTo(EGO_ID, f"{edge}_{lane}", ego_front_m)
        env.step(Action.KEEP)
        with env.watching(SafetyObserver()) as observer:
            for _ in range(9):
                env.step(Action.KEEP)
    finally:
        env.close()
    gaps = 21.0 - 2.0 * np.arange(9)  # in the traffic each decision was made in
    assert observer.decision_columns()["ttc_s"] == pytest.approx(np.minimum(gaps / 4.0, TTC_CAP_S), abs=1e-6)
    measures = observer.episode_columns()
    assert measures["min_ttc_s"] == pytest.approx(5.0 / 4.0, abs=1e-6)
    assert measures["min_headway_s"] == pytest.approx(5.0 / 30.0, abs=1e-6)
    assert measures["ttc_below_3s_share"] == pytest.approx(4 / 9) and measures["ttc_below_1_5s_share"] == 1 / 9
    assert measures["jerk_max_mps3"] == 0.0 and measures["cut_ins"] == 0  # constant speed, no lane change
