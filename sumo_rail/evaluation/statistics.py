"""95% confidence intervals by bootstrap over episodes (scipy.stats.bootstrap's resamples, percentile intervals,
seeded so the same input gives the same interval).

Every estimate is a ratio of sums over episodes, sum(numerator) / sum(denominator): a plain mean has a
denominator of ones, and a rate such as agreement pools decisions over episodes (agreements / decisions), so an
episode weighs by its decisions. Paired estimates resample seeds, keeping each seed's episodes of every driver
together, so traffic shared by two drivers cancels out of their difference. A method trained with several seeds
(`seeded_interval`) is resampled over its training seeds and the evaluation episodes together, so the interval
also holds the spread between training runs; `hierarchical_interval` does so by one bootstrap of both (seeds and
seats drawn in each resample) instead of a t factor on the seeds.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

CONFIDENCE = 0.95
RESAMPLES = 2000
MIN_PAIRS = 6
"""Fewest pairs (seeds) a paired difference gets an interval from; with fewer its interval is "n/a" and it is never
detectable. Below 6, not even differences all of one sign are significant at the 5% level (a two-sided sign test
gives 2 x 0.5^5 = 0.0625 for five of five), so no interval from the pairs alone may claim a difference; a percentile
bootstrap of so few pairs has few distinct resamples (126 for five) and spans the pairs' own range at most, an
interval of one value when they are alike."""


@dataclass(frozen=True)
class Interval:
    """An estimate and its confidence interval (NaN where there is nothing to estimate)."""

    estimate: float
    low: float
    high: float

    @property
    def excludes_zero(self) -> bool:
        """The interval lies wholly above or below 0: a detectable difference."""
        return bool(self.low > 0 or self.high < 0)

    def format(self, digits: int = 2, signed: bool = False) -> str:
        """'1.23 [1.10, 1.35]' ('+' signs with `signed`); '1.23 [n/a]' without an interval, 'n/a' without an
        estimate."""
        if np.isnan(self.estimate):
            return "n/a"
        spec = f"{'+' if signed else ''}.{digits}f"
        if np.isnan(self.low) or np.isnan(self.high):
            return f"{self.estimate:{spec}} [n/a]"
        return f"{self.estimate:{spec}} [{self.low:{spec}}, {self.high:{spec}}]"


Sample = tuple[np.ndarray, np.ndarray]
"""(numerators, denominators), one entry per episode."""


def ratio(sample: Sample, axis: int = -1) -> np.ndarray:
    """sum(numerators) / sum(denominators) along `axis` (NaN where the denominators sum to 0)."""
    numerators, denominators = sample
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sum(numerators, axis=axis) / np.sum(denominators, axis=axis)


def mean_sample(values: np.ndarray) -> Sample:
    """The sample of a plain mean."""
    values = np.asarray(values, dtype=float)
    return values, np.ones_like(values)


def interval(sample: Sample, seed: int = 0) -> Interval:
    """The pooled ratio of one driver's episodes with its interval."""
    return _bootstrap([sample], lambda a: ratio(a), seed)


def paired_difference(sample: Sample, reference: Sample, seed: int = 0) -> Interval:
    """ratio(sample) - ratio(reference), episodes paired by seed (same order in both); no interval (NaN bounds) from
    fewer than MIN_PAIRS pairs."""
    return _bootstrap([sample, reference], lambda a, r: ratio(a) - ratio(r), seed, least=MIN_PAIRS)


def closeness_difference(sample: Sample, other: Sample, target: Sample, seed: int = 0) -> Interval:
    """|ratio(sample) - ratio(target)| - |ratio(other) - ratio(target)|, paired by seed: below 0 where `sample`
    is closer to `target` than `other` is; no interval (NaN bounds) from fewer than MIN_PAIRS triples."""
    return _bootstrap([sample, other, target],
                      lambda a, b, t: np.abs(ratio(a) - ratio(t)) - np.abs(ratio(b) - ratio(t)), seed, least=MIN_PAIRS)


