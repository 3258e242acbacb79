"""How a learner's driving in recorded scenes is distributed against the humans': Wasserstein-1 distances with a
bootstrap interval that resamples whole vehicles (a vehicle's values are not independent draws)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.stats import wasserstein_distance

from sumo_rail.evaluation.statistics import CONFIDENCE, RESAMPLES, Interval


def _pooled(per_vehicle: Sequence[np.ndarray], chosen: np.ndarray) -> np.ndarray:
    values = [np.asarray(per_vehicle[i], dtype=float) for i in chosen]
    pooled = np.concatenate(values) if values else np.zeros(0)
    return pooled[np.isfinite(pooled)]


def wasserstein_interval(learner: Sequence[np.ndarray], human: Sequence[np.ndarray], seed: int = 0,
                         resamples: int = RESAMPLES) -> Interval:
    """W1 between the pooled finite values of the learner's vehicles and the humans' (each a list with one array
    per vehicle, in the quantity's unit), with a percentile interval from resampling the vehicles of each side
    with replacement; NaN where a side has no value."""
    everyone = (np.arange(len(learner)), np.arange(len(human)))
    ours, theirs = _pooled(learner, everyone[0]), _pooled(human, everyone[1])
    if ours.size == 0 or theirs.size == 0:
        return Interval(np.nan, np.nan, np.nan)
    estimate = float(wasserstein_distance(ours, theirs))
    rng = np.random.default_rng(seed)
    draws = []
    for _ in range(resamples):
        ours = _pooled(learner, rng.integers(len(learner), size=len(learner)))
        theirs = _pooled(human, rng.integers(len(human), size=len(human)))
        if ours.size and theirs.size:
            draws.append(wasserstein_distance(ours, theirs))
    tail = 50 * (1 - CONFIDENCE)
    low, high = np.percentile(draws, [tail, 100 - tail]) if draws else (np.nan, np.nan)
    return Interval(estimate, float(low), float(high))
