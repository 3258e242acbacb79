"""The acceleration interface's reading of a track: each period's mean acceleration in its bin, no dead band, the lane
change at its onset, NGSIM's noisy speeds smoothed."""

from __future__ import annotations

import numpy as np
import pytest

from sumo_rail.action_config import ActionConfig
from sumo_rail.recordings.acceleration_reading import (
    period_accelerations,
    read_acceleration_track,
    smoothing_for,
)
from sumo_rail.recordings.actions import ActionRule
from sumo_rail.sim.actions import Lateral, split_acceleration_action

INTERFACE = ActionConfig(interface="acceleration")
RULE = ActionRule(decision_period_s=0.5, dead_band_mps2=1.3, speed_step_mps=2.0)


def track(accelerations_mps2: list[float], rate_hz: float, period_s: float = 0.5, speed_mps: float = 25.0):
    """Rows at `rate_hz` of a vehicle holding each acceleration [m/s^2] for one period in turn: (times, speeds); at
    25 Hz a period's end falls between two rows (0.5 s is 12.5 frames)."""
    time_s = np.arange(round(len(accelerations_mps2) * period_s * rate_hz) + 1) / rate_hz
    ends = speed_mps + np.concatenate([[0.0], np.cumsum(np.array(accelerations_mps2) * period_s)])
    return time_s, np.interp(time_s, period_s * np.arange(len(ends)), ends)


@pytest.mark.parametrize(("rate_hz", "held"), [(10.0, [0.25, -0.25, 0.0, 1.0, -3.5, 2.75, 0.5]),
                                               (25.0, [0.25, -0.25, 0.0, 1.0, 0.5, 1.25, 0.5])])
def test_each_periods_acceleration_is_read_exactly_with_no_dead_band(rate_hz, held):
    """At 25 Hz (highD) an instant falls midway between two rows, 0.02 s from each: where the acceleration jumps by j
    there, the speed interpolated at the instant is off by j x 0.01 s, a period's mean by 0.02 j."""
    time_s, speeds = track(held, rate_hz)
    lanes, edges = np.zeros(len(time_s), int), np.full(len(time_s), "e")
    instants, actions, accelerations = read_acceleration_track(time_s, speeds, lanes, edges, None, RULE, INTERFACE)
    np.testing.assert_allclose(instants, 0.5 * np.arange(len(held)), atol=1e-9)
    # exact at 10 Hz; at 25 Hz the rows straddle the instants where the acceleration changes
    np.testing.assert_allclose(accelerations, held, atol=1e-9 if rate_hz == 10.0 else 0.02)
    read = [INTERFACE.acceleration_mps2(split_acceleration_action(int(a), INTERFACE)[0]) for a in actions]
    assert read == held  # gentle changes (0.25 m/s^2) are not keep
    assert all(split_acceleration_action(int(a), INTERFACE)[1] is Lateral.KEEP for a in actions)


def test_an_acceleration_beyond_the_range_is_read_as_the_ranges_end():
    time_s, speeds = track([-8.0, 4.0], 10.0)
    _, actions, accelerations = read_acceleration_track(time_s, speeds, np.zeros(len(time_s), int),
                                                        np.full(len(time_s), "e"), None, RULE, INTERFACE)
    assert accelerations == pytest.approx([-8.0, 4.0])
    assert [split_acceleration_action(int(a), INTERFACE)[0] for a in actions] == [0, INTERFACE.acceleration_bins - 1]


def test_a_lane_change_is_read_at_its_onset_with_the_periods_acceleration():
    time_s, speeds = track([0.0] * 8, 10.0)
    lateral = np.where(time_s < 1.2, 0.0, np.minimum((time_s - 1.2) * 1.0, 3.2))  # sideways from 1.2 s at 1 m/s
    lanes = np.where(lateral > 1.6, 1, 0)  # the centre crosses the marking at 2.8 s
    _, actions, _ = read_acceleration_track(time_s, speeds + 0.0 * time_s, lanes, np.full(len(time_s), "e"),
                                            lateral, RULE, INTERFACE)
    decoded = [split_acceleration_action(int(a), INTERFACE) for a in actions]
    assert [lateral for _, lateral in decoded].index(Lateral.LEFT) == 2  # began in the period 1.0 .. 1.5 s
    assert sum(lateral is not Lateral.KEEP for _, lateral in decoded) == 1
    assert decoded[2][0] == INTERFACE.nearest_bin(0.0)


def test_a_track_shorter_than_one_period_reads_no_decision_even_with_a_lane_change():
    time_s = np.arange(4) * 0.1  # 0.3 s: no decision instant with a whole period after it
    instants, actions, accelerations = read_acceleration_track(time_s, np.full(4, 20.0), np.array([0, 0, 1, 1]),
                                                               np.full(4, "e"), None, RULE, INTERFACE)
    assert len(instants) == len(actions) == len(accelerations) == 0


def test_smoothing_takes_most_of_ngsims_noise_out_of_the_reading():
    """A driver whose acceleration swings as a sine of 8 s, its speeds with NGSIM-like noise at 10 Hz."""
    rng = np.random.default_rng(0)
    time_s = np.arange(0, 40.01, 0.1)
    speeds = 25.0 + 8.0 / (2 * np.pi) * (1 - np.cos(2 * np.pi * time_s / 8.0))  # acceleration sin(2 pi t / 8)
    noisy = speeds + rng.normal(0.0, 0.15, len(speeds))
    instants = 0.5 * np.arange(80)
    truth = np.diff(np.interp(0.5 * np.arange(81), time_s, speeds)) / 0.5
    raw = period_accelerations(time_s, noisy, instants, 0.5)
    smoothed = period_accelerations(time_s, noisy, instants, 0.5, smoothing_for("ngsim"))
    inner = slice(2, -2)  # away from the ends, where the average is one-sided

    def rms(read):
        return float(np.sqrt(np.mean((read[inner] - truth[inner]) ** 2)))

    assert rms(smoothed) < 0.5 * rms(raw)
    assert smoothing_for("highd") == smoothing_for("fcd") == 0.0 and smoothing_for("ngsim") == 1.0