def seeded_interval(sample: Sequence[Sample], reference: Sequence[Sample] | None = None,
                    seed: int = 0, share: bool = False) -> Interval:
    """A method's pooled ratio over its training runs (`sample`, one Sample per training seed, every run on the
    same episodes), or its difference to `reference` (paired run by run, e.g. RAIL seed s against the BC it started
    from, and episode by episode). One run: the episode bootstrap (`interval`, `paired_difference`). Several runs:
    the pooled estimate +- t(runs - 1) x sqrt(s^2 / runs + se^2), where s is the standard deviation of the runs' own
    estimates (the spread between training runs) and se the standard error over episodes of the pooled estimate
    (from its episode bootstrap: half the 95% width / 1.96), as every run meets the same episodes. Student's t
    keeps the coverage with as few as three runs, which a percentile bootstrap over runs does not (about 78%).

    A share (`share`: every numerator a part of its denominator, so the ratio lies in [0, 1], a difference of two in
    [-1, 1]) has its interval cut to that range: the t interval is symmetric and knows no bounds, and the part of it
    outside the range holds no value a share can take, so the cut interval holds the true share whenever the whole
    one did (the same coverage) and says nothing impossible (no collision share below 0). An interval inside the range
    is left as it is (the bootstrap's never leaves it)."""
    shapes = {np.shape(part) for group in (sample, reference or sample) for pair in group for part in pair}
    if len(sample) != len(reference or sample) or len(shapes) != 1 or len(shapes.pop()) != 1:
        raise ValueError("paired training runs must have the same numbers of runs and episodes")
    if share and not all(_is_share(run) for run in [*sample, *(reference or [])]):
        raise ValueError("a share's numerators must lie between 0 and their denominators")
    found = _seeded(sample, reference, seed)
    if not share:
        return found
    least = 0.0 if reference is None else -1.0
    return Interval(found.estimate, float(np.clip(found.low, least, 1.0)), float(np.clip(found.high, least, 1.0)))


def _is_share(run: Sample) -> bool:
    """Whether every numerator of `run` lies between 0 and its denominator."""
    numerators, denominators = (np.asarray(part, dtype=float) for part in run)
    return bool(np.all((numerators >= 0) & (numerators <= denominators)))


def _seeded(sample: Sequence[Sample], reference: Sequence[Sample] | None, seed: int) -> Interval:
    """`seeded_interval` of any ratio (no range known)."""
    pooled = [_sum_runs(group) for group in ([sample] if reference is None else [sample, reference])]
    episodes = interval(pooled[0], seed) if reference is None else paired_difference(pooled[0], pooled[1], seed)
    own = np.array([ratio(run) for run in sample]) - (0.0 if reference is None else
                                                      np.array([ratio(run) for run in reference]))
    own = own[~np.isnan(own)]
    if len(own) < 2 or np.isnan(episodes.low):
        return episodes
    episode_error = (episodes.high - episodes.low) / (2 * stats.norm.ppf(0.5 + CONFIDENCE / 2))
    half = stats.t.ppf(0.5 + CONFIDENCE / 2, len(own) - 1) * np.hypot(np.std(own, ddof=1) / np.sqrt(len(own)),
                                                                       episode_error)
    return Interval(episodes.estimate, float(episodes.estimate - half), float(episodes.estimate + half))


