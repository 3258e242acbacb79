"""The action-reading rule on synthetic tracks whose actions are known."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from sumo_rail.config import EnvConfig
from sumo_rail.recordings.actions import ActionRule, ego_limits, read_actions, read_track
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
    assert RULE.dead_band_mps2 == pytest.approx(0.5 * 2.6)
    slow = ActionRule.for_env(EnvConfig(speed_step_mps=0.5))  # a step of 0.5 m/s adds at most 1 m/s^2 a period
    assert slow.dead_band_mps2 == pytest.approx(0.5 * 0.5 / 0.5)


def test_speed_changes_beyond_the_dead_band_are_accelerate_and_decelerate():
    # 0..1 s cruising with a dawdle of 1 m/s^2; 1..2.5 s +1.6 m/s^2; 2.5..4 s -2.0 m/s^2; then cruising
    acceleration = np.select([TIME < 1.0, TIME < 2.5, TIME < 4.0], [1.0 * np.sin(8 * TIME), 1.6, -2.0], 0.0)
    speed = 25.0 + np.concatenate([[0.0], np.cumsum(acceleration[:-1] * STEP_S)])
    expected = [Action.KEEP] * 2 + [Action.ACCELERATE] * 3 + [Action.DECELERATE] * 3 + [Action.KEEP] * 2
    assert read(speed).tolist() == [int(action) for action in expected]


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
    lane = np.where(TIME < 3.05, 2, 1)
    speed = 25.0 + 2.0 * TIME  # accelerating throughout
    actions = read(speed, lane)
    assert actions[6] == Action.LANE_RIGHT and (np.delete(actions, 6) == Action.ACCELERATE).all()


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
