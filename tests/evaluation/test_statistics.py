import numpy as np
import pytest
from scipy import stats

from sumo_rail.evaluation.statistics import (
    MIN_PAIRS,
    RESAMPLES,
    Interval,
    closeness_difference,
    interval,
    mean_sample,
    paired_difference,
    ratio,
    seeded_interval,
    slope,
)


def test_mean_interval_is_seeded_and_covers_the_mean():
    values = np.random.default_rng(0).normal(10.0, 2.0, 200)
    first, again = interval(mean_sample(values), seed=3), interval(mean_sample(values), seed=3)
    assert first == again
    assert first.estimate == pytest.approx(values.mean())
    half_width = 1.96 * values.std(ddof=1) / np.sqrt(len(values))  # the normal-theory interval, for scale
    assert first.low < values.mean() < first.high
    assert (first.high - first.low) / 2 == pytest.approx(half_width, rel=0.15)
    assert interval(mean_sample(values), seed=4) != first



def test_an_interval_is_the_95_percent_percentile_interval_of_the_seeded_resamples():
    """Where no resample is undefined, the interval is scipy's own 95% percentile interval on the same draws (a
    90% or 99% interval, from a wrong tail, differs by far more than the rounding allowed here)."""
    values = np.random.default_rng(0).normal(10.0, 2.0, 200)
    ours = interval(mean_sample(values), seed=3)
    scipys = stats.bootstrap((values,), np.mean, confidence_level=0.95, n_resamples=RESAMPLES, method="percentile",
                             random_state=np.random.default_rng(3)).confidence_interval
    assert (ours.low, ours.high) == pytest.approx((scipys.low, scipys.high), rel=1e-9)

def test_ratio_pools_over_episodes():
    agreements, decisions = np.array([9, 1]), np.array([10, 90])
    assert ratio((agreements, decisions)) == pytest.approx(10 / 100)  # not the mean of 0.9 and 0.011
    assert interval((agreements, decisions)).estimate == pytest.approx(0.1)


def test_paired_difference_cancels_what_the_seeds_share():
    rng = np.random.default_rng(1)
    traffic = rng.normal(100.0, 10.0, 60)           # the seed's traffic moves both drivers alike
    a, b = traffic + 1.0 + rng.normal(0, 0.1, 60), traffic + rng.normal(0, 0.1, 60)
    paired = paired_difference(mean_sample(a), mean_sample(b))
    assert paired.excludes_zero and paired.low > 0.9 and paired.high < 1.1
    unpaired = paired_difference(mean_sample(a), mean_sample(rng.permutation(b)))
    assert not unpaired.excludes_zero  # shuffled pairs hide the same difference in the traffic's spread


def test_closeness_difference_says_which_is_closer_to_the_target():
    rng = np.random.default_rng(2)
    target = rng.normal(2.4, 1.0, 100)
    near, far = target + rng.normal(0.1, 0.2, 100), target + rng.normal(1.5, 0.2, 100)
    assert closeness_difference(mean_sample(near), mean_sample(far), mean_sample(target)).high < 0
    assert closeness_difference(mean_sample(far), mean_sample(near), mean_sample(target)).low > 0


def test_seeded_interval_holds_the_spread_between_training_runs():
    rng = np.random.default_rng(5)
    traffic = rng.normal(100.0, 10.0, 80)
    # three training runs of one method whose means differ by far more than the episodes' noise after pairing
    runs = [mean_sample(traffic + offset + rng.normal(0, 0.1, 80)) for offset in (0.0, 2.0, 4.0)]
    reference = [mean_sample(traffic + rng.normal(0, 0.1, 80))] * 3
    found = seeded_interval(runs, reference, seed=1)
    assert found == seeded_interval(runs, reference, seed=1)
    assert found.estimate == pytest.approx(2.0, abs=0.05)
    assert found.low < 0.5 and found.high > 3.5  # the runs' spread, 0 to 4, not the episodes' 0.1
    pooled = paired_difference(mean_sample(np.concatenate([r[0] for r in runs])),
                               mean_sample(np.concatenate([r[0] for r in reference])))
    assert pooled.high - pooled.low < (found.high - found.low) / 3  # episodes alone would claim far more certainty
    # with one run it is the episode bootstrap: close to the paired interval
    assert seeded_interval(runs[:1], reference[:1]) == paired_difference(runs[0], reference[0])
    alone = seeded_interval(runs)
    assert alone.estimate == pytest.approx(np.mean([r[0] for r in runs]))
    with pytest.raises(ValueError, match="same numbers of runs and episodes"):
        seeded_interval(runs, reference[:2])


def shares(*hits: int, episodes: int = 200) -> list[tuple[np.ndarray, np.ndarray]]:
    """One run per count in `hits`: that many of its `episodes` episodes had the event (a collision, say)."""
    return [mean_sample((np.arange(episodes) < count).astype(float)) for count in hits]