def hierarchical_interval(sample: Sequence[Sample], reference: Sequence[Sample] | None = None,
                          seed: int = 0) -> Interval:
    """`seeded_interval`'s estimate (a method's pooled ratio over its training runs, `sample` one Sample per training
    seed on the same seats, or its difference to `reference`, paired run by run and seat by seat) with a percentile
    interval from one bootstrap of training seeds and seats together: each of `RESAMPLES` resamples draws the runs
    with replacement and, once for all of them, the seats with replacement, and recomputes the pooled ratio (or
    difference) over the drawn runs' drawn seats. Seats are crossed with seeds, not nested in them (every run meets the
    same seats), so one draw of seats serves every run (the pigeonhole bootstrap of crossed designs, Owen 2007):
    a seat's own difficulty then weighs in the interval once, as in the estimate, and the seeds' disagreement through
    the drawn runs. Seeded (`seed`), so the same input gives the same interval. With one run it is the seat bootstrap;
    with few runs the draw of runs sees their spread only through them (three runs give ten distinct draws), so it is
    narrower than the between-run spread deserves (tests/evaluation/test_hierarchical_bootstrap.py measures the
    coverage). NaN bounds from fewer than MIN_PAIRS seats for a difference (2 for a level); resamples where a ratio is
    undefined are left out."""
    groups = [sample] if reference is None else [sample, reference]
    numerators = [np.array([np.asarray(run[0], dtype=float) for run in group]) for group in groups]
    denominators = [np.array([np.asarray(run[1], dtype=float) for run in group]) for group in groups]
    shapes = {array.shape for array in (*numerators, *denominators)}
    if len(shapes) != 1 or len(next(iter(shapes))) != 2:
        raise ValueError("paired training runs must have the same numbers of runs and episodes")
    runs, seats = shapes.pop()

    def pooled(run_weights: np.ndarray, seat_weights: np.ndarray) -> np.ndarray:
        """The statistic under weights (B, runs) and (B, seats): how often each run and seat was drawn."""
        values = [np.einsum("br,rs,bs->b", run_weights, numerator, seat_weights)
                  / np.einsum("br,rs,bs->b", run_weights, denominator, seat_weights)
                  for numerator, denominator in zip(numerators, denominators, strict=True)]
        return values[0] if reference is None else values[0] - values[1]

    with np.errstate(invalid="ignore", divide="ignore"):
        estimate = float(pooled(np.ones((1, runs)), np.ones((1, seats)))[0])
        if seats < (2 if reference is None else MIN_PAIRS) or np.isnan(estimate):
            return Interval(estimate, np.nan, np.nan)
        rng = np.random.default_rng(seed)
        run_weights = rng.multinomial(runs, np.full(runs, 1.0 / runs), size=RESAMPLES).astype(float)
        seat_weights = rng.multinomial(seats, np.full(seats, 1.0 / seats), size=RESAMPLES).astype(float)
        resampled = pooled(run_weights, seat_weights)
    tail = 50 * (1 - CONFIDENCE)
    low, high = np.nanpercentile(resampled, [tail, 100 - tail])
    return Interval(estimate, float(low), float(high))


def slope(x: np.ndarray, y: np.ndarray) -> Interval:
    """The least-squares slope of y on x [y per unit of x] with its interval: the slope +- t(n - 2) x its standard
    error (scipy.stats.linregress), which assumes independent, equally noisy points about a straight line. NaN
    bounds with fewer than three points."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if len(x) < 2 or len(np.unique(x)) < 2:
        return Interval(np.nan, np.nan, np.nan)
    fit = stats.linregress(x, y)
    if len(x) < 3:
        return Interval(float(fit.slope), np.nan, np.nan)
    half = stats.t.ppf(0.5 + CONFIDENCE / 2, len(x) - 2) * fit.stderr
    return Interval(float(fit.slope), float(fit.slope - half), float(fit.slope + half))


def _sum_runs(runs: Sequence[Sample]) -> Sample:
    """Numerators and denominators summed over training runs, episode by episode."""
    return (np.sum([np.asarray(run[0], dtype=float) for run in runs], axis=0),
            np.sum([np.asarray(run[1], dtype=float) for run in runs], axis=0))


def _bootstrap(samples: Sequence[Sample], statistic: Callable[..., np.ndarray], seed: int, least: int = 2) -> Interval:
    """`statistic` of `samples` with its percentile interval over episodes resampled together; NaN bounds from fewer
    than `least` episodes."""
    arrays = [np.asarray(part, dtype=float) for sample in samples for part in sample]
    lengths = {len(array) for array in arrays}
    if len(lengths) != 1:
        raise ValueError(f"paired samples must have the same number of episodes, got {sorted(lengths)}")

    def on_arrays(*flat: np.ndarray, axis: int = -1) -> np.ndarray:
        pairs = [(np.moveaxis(flat[i], axis, -1), np.moveaxis(flat[i + 1], axis, -1)) for i in range(0, len(flat), 2)]
        return statistic(*pairs)

    estimate = float(on_arrays(*arrays))
    if lengths.pop() < least or np.isnan(estimate):
        return Interval(estimate, np.nan, np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # constant samples: the interval is the estimate itself
        result = stats.bootstrap(arrays, on_arrays, paired=True, vectorized=True, confidence_level=CONFIDENCE,
                                 n_resamples=RESAMPLES, method="percentile", random_state=np.random.default_rng(seed))
    # Percentiles of the resampled estimates, leaving out resamples where a rate is undefined (no decision of
    # the kind drawn, as with rare lane changes); scipy's own interval would be NaN then.
    tail = 50 * (1 - CONFIDENCE)
    low, high = np.nanpercentile(result.bootstrap_distribution, [tail, 100 - tail])
    return Interval(estimate, float(low), float(high))
