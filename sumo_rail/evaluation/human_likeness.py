"""How human a driver is in a recorded scene: how far its track drifts from the human's it replaced, and how far its
distributions (speeds, accelerations, headways, lane-change gaps) are from the humans'.

A track is a table with columns `time_s` [s], `x_m` and `y_m` [m] (positions in the recording's plane), time
increasing. The position error at horizon h is the distance between the driven and the reference track h seconds
after the reference's start, both interpolated linearly in time (the displacement error of nuPlan's open-loop and
Waymax's log metrics, at one instant); undefined (NaN) when either track ends earlier (the driven one after a
collision, say). Distributions are compared with the Wasserstein-1 distance (in the quantity's own unit), and its
interval comes from a bootstrap that resamples whole vehicles or episodes: values of one vehicle are not independent.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy.stats import wasserstein_distance

from sumo_rail.evaluation.statistics import CONFIDENCE, RESAMPLES, Interval, interval, mean_sample

HORIZONS_S = (1.0, 2.0, 5.0, 10.0, 15.0, 20.0)
"""Horizons of the position error [s] (the field's curve: 1-5 s as Kuefler et al., 10-20 s as PS-GAIL's and the Sim
Agents' longer rollouts); a horizon beyond an episode's end is NaN there."""


def position_at(track: pd.DataFrame, time_s: float) -> np.ndarray:
    """The track's (x, y) [m] at `time_s` [s], linearly interpolated; NaNs outside the track's time span."""
    times = track["time_s"].to_numpy(dtype=float)
    if len(times) == 0 or not times[0] <= time_s <= times[-1]:
        return np.full(2, np.nan)
    return np.array([np.interp(time_s, times, track[axis].to_numpy(dtype=float)) for axis in ("x_m", "y_m")])


def position_errors(driven: pd.DataFrame, reference: pd.DataFrame,
                    horizons_s: Sequence[float] = HORIZONS_S) -> np.ndarray:
    """The distance [m] between `driven` and `reference` at each horizon [s] after the reference's start; NaN where
    either track has ended."""
    if reference.empty:
        raise ValueError("the reference track is empty")
    start = float(reference["time_s"].iloc[0])
    return np.array([float(np.hypot(*(position_at(driven, start + h) - position_at(reference, start + h))))
                     for h in horizons_s])


def track_rmse(driven: pd.DataFrame, reference: pd.DataFrame) -> tuple[float, float]:
    """(position [m], speed [m/s]) root mean square error of `driven` against `reference` over the driven track's
    instants within the reference's time span (the reference interpolated linearly there); NaNs without any."""
    times = driven["time_s"].to_numpy(dtype=float)
    reference_times = reference["time_s"].to_numpy(dtype=float)
    inside = (times >= reference_times[0]) & (times <= reference_times[-1]) if len(reference_times) else times < 0
    if not inside.any():
        return np.nan, np.nan
    times = times[inside]
    squared = {name: (driven[name].to_numpy(dtype=float)[inside]
                      - np.interp(times, reference_times, reference[name].to_numpy(dtype=float))) ** 2
               for name in ("x_m", "y_m", "speed_mps")}
    return float(np.sqrt(np.mean(squared["x_m"] + squared["y_m"]))), float(np.sqrt(np.mean(squared["speed_mps"])))


def position_error_intervals(pairs: Sequence[tuple[pd.DataFrame, pd.DataFrame]], seed: int = 0,
                             horizons_s: Sequence[float] = HORIZONS_S) -> dict[float, Interval]:
    """Per horizon [s], the mean position error [m] over the episodes (driven, reference) whose tracks both reach it,
    with its 95% bootstrap interval over episodes (`statistics.interval`); NaN without any."""
    errors = np.array([position_errors(driven, reference, horizons_s) for driven, reference in pairs],
                      dtype=float).reshape(len(pairs), len(horizons_s))
    result = {}
    for column, horizon in enumerate(horizons_s):
        reached = errors[:, column][~np.isnan(errors[:, column])]
        result[float(horizon)] = (interval(mean_sample(reached), seed) if len(reached)
                                  else Interval(np.nan, np.nan, np.nan))
    return result


def wasserstein(ours: np.ndarray, theirs: np.ndarray) -> float:
    """Wasserstein-1 distance between two samples (NaNs left out), in their unit; NaN when either is empty."""
    ours, theirs = (np.asarray(values, dtype=float) for values in (ours, theirs))
    ours, theirs = ours[~np.isnan(ours)], theirs[~np.isnan(theirs)]
    return float(wasserstein_distance(ours, theirs)) if len(ours) and len(theirs) else np.nan


def wasserstein_interval(ours: Sequence[np.ndarray], theirs: Sequence[np.ndarray], seed: int = 0,
                         resamples: int = RESAMPLES) -> Interval:
    """The Wasserstein-1 distance between two samples given in groups (one array per vehicle or episode), with a
    95% percentile interval from resampling whole groups of each side with replacement (`resamples` times, seeded:
    the same input gives the same interval). NaN bounds with fewer than two groups on a side.

    A resample is the same values weighted by how often their group was drawn, so the values are sorted once and
    each resample's distance is the area between the two weighted distribution functions (`_weighted_w1`): the
    distance scipy gives for the resampled values, in a few numpy operations."""
    ours, theirs = ([np.asarray(group, dtype=float) for group in side] for side in (ours, theirs))
    estimate = wasserstein(_joined(ours), _joined(theirs))
    if min(len(ours), len(theirs)) < 2 or np.isnan(estimate):
        return Interval(estimate, np.nan, np.nan)
    values, groups, is_ours = _sorted_groups(ours, theirs)
    steps, in_draw = np.diff(values), np.where(is_ours, groups, len(ours) + groups)
    rng = np.random.default_rng(seed)
    drawn = np.array([np.concatenate([np.bincount(rng.integers(count, size=count), minlength=count)
                                      for count in (len(ours), len(theirs))]) for _ in range(resamples)])
    return _percentile_interval(estimate, _weighted_w1(steps, drawn, in_draw, is_ours))


def paired_wasserstein_interval(ours: Sequence[np.ndarray], others: Sequence[np.ndarray],
                                theirs: Sequence[np.ndarray], seed: int = 0, resamples: int = RESAMPLES) -> Interval:
    """W1(ours, theirs) - W1(others, theirs): how much farther one driver's distribution is from the humans' than
    another's, the three samples given seat by seat (element i of each: that driver's values in seat i, a method's
    training runs pooled), with a 95% percentile interval from resampling whole seats with replacement, the same
    seats for the three (paired: the traffic of a seat is common to both drivers and the human). NaN bounds with
    fewer than two seats."""
    if not len(ours) == len(others) == len(theirs):
        raise ValueError("paired samples must be given for the same seats")
    ours, others, theirs = ([np.asarray(group, dtype=float) for group in side] for side in (ours, others, theirs))
    estimate = (wasserstein(_joined(ours), _joined(theirs)) - wasserstein(_joined(others), _joined(theirs)))
    if len(ours) < 2 or np.isnan(estimate):
        return Interval(estimate, np.nan, np.nan)
    pairs = [(np.diff(values), groups, is_ours)
             for values, groups, is_ours in (_sorted_groups(side, theirs) for side in (ours, others))]
    rng = np.random.default_rng(seed)
    drawn = np.array([np.bincount(rng.integers(len(ours), size=len(ours)), minlength=len(ours))
                      for _ in range(resamples)])
    ours_draws, others_draws = (_weighted_w1(steps, drawn, groups, is_ours) for steps, groups, is_ours in pairs)
    return _percentile_interval(estimate, ours_draws - others_draws)


def _sorted_groups(ours: Sequence[np.ndarray], theirs: Sequence[np.ndarray]
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Both sides' values (NaNs left out) sorted, with each value's group (its index within its side) and whether it
    is one of `ours`."""
    values = np.concatenate([_joined(ours), _joined(theirs)])
    groups = np.concatenate([np.repeat(np.arange(len(side)), [len(group) for group in side])
                             for side in (ours, theirs)])
    side = np.repeat([0, 1], [sum(map(len, ours)), sum(map(len, theirs))])
    keep = ~np.isnan(values)
    order = np.argsort(values[keep], kind="stable")
    return values[keep][order], groups[keep][order], side[keep][order] == 0


def _percentile_interval(estimate: float, draws: np.ndarray) -> Interval:
    """The estimate with the 95% percentile interval of its bootstrap `draws` (NaN draws left out)."""
    tail = 50 * (1 - CONFIDENCE)
    low, high = np.nanpercentile(draws, [tail, 100 - tail])
    return Interval(estimate, float(low), float(high))


def _weighted_w1(steps: np.ndarray, drawn: np.ndarray, groups: np.ndarray, is_ours: np.ndarray) -> np.ndarray:
    """The Wasserstein-1 distance of each resample (row of `drawn`: how often each group was drawn) between the two
    weighted samples of the same sorted values whose gaps are `steps` (`np.diff` of the values): `groups` each
    value's index into a row, `is_ours` which side it is on; the integral of |F_ours - F_theirs| (the distribution
    functions' cumulative counts kept in integers, so exact); NaN where a side has no weight. One row at a time
    into buffers made once (rows at once are slower: the arrays leave the cache)."""
    count = len(groups)
    weights, ours_weights, ours, everyone = (np.empty(count, dtype=np.int64) for _ in range(4))
    ours_share, theirs_share = np.empty(count - 1), np.empty(count - 1)
    distances = np.full(len(drawn), np.nan)
    for row, draw in enumerate(drawn):
        np.take(draw, groups, out=weights)
        np.cumsum(np.multiply(weights, is_ours, out=ours_weights), out=ours)
        theirs = np.subtract(np.cumsum(weights, out=everyone), ours, out=everyone)
        if ours[-1] and theirs[-1]:
            np.divide(ours[:-1], ours[-1], out=ours_share)
            np.divide(theirs[:-1], theirs[-1], out=theirs_share)
            difference = np.abs(np.subtract(ours_share, theirs_share, out=ours_share), out=ours_share)
            distances[row] = np.multiply(difference, steps, out=difference).sum()
    return distances


def _joined(groups: Sequence[np.ndarray]) -> np.ndarray:
    return np.concatenate(groups) if groups else np.empty(0)
