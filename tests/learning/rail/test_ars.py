import math

import numpy as np
import pytest

from sumo_rail.learning.rail.ars import NoiseAdaptation, adapt_noise, ars_update, centred_ranks
from sumo_rail.learning.rail.noise import directions


def test_hand_computed_update():
    theta = np.array([1.0, -1.0], dtype=np.float32)
    deltas = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], dtype=np.float32)
    step = ars_update(theta, deltas, np.array([1.0, 3.0, 2.0]), np.array([2.0, 0.0, 5.0]), top=2, step_size=0.1)
    # max(r+, r-) = [2, 3, 5] -> directions 2 then 1; selected returns {2, 5, 3, 0}: mean 2.5, variance 13 / 4.
    assert step.selected.tolist() == [2, 1]
    assert step.reward_std == pytest.approx(math.sqrt(3.25))
    # sum = (2 - 5) * [1, 1] + (3 - 0) * [0, 1] = [-3, 0]
    expected = np.array([1.0 - 0.1 / (2 * math.sqrt(3.25)) * 3.0, -1.0], dtype=np.float32)
    assert step.parameters.dtype == np.float32
    np.testing.assert_array_equal(step.parameters, expected)


def test_top_n_is_ars_v1_with_reward_std_scaling():
    rng = np.random.default_rng(1)
    theta = rng.normal(size=6).astype(np.float32)
    deltas = directions(3, 0, 5, 6)
    plus, minus = rng.normal(size=5), rng.normal(size=5)
    step = ars_update(theta, deltas, plus, minus, top=5, step_size=0.02)
    sigma = np.std(np.concatenate([plus, minus]))
    expected = theta + 0.02 / (5 * sigma) * sum((p - m) * d.astype(np.float64)
                                                 for p, m, d in zip(plus, minus, deltas, strict=True))
    assert sorted(step.selected.tolist()) == [0, 1, 2, 3, 4]
    np.testing.assert_allclose(step.parameters, expected, rtol=1e-6)
    assert step.reward_std == pytest.approx(sigma)


def test_ties_are_broken_by_lower_index():
    deltas = np.eye(5, dtype=np.float32)
    step = ars_update(np.zeros(5, dtype=np.float32), deltas, np.array([1.0, 3.0, 0.0, 2.0, 3.0]),
                      np.array([0.0, 1.0, 3.0, 0.0, 3.0]), top=5, step_size=1.0)
    assert step.selected.tolist() == [1, 2, 4, 3, 0]  # max = [1, 3, 3, 2, 3]
    equal = ars_update(np.zeros(5, dtype=np.float32), deltas, np.full(5, 2.0), np.array([0.0, 2.0, 1.0, 2.0, 0.0]),
                       top=3, step_size=1.0)
    assert equal.selected.tolist() == [0, 1, 2]


def test_equal_returns_keep_parameters():
    theta = np.array([0.5, -0.25, 3.0], dtype=np.float32)
    step = ars_update(theta, directions(0, 0, 4, 3), np.full(4, 7.0), np.full(4, 7.0), top=2, step_size=0.1)
    assert step.reward_std == 0.0
    assert step.parameters.tobytes() == theta.tobytes()
    assert step.parameters is not theta


def test_ascends_a_quadratic_objective():
    size, count, top, nu = 8, 16, 8, 0.05
    target = np.linspace(-2.0, 2.0, size)
    theta = np.zeros(size, dtype=np.float32)

    def objective(values: np.ndarray) -> np.ndarray:
        return -np.sum(np.square(values - target), axis=-1)

    start = objective(theta)
    for iteration in range(300):
        deltas = directions(42, iteration, count, size)
        step = ars_update(theta, deltas, objective(theta + nu * deltas), objective(theta - nu * deltas), top, 0.02)
        theta = step.parameters
    assert objective(theta) > 0.01 * start  # from -||target||^2 ~ -13 to within 1 % of it


