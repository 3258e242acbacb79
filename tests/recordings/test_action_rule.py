"""The action-reading rule on synthetic tracks whose actions are known."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from sumo_rail.config import EnvConfig
from sumo_rail.recordings.actions import ActionRule, ego_limits, read_actions, read_track, speed_actions
from sumo_rail.sim.actions import Action

RULE = ActionRule.for_env(EnvConfig())
STEP_S = 0.1
TIME = np.arange(0.0, 5.0 + 1e-9, STEP_S)
"""Ten decision periods of 0.5 s at SUMO's 0.1 s step."""


def read(speed: np.ndarray, lane: np.ndarray | None = None, lateral: np.ndarray | None = None) -> np.ndarray:
    lanes = np.zeros(len(TIME), dtype=int) if lane is None else lane
    return read_track(TIME, speed, lanes, np.full(len(TIME), "road"), lateral, RULE)[1]


def test_the_dead_band_is_half_of_what_one_set_point_step_does_to_the_acc_ego():
    assert ego_limits() == (2.6, 3.0)  # networks/traffic.rou.xml, vType ego
    assert RULE.dead_band_mps2 == pytest.approx(0.5 * 2.6) and RULE.speed_step_mps == EnvConfig().speed_step_mps
    slow = ActionRule.for_env(EnvConfig(speed_step_mps=0.5))  # a step of 0.5 m/s adds at most 1 m/s^2 a period
    assert slow.dead_band_mps2 == pytest.approx(0.5 * 0.5 / 0.5)


def acc_speeds(set_points: list[float], start_mps: float, limits: list[float] | None = None) -> np.ndarray:
    """The speeds [m/s] at SUMO's steps of an ego whose ACC drives toward the set-point of each period (one per
    0.5 s period) at the ego type's full acceleration (2.6) and deceleration (3.0 m/s^2), never above the period's
    speed limit (`limits`: a slower leader; default none)."""
    speeds = [start_mps]
    for time_s in TIME[1:]:
        period = min(int((time_s - 1e-9) / 0.5), len(set_points) - 1)
        target = min(set_points[period], limits[period] if limits else np.inf)
        speeds.append(float(np.clip(target, speeds[-1] - 3.0 * STEP_S, speeds[-1] + 2.6 * STEP_S)))
    return np.array(speeds)


def test_a_run_of_accelerates_is_counted_in_set_point_steps_not_in_accelerating_periods():
    # accelerates at periods 2 and 3 (+2 m/s each): the ACC closes 4 m/s at 2.6 m/s^2 over periods 2 to 5; a
    # decelerate at period 7 closes 2 m/s at 3.0 m/s^2 over periods 7 and 8
    set_points = [25.0] * 2 + [27.0] + [29.0] * 4 + [27.0] * 3
    actions = read(acc_speeds(set_points, 25.0))
    expected = [Action.KEEP] * 2 + [Action.ACCELERATE] * 2 + [Action.KEEP] * 3 + [Action.DECELERATE] + [Action.KEEP] * 2
    assert actions.tolist() == [int(action) for action in expected]


def test_the_acc_catching_up_on_its_set_point_or_following_a_leader_is_keep():
    # an accelerate at period 0 (25 -> 27 m/s); a slower leader then holds the ego at 23 m/s over periods 3 to 5
    # (3 m/s^2 of braking, begun below the set-point after the gentle slowing of period 2, 1.2 m/s^2); the leader leaves
    # and the ACC climbs back to the set-point it had: one accelerate, all else keep
    limits = [np.inf] * 2 + [26.4] + [23.0] * 3 + [np.inf] * 4
    speeds = acc_speeds([27.0] * 10, 25.0, limits)
    assert (np.diff(speeds[::5]) / 0.5 < -1.3).any() and (np.diff(speeds[::5]) / 0.5 > 1.3).sum() >= 3
    actions = read(speeds)
    assert actions[0] == Action.ACCELERATE and (actions[1:] == Action.KEEP).all()


def test_the_set_point_follows_a_gentle_speed_change_before_a_step():
    # 2 m/s gained at 0.8 m/s^2 (within the dead band: keep) over 0 .. 2.5 s, then one set-point step closed by the ACC
    gentle = np.clip(25.0 + 0.8 * TIME, None, 27.0)
    speed = np.clip(gentle + 2.6 * np.clip(TIME - 2.5, 0.0, None), None, 29.0)
    assert read(speed).tolist() == [0, 0, 0, 0, 0, 1, 0, 0, 0, 0]


