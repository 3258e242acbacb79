import math

import libsumo
import numpy as np
import pytest
from scenes import two_vehicle_road, view

from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.period_safety import CUT_IN_WINDOW_S, PeriodSafety, jerk_readings, jerks, nearest_follower
from sumo_rail.sim.simulation import EGO_ID
from sumo_rail.sim.vehicles import PeriodReport


def report(accelerations=(), watched=None):
    return PeriodReport(False, False, False, min(accelerations, default=0.0), 0, None, tuple(accelerations),
                        watched or {})


def test_jerk_is_the_change_of_acceleration_per_step_across_periods():
    assert jerks([1.0, 1.5, 0.5], None, 0.1) == pytest.approx([5.0, 10.0])
    assert jerks([1.0], 0.0, 0.1) == pytest.approx([10.0])  # against the last step of the period before
    assert len(jerks([], 0.0, 0.1)) == 0


def test_the_jerk_readings_are_numpys_bit_for_bit():
    """The readings as they were computed with numpy: |diff| / step, then max(initial=0) and mean."""
    rng = np.random.default_rng(36)
    for _ in range(3000):
        accelerations = rng.normal(0.0, 2.0, int(rng.integers(0, 21))) * rng.choice([1e-3, 1.0, 10.0])
        previous = None if rng.random() < 0.2 else float(rng.normal(0.0, 2.0))
        step = float(rng.choice([0.1, 0.05, 0.2]))
        series = np.asarray(([] if previous is None else [previous]) + accelerations.tolist(), dtype=float)
        expected = np.abs(np.diff(series)) / step
        period_jerks = jerks(accelerations.tolist(), previous, step)
        assert np.array_equal(period_jerks, expected)
        jerk_max, jerk_mean = jerk_readings(period_jerks)
        assert jerk_max == float(expected.max(initial=0.0))
        assert jerk_mean == (float(expected.mean()) if len(expected) else 0.0)


def test_the_follower_is_the_nearest_vehicle_behind_the_ego_in_that_lane():
    traffic = view([(2, 980.0, 4.5, 30.0), (2, 960.0, 4.5, 30.0), (2, 998.0, 4.5, 30.0), (1, 990.0, 4.5, 30.0)])
    assert nearest_follower(traffic.ego, traffic.neighbours, 2) == "v0"  # v2 is alongside (front past our rear)
    assert nearest_follower(traffic.ego, traffic.neighbours, 3) is None


def test_a_started_change_watches_the_new_follower_for_the_window_only():
    safety = PeriodSafety(step_length_s=0.1, decision_period_s=0.5)
    changing = view([(2, 980.0, 4.5, 30.0)], lateral=0.3)  # between lanes, after a request for lane 2
    first = safety.update(report([0.0, 0.0]), changing.ego, changing.neighbours, 2, was_changing=False)
    assert first["cut_ins"] == 1 and first["cut_in_follower_accel_mps2"] == math.inf and safety.watched() == ("v0",)
    periods = round(CUT_IN_WINDOW_S / 0.5)
    readings = [safety.update(report([0.0], {"v0": -1.0 - k}), changing.ego, changing.neighbours, None, True)
                for k in range(periods + 1)]
    assert [reading["cut_in_follower_accel_mps2"] for reading in readings[:periods]] == [-1.0 - k for k in
                                                                                          range(periods)]
    assert readings[periods]["cut_in_follower_accel_mps2"] == math.inf and safety.watched() == ()
    assert sum(reading["cut_ins"] for reading in readings) == 0  # a change already under way is no new cut-in
    refused = PeriodSafety(0.1, 0.5).update(report(), view([(2, 980.0, 4.5, 30.0)]).ego, changing.neighbours, 2,
                                            was_changing=False)
    assert refused["cut_ins"] == 0  # the request did not start a change


def test_a_scripted_cut_in_in_sumo_reads_the_followers_known_deceleration(small_config):
    """The ego at 25 m/s changes left in front of a follower 40 m behind at 25 m/s; once the change has started
    the follower is told to slow down to 20 m/s over 2 s, a deceleration of 2.5 m/s^2, which the readings give."""
    env = HighwayEnv(small_config)
    try:
        edge = two_vehicle_road(env, "follower", 2, 25.0, 25.0)
        libsumo.vehicle.moveTo(EGO_ID, f"{edge}_1", 400.0)
        libsumo.vehicle.moveTo("follower", f"{edge}_2", 400.0 - 4.5 - 40.0)
        env.step(Action.KEEP)
        infos = [env.step(Action.LANE_LEFT)[4]]
        assert infos[0]["cut_ins"] == 1 and infos[0]["lane_change_in_progress"]
        libsumo.vehicle.slowDown("follower", 20.0, 2.0)
        infos += [env.step(Action.KEEP)[4] for _ in range(7)]
    finally:
        env.close()
    follower = np.array([info["cut_in_follower_accel_mps2"] for info in infos])
    assert follower[0] == math.inf  # watched from the period after the one the change started in
    assert follower.min() == pytest.approx(-2.5, abs=1e-6)
    assert follower[7] == math.inf  # 3 s later it is no longer watched


def test_a_request_made_while_a_change_is_under_way_is_no_new_cut_in():
    """The same request, ego between lanes with a follower in the requested lane: a cut-in only when no change was
    under way before it (the first test's later periods pass no request, so they cannot tell)."""
    changing = view([(2, 980.0, 4.5, 30.0)], lateral=0.3)
    under_way = PeriodSafety(0.1, 0.5).update(report([0.0]), changing.ego, changing.neighbours, 2, was_changing=True)
    assert under_way["cut_ins"] == 0
    fresh = PeriodSafety(0.1, 0.5).update(report([0.0]), changing.ego, changing.neighbours, 2, was_changing=False)
    assert fresh["cut_ins"] == 1


def test_a_scripted_braking_reads_its_known_jerk_in_sumo(small_config):
    """The ego held at 25 m/s is told to slow down to 20 m/s over 2 s (2.5 m/s^2) at a decision: its acceleration
    goes 0 -> -2.5 m/s^2 in one 0.1 s step, a jerk of 25 m/s^3, one of the period's five steps (mean 5 m/s^3); the
    periods before read 0 (both SUMO scenes above run at constant speed, where any jerk passes)."""
    env = HighwayEnv(small_config)
    try:
        two_vehicle_road(env, "other", 4, 25.0, 25.0)
        steady = [env.step(Action.KEEP)[4] for _ in range(2)]
        libsumo.vehicle.slowDown(EGO_ID, 20.0, 2.0)
        braking = env.step(Action.KEEP)[4]
    finally:
        env.close()
    assert [(info["jerk_max_mps3"], info["jerk_mean_mps3"]) for info in steady] == [(0.0, 0.0), (0.0, 0.0)]
    assert braking["jerk_max_mps3"] == pytest.approx(2.5 / 0.1)
    assert braking["jerk_mean_mps3"] == pytest.approx(2.5 / 0.1 / 5)