def test_invalid_arguments():
    theta, deltas, returns = np.zeros(2, dtype=np.float32), np.zeros((3, 2), dtype=np.float32), np.zeros(3)
    with pytest.raises(ValueError, match="flat vector"):
        ars_update(np.zeros((2, 1)), deltas, returns, returns, 1, 0.1)
    with pytest.raises(ValueError, match=r"deltas must have shape \(N, 2\)"):
        ars_update(theta, np.zeros((3, 4)), returns, returns, 1, 0.1)
    with pytest.raises(ValueError, match=r"returns must have shape \(3,\)"):
        ars_update(theta, deltas, np.zeros(2), returns, 1, 0.1)
    with pytest.raises(ValueError, match="finite"):
        ars_update(theta, deltas, np.array([0.0, np.nan, 1.0]), returns, 1, 0.1)
    for top in (0, 4):
        with pytest.raises(ValueError, match="top must be between 1 and"):
            ars_update(theta, deltas, returns, returns, top, 0.1)
    with pytest.raises(ValueError, match=r"rail\.noise\.every must be between 1 and"):
        NoiseAdaptation(every=0)


def noise_sequence(returns: list[float], schedule: NoiseAdaptation) -> list[float]:
    """nu after each iteration, as a training loop would track it: best so far vs best at the previous check."""
    nu, best_before, best_now, history = schedule.initial, -math.inf, -math.inf, []
    for iteration, value in enumerate(returns):
        best_now = max(best_now, value)
        nu = adapt_noise(nu, iteration, best_before, best_now, schedule)
        if (iteration + 1) % schedule.every == 0:
            best_before = best_now
        history.append(nu)
    return history


def test_noise_grows_while_stagnating_and_resets_on_improvement():
    schedule = NoiseAdaptation(initial=0.03, increment=0.001, every=3)
    improving = noise_sequence([float(k) for k in range(9)], schedule)
    assert improving == [0.03] * 9
    stagnating = noise_sequence([5.0, 1.0, 2.0, 4.0, 3.0, 5.0, 0.0, 0.0, 0.0, 6.0, 0.0, 0.0], schedule)
    # checks after iterations 2 (first best: improved), 5 (5 <= 5: +tau), 8 (still 5: +tau), 11 (6 > 5: reset)
    expected = [0.03] * 5 + [0.031] * 3 + [0.032] * 3 + [0.03]
    np.testing.assert_allclose(stagnating, expected, rtol=0, atol=1e-12)
    assert adapt_noise(0.05, 4, 1.0, 1.0, schedule) == 0.05  # not a check iteration: unchanged
    assert adapt_noise(0.05, 5, 1.0, 1.0, schedule) == pytest.approx(0.051)  # check, equal is not an improvement
    assert adapt_noise(0.05, 5, 1.0, 1.5, schedule) == 0.03


def test_rank_shaping_ignores_the_scale_of_the_returns_and_keeps_the_top_directions():
    deltas = directions(3, 0, 6, 10)
    plus, minus = np.array([3.0, -1.0, 0.5, 8.0, 2.0, -4.0]), np.array([1.0, 0.0, 0.4, -2.0, 2.5, -5.0])
    theta = np.zeros(10, np.float32)
    ranked = ars_update(theta, deltas, plus, minus, 3, 0.1, "rank")
    squashed = ars_update(theta, deltas, np.cbrt(plus) * 100, np.cbrt(minus) * 100, 3, 0.1, "rank")
    assert np.array_equal(ranked.parameters, squashed.parameters)  # any increasing transform: the same step
    assert ranked.selected.tolist() == ars_update(theta, deltas, plus, minus, 3, 0.1).selected.tolist() == [3, 0, 4]
    ranks = centred_ranks(np.concatenate([plus, minus]))
    assert ranks.min() == -0.5 and ranks.max() == 0.5 and ranks.sum() == pytest.approx(0.0)
    expected = 0.1 / 3 * sum((ranks[k] - ranks[6 + k]) * deltas[k].astype(np.float64) for k in (3, 0, 4))
    np.testing.assert_allclose(ranked.parameters, expected, rtol=1e-6)
    with pytest.raises(ValueError, match="fitness shaping"):
        ars_update(theta, deltas, plus, minus, 3, 0.1, "softmax")


def test_centred_ranks_share_ties():
    assert centred_ranks(np.array([1.0, 1.0, 3.0])).tolist() == [-0.25, -0.25, 0.5]