def test_a_speed_phase_above_the_set_point_adds_the_steps_it_gained():
    # from cruising at the set-point, 4 m/s gained at 1.6 m/s^2 over 2.5 s: two steps, in the phase's first periods
    acceleration = np.where((TIME >= 1.0) & (TIME < 3.5), 1.6, 0.0)
    speed = 25.0 + np.concatenate([[0.0], np.cumsum(acceleration[:-1] * STEP_S)])
    assert read(speed).tolist() == [0, 0, 1, 1, 0, 0, 0, 0, 0, 0]


def test_a_lane_change_belongs_to_the_period_in_which_the_sideways_movement_began():
    # left from lane 1 to lane 2 (3.2 m lanes): sideways at 1.6 m/s from 1.2 s, crossing the marking at 2.2 s
    lateral = np.clip(1.6 * (TIME - 1.2), 0.0, 3.2) - 4.8
    lane = np.where(lateral > -3.2 - 1e-9, 2, 1)
    actions = read(np.full(len(TIME), 25.0), lane, lateral)
    assert actions[2] == Action.LANE_LEFT  # the period 1.0 .. 1.5 s, not 2.0 .. 2.5 s when the lane index changed
    assert (np.delete(actions, 2) == Action.KEEP).all()
    without_positions = read(np.full(len(TIME), 25.0), lane, None)
    assert without_positions[4] == Action.LANE_LEFT and without_positions[2] == Action.KEEP


def test_a_lower_lane_index_is_a_change_to_the_right_and_wins_over_the_speed():
    lane = np.where(TIME < 1.05, 2, 1)
    speed = 25.0 + 2.0 * TIME  # accelerating throughout: 10 m/s, five set-point steps
    assert read(speed, lane).tolist() == [1, 1, 4, 1, 1, 0, 0, 0, 0, 0]


def test_a_lane_index_that_changes_with_the_edge_is_not_a_lane_change():
    edges = np.where(TIME < 2.0, "a", "b")
    lane = np.where(TIME < 2.0, 1, 2)  # edge b has a lane more on the right
    actions = read_track(TIME, np.full(len(TIME), 25.0), lane, edges, None, RULE)[1]
    assert (actions == Action.KEEP).all()


def test_every_track_of_a_scene_gets_one_action_per_whole_period():
    tracks = pd.DataFrame({"vehicle_id": ["a"] * len(TIME) + ["b"] * 8, "time_s": [*TIME, *TIME[:8]],
                           "speed_mps": 20.0, "lane": 0, "edge": "road", "y_m": -1.6})
    actions = read_actions(tracks, RULE, lateral=True)
    assert actions.groupby("vehicle_id").size().to_dict() == {"a": 10, "b": 1}
    assert actions["time_s"][actions["vehicle_id"] == "a"].to_numpy() == pytest.approx(np.arange(10) * 0.5)


def test_at_25_hz_a_change_starting_between_frames_keeps_its_period():
    """highD's frames (0.04 s) miss every other decision instant (x.5 s): the first frame that has moved decides."""
    time = np.arange(0.0, 5.0 + 1e-9, 0.04)
    lateral = np.clip(1.6 * (time - 1.5), 0.0, 3.2) - 4.8  # starts at 1.5 s, between the frames at 1.48 and 1.52 s
    lane = np.where(lateral > -3.2 - 1e-9, 2, 1)
    actions = read_track(time, np.full(len(time), 25.0), lane, np.full(len(time), "road"), lateral, RULE)[1]
    assert actions[3] == Action.LANE_LEFT and (np.delete(actions, 3) == Action.KEEP).all()


def test_a_lane_first_seen_on_a_decision_instant_changed_in_the_period_before():
    lane = np.where(TIME < 2.0 - 1e-9, 1, 2)  # the row at 2.0 s is the first in lane 2: it changed after 1.9 s
    assert read(np.full(len(TIME), 25.0), lane).tolist().index(Action.LANE_LEFT) == 3


