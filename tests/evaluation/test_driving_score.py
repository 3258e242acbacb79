"""nuPlan-style driving score: gates zero it, terms lower it by their weights."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sumo_rail.evaluation.driving_score import WEIGHTS, EpisodeDriving, comfortable, driving_score, speed_limit_score

CLEAN = EpisodeDriving(step_length_s=0.1, speed_mps=np.full(50, 25.0), acceleration_mps2=np.zeros(50),
                       speed_limit_mps=33.33, min_ttc_s=np.inf, progress_m=125.0, reference_progress_m=125.0,
                       at_fault_collision=False, left_road=False)


def test_clean_episode_scores_one():
    assert driving_score(CLEAN)["driving_score"] == 1.0


@pytest.mark.parametrize("change", [{"at_fault_collision": True}, {"left_road": True}, {"progress_m": 10.0}])
def test_each_gate_zeroes_the_score(change):
    assert driving_score(dataclasses.replace(CLEAN, **change))["driving_score"] == 0.0


def test_ttc_below_bound_costs_its_weight():
    score = driving_score(dataclasses.replace(CLEAN, min_ttc_s=0.5))
    assert score["ttc"] == 0.0
    assert score["driving_score"] == pytest.approx(1.0 - WEIGHTS["ttc"] / sum(WEIGHTS.values()))


def test_half_progress_halves_its_term():
    assert driving_score(dataclasses.replace(CLEAN, progress_m=62.5))["progress"] == pytest.approx(0.5)


def test_speeding_by_the_threshold_all_the_time_scores_zero():
    assert speed_limit_score(np.full(10, 30.0 + 2.23), 30.0, 0.1) == pytest.approx(0.0)
    assert speed_limit_score(np.full(10, 30.0), 30.0, 0.1) == 1.0


def test_comfort_bounds():
    assert comfortable(np.full(5, 2.3), 0.1)
    assert not comfortable(np.full(5, 2.5), 0.1)  # above max_lon_accel
    assert not comfortable(np.full(5, -4.1), 0.1)  # below min_lon_accel
    assert not comfortable(np.array([0.0, 0.5]), 0.1)  # jerk 5 m/s^3 above max_abs_lon_jerk
