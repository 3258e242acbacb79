"""The log as a teacher: on the human's own state it says what the human did; off the track it steers back."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from sumo_rail.action_config import ActionConfig
from sumo_rail.learning.log_teacher import log_label, read_human_track, return_acceleration
from sumo_rail.recordings.acceleration_reading import read_acceleration_track
from sumo_rail.recordings.actions import ActionRule
from sumo_rail.sim.actions import Lateral, split_acceleration_action

INTERFACE = ActionConfig(interface="acceleration")
RULE = ActionRule(decision_period_s=0.5, dead_band_mps2=1.3, speed_step_mps=2.0)
HORIZON_S = 3.0


def human_rows(rate_hz: float = 10.0) -> pd.DataFrame:
    """20 s of a driver that speeds up, brakes, cruises and changes one lane to the left from 9 s (sideways at 1 m/s
    from lane 0's centre, 0.0 m, to lane 1's, 3.2 m)."""
    time_s = np.arange(round(20.0 * rate_hz) + 1) / rate_hz
    acceleration = np.select([time_s < 4.0, time_s < 7.0, time_s < 12.0], [1.25, -2.0, 0.0], 0.5)
    speed = 25.0 + np.concatenate([[0.0], np.cumsum(acceleration[:-1] * np.diff(time_s))])
    position = 100.0 + np.concatenate([[0.0], np.cumsum((speed[:-1] + speed[1:]) / 2.0 * np.diff(time_s))])
    lateral = np.clip(time_s - 9.0, 0.0, 3.2)
    return pd.DataFrame({"time_s": time_s, "speed_mps": speed, "lane_position_m": position,
                         "lane": np.where(lateral > 1.6, 1, 0), "edge": "e", "y_m": lateral})


def test_on_the_humans_own_state_the_label_is_the_humans_read_action():
    rows = human_rows()
    human = read_human_track(rows, RULE, INTERFACE)
    columns = [rows[name].to_numpy() for name in ("time_s", "speed_mps", "lane", "edge", "y_m")]
    instants, read, _ = read_acceleration_track(*columns, RULE, INTERFACE)
    labels = []
    for instant in instants:
        at = rows.iloc[int(np.argmin(np.abs(rows["time_s"] - instant)))]
        labels.append(log_label(float(instant), float(at["lane_position_m"]), float(at["speed_mps"]), int(at["lane"]),
                                human, HORIZON_S, INTERFACE))
    assert labels == read.tolist()
    assert any(split_acceleration_action(a, INTERFACE)[1] is Lateral.LEFT for a in labels)  # the change is in it
    assert len({split_acceleration_action(a, INTERFACE)[0] for a in labels}) >= 3  # and several accelerations


@pytest.mark.parametrize(("position_offset_m", "speed_offset_mps", "sign"),
                         [(-10.0, 0.0, +1), (+10.0, 0.0, -1), (0.0, -3.0, +1), (0.0, +3.0, -1)])
def test_behind_or_slower_it_accelerates_more_ahead_or_faster_less(position_offset_m, speed_offset_mps, sign):
    rows = human_rows()
    human = read_human_track(rows, RULE, INTERFACE)
    at = rows.iloc[20]  # 2 s, the human accelerating at 1.25 m/s^2
    human_action = log_label(2.0, float(at["lane_position_m"]), float(at["speed_mps"]), 0, human, HORIZON_S, INTERFACE)
    action = log_label(2.0, float(at["lane_position_m"]) + position_offset_m, float(at["speed_mps"]) + speed_offset_mps,
                       0, human, HORIZON_S, INTERFACE)
    assert human_action is not None and action is not None
    bins = [split_acceleration_action(a, INTERFACE)[0] for a in (human_action, action)]
    assert np.sign(bins[1] - bins[0]) == sign


def test_the_correction_closes_position_and_speed_at_the_horizon():
    """Following the human's accelerations plus the correction d, the errors at H are e_p + e_v H + d H^2 / 2 and
    e_v + d H: d minimises their squares (position, H x speed), so neither error grows and a lag is closed."""
    for e_p, e_v in [(-10.0, 0.0), (0.0, 2.0), (5.0, -1.0)]:
        d = return_acceleration(e_p, e_v, HORIZON_S)
        cost = [(e_p + e_v * HORIZON_S + x * HORIZON_S**2 / 2) ** 2 + (HORIZON_S * (e_v + x * HORIZON_S)) ** 2
                for x in (d - 0.01, d, d + 0.01)]
        assert cost[1] < min(cost[0], cost[2])
    assert abs(-10.0 + return_acceleration(-10.0, 0.0, HORIZON_S) * HORIZON_S**2 / 2) < 10.0
    # a longer horizon returns more gently
    assert abs(return_acceleration(-10.0, 0.0, 6.0)) < abs(return_acceleration(-10.0, 0.0, 2.0))


def test_far_off_the_label_is_the_ranges_end_and_the_lane_change_goes_toward_the_humans_lane():
    rows = human_rows()
    human = read_human_track(rows, RULE, INTERFACE)
    at = rows.iloc[110]  # 11 s: the human crossed into lane 1 at 10.6 s
    far_behind = log_label(11.0, float(at["lane_position_m"]) - 500.0, float(at["speed_mps"]), 0, human, HORIZON_S,
                           INTERFACE)
    assert far_behind is not None
    bin_, lateral = split_acceleration_action(far_behind, INTERFACE)
    assert bin_ == INTERFACE.acceleration_bins - 1  # clipped to +3 m/s^2
    assert lateral is Lateral.LEFT  # an ego left in lane 0 follows the human into lane 1
    at = rows.iloc[150]  # 15 s: the human in lane 1; an ego in lane 2 goes right, one in lane 1 keeps its lane
    assert split_acceleration_action(log_label(15.0, float(at["lane_position_m"]), float(at["speed_mps"]), 2, human,
                                               HORIZON_S, INTERFACE), INTERFACE)[1] is Lateral.RIGHT
    assert split_acceleration_action(log_label(15.0, float(at["lane_position_m"]), float(at["speed_mps"]), 1, human,
                                               HORIZON_S, INTERFACE), INTERFACE)[1] is Lateral.KEEP


def test_no_label_past_the_tracks_last_decision_or_before_its_first():
    human = read_human_track(human_rows(), RULE, INTERFACE)
    assert log_label(19.9, 600.0, 30.0, 1, human, HORIZON_S, INTERFACE) is not None  # the last period: 19.5-20 s
    assert log_label(20.0, 600.0, 30.0, 1, human, HORIZON_S, INTERFACE) is None
    assert log_label(-0.5, 100.0, 25.0, 0, human, HORIZON_S, INTERFACE) is None