def test_in_a_sweep_over_two_lanes_the_second_change_begins_midway_between_the_crossings():
    # right from lane 3 to lane 1 (3.2 m lanes) at 1.6 m/s from 1.05 s: crossings at 2.05 and 4.05 s
    lateral = -np.clip(1.6 * (TIME - 1.05), 0.0, 6.4)
    lane = np.select([lateral > -1.6, lateral > -4.8], [3, 2], 1)
    actions = read(np.full(len(TIME), 25.0), lane, lateral)
    assert actions[2] == Action.LANE_RIGHT and actions[6] == Action.LANE_RIGHT  # 1.0 .. 1.5 s and 3.0 .. 3.5 s
    assert (np.delete(actions, [2, 6]) == Action.KEEP).all()


def left_change(time: np.ndarray, sideways_mps: float, begin_s: float) -> np.ndarray:
    """The actions read off a change from lane 1 to lane 2 (3.2 m lanes) at 25 m/s, moving sideways at
    `sideways_mps` from `begin_s` on (crossing the marking 1.6 m later)."""
    lateral = np.clip(sideways_mps * (time - begin_s), 0.0, 3.2) - 4.8
    lane = np.where(lateral > -3.2 - 1e-9, 2, 1)
    return read_track(time, np.full(len(time), 25.0), lane, np.full(len(time), "road"), lateral, RULE)[1]


def test_a_slow_sideways_drift_is_a_change_under_way_from_where_it_began():
    # 0.6 m/s sideways (above the 0.2 m/s of lane keeping) from 1.2 s: the marking is crossed 2.7 s later, at 3.9 s
    actions = left_change(TIME, 0.6, 1.2)
    assert actions[2] == Action.LANE_LEFT and (np.delete(actions, 2) == Action.KEEP).all()


def test_a_change_is_looked_for_up_to_three_seconds_before_its_crossing():
    # 1.2 m/s sideways from 1.2 s crosses 1.3 s later: the change is the period 1.0 .. 1.5 s's, not 2.5 .. 3.0 s's
    assert left_change(TIME, 1.2, 1.2).tolist().index(Action.LANE_LEFT) == 2
    # a drift of 0.4 m/s from 0 s crosses at 4 s: read 3 s back, at 1.0 .. 1.5 s, not where the drift began
    drift = left_change(np.arange(0.0, 8.0 + 1e-9, STEP_S), 0.4, 0.0)
    assert drift.tolist().index(Action.LANE_LEFT) == 2 and (np.delete(drift, 2) == Action.KEEP).all()


def speeds_at_instants(accelerations_mps2: list[float]) -> np.ndarray:
    """The speeds [m/s] at the decision instants of a car cruising at its set-point of 25 m/s whose mean
    acceleration over each 0.5 s period is the given one [m/s^2]."""
    return 25.0 + np.concatenate([[0.0], np.cumsum(np.array(accelerations_mps2) * RULE.decision_period_s)])


@pytest.mark.parametrize(("sign", "action"), [(1.0, Action.ACCELERATE), (-1.0, Action.DECELERATE)])
def test_a_phase_lasts_while_its_acceleration_stays_above_the_floor(sign, action):
    # 2.6 m/s^2 for a period, then 0.9 m/s^2 (above the 0.5 m/s^2 floor, within the dead band) for five: 3.55 m/s in
    # one phase, two set-point steps
    speeds = speeds_at_instants([0.0, 0.0, *(sign * np.array([2.6, 0.9, 0.9, 0.9, 0.9, 0.9])), 0.0, 0.0])
    assert speed_actions(speeds, RULE).tolist() == [Action.KEEP] * 2 + [action] * 2 + [Action.KEEP] * 6


@pytest.mark.parametrize(("sign", "action"), [(1.0, Action.ACCELERATE), (-1.0, Action.DECELERATE)])
def test_a_phase_begun_at_the_set_point_is_at_least_one_step(sign, action):
    # 1.6 m/s^2 for one period from the set-point: 0.8 m/s, less than half a 2 m/s step, is still one action
    speeds = speeds_at_instants([0.0, 0.0, sign * 1.6] + [0.0] * 7)
    assert speed_actions(speeds, RULE).tolist() == [Action.KEEP] * 2 + [action] + [Action.KEEP] * 7