def test_a_shares_interval_over_training_runs_stays_within_0_and_1():
    """A rare event seen in one run of three: the t interval about the pooled 0.005 reaches below 0, where no share
    lies; a share's is cut at 0 (and at 1 for one seen almost always), the estimate kept; one inside is the same."""
    rare, plain = shares(3, 0, 0), seeded_interval(shares(3, 0, 0))
    assert plain.low < 0.0  # what the bounds are for
    assert seeded_interval(rare, share=True) == Interval(plain.estimate, 0.0, plain.high)
    usual = seeded_interval(shares(197, 200, 200), share=True)
    assert usual.estimate == pytest.approx(0.995) and usual.high == 1.0 < seeded_interval(shares(197, 200, 200)).high
    assert seeded_interval(shares(90, 100, 110), share=True) == seeded_interval(shares(90, 100, 110))
    difference = seeded_interval(shares(197, 200, 200), shares(3, 0, 0), share=True)  # a difference: in [-1, 1]
    assert difference.high == 1.0 < seeded_interval(shares(197, 200, 200), shares(3, 0, 0)).high
    with pytest.raises(ValueError, match="between 0 and their denominators"):
        seeded_interval([mean_sample(np.array([0.5, 2.0]))] * 3, share=True)


def test_seeded_interval_covers_the_method_mean_with_three_runs():
    rng = np.random.default_rng(7)
    covered, trials = 0, 200
    for _ in range(trials):  # the training runs' spread (sd 1) dominates the episodes' noise (sd 1 / sqrt(60))
        runs = [mean_sample(rng.normal(rng.normal(0.0, 1.0), 1.0, 60)) for _ in range(3)]
        found = seeded_interval(runs)
        covered += found.low <= 0.0 <= found.high
    assert covered / trials >= 0.9


def test_slope_interval_covers_the_true_slope_and_separates_rising_from_flat():
    rng = np.random.default_rng(3)
    x = np.arange(6) * 5.0  # six validations, every 5 iterations
    covered, rising_found, flat_called_rising, trials = 0, 0, 0, 400
    for _ in range(trials):
        rising = slope(x, 0.1 + 0.004 * x + rng.normal(0.0, 0.01, x.size))
        flat = slope(x, 0.1 + rng.normal(0.0, 0.01, x.size))
        covered += rising.low <= 0.004 <= rising.high
        rising_found += rising.low > 0
        flat_called_rising += flat.low > 0
    assert 0.9 <= covered / trials <= 0.99
    assert rising_found / trials > 0.95 and flat_called_rising / trials < 0.06


def test_slope_of_a_line_and_of_too_few_points():
    exact = slope(np.array([0.0, 1.0, 2.0, 3.0]), np.array([1.0, 3.0, 5.0, 7.0]))
    assert (exact.estimate, exact.low, exact.high) == pytest.approx((2.0, 2.0, 2.0))
    two = slope(np.array([0.0, 1.0]), np.array([0.0, 1.0]))
    assert two.estimate == pytest.approx(1.0) and np.isnan(two.low)
    assert np.isnan(slope(np.array([1.0, 1.0, 1.0]), np.array([0.0, 1.0, 2.0])).estimate)


def test_degenerate_samples():
    constant = interval(mean_sample(np.full(5, 2.0)))
    assert (constant.estimate, constant.low, constant.high) == (2.0, 2.0, 2.0)
    assert np.isnan(interval(mean_sample(np.array([1.0]))).low)
    assert np.isnan(interval((np.zeros(4), np.zeros(4))).estimate)
    with pytest.raises(ValueError, match="same number of episodes"):
        paired_difference(mean_sample(np.ones(3)), mean_sample(np.ones(4)))


def test_formatting():
    assert Interval(0.5, 0.25, 0.75).format(3) == "0.500 [0.250, 0.750]"
    assert Interval(-1.0, -2.0, 0.5).format(2, signed=True) == "-1.00 [-2.00, +0.50]"
    assert Interval(float("nan"), float("nan"), float("nan")).format() == "n/a"
    assert Interval(1.0, 0.1, 2.0).excludes_zero and not Interval(1.0, -0.1, 2.0).excludes_zero



@pytest.mark.parametrize("pairs", range(1, MIN_PAIRS))
def test_too_few_pairs_give_no_interval_and_no_detectable_difference(pairs):
    """Pairs that all differ alike by 14: below MIN_PAIRS the difference has no interval ("n/a"), however alike
    they are; from MIN_PAIRS on it has one, which excludes 0."""
    ours, theirs = mean_sample(np.full(pairs, 15.0)), mean_sample(np.ones(pairs))
    few = paired_difference(ours, theirs)
    assert few.estimate == 14.0 and np.isnan(few.low) and np.isnan(few.high) and not few.excludes_zero
    assert few.format(signed=True) == "+14.00 [n/a]"
    closer = closeness_difference(theirs, ours, theirs)
    assert closer.estimate == -14.0 and np.isnan(closer.high)
    enough = paired_difference(mean_sample(np.full(MIN_PAIRS, 15.0)), mean_sample(np.ones(MIN_PAIRS)))
    assert enough.excludes_zero and enough.format(signed=True) == "+14.00 [+14.00, +14.00]"
