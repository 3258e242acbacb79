"""Wasserstein distance between learners and humans, with an interval over vehicles."""

from __future__ import annotations

import numpy as np

from sumo_rail.evaluation.human_likeness import wasserstein_interval


def test_shifted_distribution_is_its_shift_and_inside_the_interval():
    rng = np.random.default_rng(0)
    human = [rng.normal(25.0, 2.0, 50) for _ in range(30)]
    learner = [values + 3.0 for values in human]
    result = wasserstein_interval(learner, human, resamples=200)
    assert abs(result.estimate - 3.0) < 1e-9
    assert result.low <= result.estimate <= result.high
    assert result.low > 2.0


def test_interval_widens_with_fewer_vehicles():
    rng = np.random.default_rng(1)
    many = [rng.normal(rng.normal(25.0, 3.0), 1.0, 20) for _ in range(60)]
    few = many[:6]
    wide = wasserstein_interval(few, [v + 1.0 for v in few], resamples=200, seed=2)
    narrow = wasserstein_interval(many, [v + 1.0 for v in many], resamples=200, seed=2)
    assert (wide.high - wide.low) > (narrow.high - narrow.low)


def test_nan_values_are_left_out_and_empty_side_is_nan():
    with_nan = [np.array([1.0, np.nan, 2.0])]
    assert wasserstein_interval(with_nan, [np.array([1.0, 2.0])], resamples=20).estimate == 0.0
    assert np.isnan(wasserstein_interval([np.array([np.nan])], [np.array([1.0])], resamples=20).estimate)
