import numpy as np
import pandas as pd
import pytest

from sumo_rail.evaluation.human_likeness import (
    position_error_intervals,
    position_errors,
    track_rmse,
    wasserstein,
    wasserstein_interval,
)


def _track(start_s: float, seconds: float, x0: float = 0.0, y0: float = 0.0, speed: float = 30.0) -> pd.DataFrame:
    times = start_s + np.arange(0.0, seconds + 1e-9, 0.04)  # highD's 25 Hz
    return pd.DataFrame({"time_s": times, "x_m": x0 + speed * (times - start_s), "y_m": np.full(len(times), y0),
                         "speed_mps": np.full(len(times), speed)})


def test_a_constant_offset_track_gives_that_offset_at_every_horizon():
    human = _track(100.0, 20.0)
    beside = _track(100.0, 20.0, x0=3.0, y0=4.0)  # 3 m ahead, 4 m across: 5 m
    assert position_errors(beside, human) == pytest.approx([5.0] * 6)  # 1, 2, 5, 10, 15 and 20 s
    assert position_errors(human, human).tolist() == [0.0] * 6


def test_a_slower_track_drifts_in_proportion_and_an_ended_track_has_no_error():
    human = _track(0.0, 12.0, speed=30.0)
    slower = _track(0.0, 12.0, speed=28.0)  # 2 m/s slower: 2, 10, 20 m behind
    assert position_errors(slower, human, (1.0, 5.0, 10.0)) == pytest.approx([2.0, 10.0, 20.0])
    crashed = _track(0.0, 3.0)
    errors = position_errors(crashed, human)
    assert errors[0] == errors[1] == 0.0 and np.isnan(errors[2:]).all()  # 1 and 2 s reached, 5 s and on not
    assert np.isnan(position_errors(human, human)[-1])  # a 12 s track has no 15 or 20 s error


def test_the_rmse_of_a_drifting_track_is_over_its_instants_within_the_reference():
    human = _track(0.0, 10.0, speed=30.0)
    slower = _track(0.0, 12.0, speed=28.0)  # 2 m/s slower: 2t m behind at t
    times = slower["time_s"].to_numpy()
    within = times[times <= 10.0 + 1e-9]
    position, speed = track_rmse(slower, human)
    assert position == pytest.approx(np.sqrt(np.mean((2 * within) ** 2)))
    assert speed == pytest.approx(2.0)
    assert np.isnan(track_rmse(_track(20.0, 5.0), human)).all()  # no instant in common


def test_errors_over_episodes_have_their_mean_and_interval():
    human = _track(0.0, 12.0)
    pairs = [(_track(0.0, 12.0, y0=offset), human) for offset in (1.0, 2.0, 3.0, 4.0)] + [(_track(0.0, 3.0), human)]
    found = position_error_intervals(pairs, seed=3)
    assert found[1.0].estimate == pytest.approx((1 + 2 + 3 + 4 + 0) / 5)
    assert found[10.0].estimate == pytest.approx(2.5)  # the ended track left out
    assert 1.0 <= found[10.0].low < 2.5 < found[10.0].high <= 4.0
    assert position_error_intervals(pairs, seed=3) == found  # seeded


def test_wasserstein_of_identical_and_shifted_samples():
    speeds = np.random.default_rng(0).normal(30.0, 3.0, 500)
    assert wasserstein(speeds, speeds) == 0.0
    assert wasserstein(speeds + 1.5, speeds) == pytest.approx(1.5)
    assert np.isnan(wasserstein(np.array([np.nan]), speeds))


def test_the_bootstrap_resamples_whole_vehicles_and_is_reproducible():
    rng = np.random.default_rng(1)
    humans = [rng.normal(mean, 1.0, 50) for mean in rng.normal(30.0, 2.0, 40)]
    shifted = [vehicle + 2.0 for vehicle in humans]
    found = wasserstein_interval(shifted, humans, seed=5, resamples=400)
    assert found.estimate == pytest.approx(2.0)
    assert found.low < 2.0 < found.high
    assert wasserstein_interval(shifted, humans, seed=5, resamples=400) == found
    # Vehicles differ more between than within: resampling whole vehicles gives a wider interval than
    # resampling values one by one would (each value its own group).
    values = wasserstein_interval([[v] for g in shifted for v in g], [[v] for g in humans for v in g], seed=5,
                                  resamples=400)
    assert found.high - found.low > 1.5 * (values.high - values.low)
    assert np.isnan(wasserstein_interval([shifted[0]], humans).low)


def test_the_bootstrap_distances_are_scipys_on_the_resampled_values():
    """Each resample weighs the sorted values by how often their group was drawn: the interval is the one a plain
    loop over resampled, concatenated groups gives with scipy's distance."""
    from scipy.stats import wasserstein_distance

    from sumo_rail.evaluation.statistics import CONFIDENCE

    rng = np.random.default_rng(3)
    ours = [rng.normal(1.0, 1.0, rng.integers(1, 6)) for _ in range(12)]
    theirs = [rng.normal(0.0, 2.0, rng.integers(1, 6)) for _ in range(9)]
    theirs[2][0] = np.nan  # left out, as everywhere
    found = wasserstein_interval(ours, theirs, seed=11, resamples=300)
    draws = np.random.default_rng(11)
    plain = []
    for _ in range(300):
        picked = [np.concatenate([side[k] for k in draws.integers(len(side), size=len(side))])
                  for side in (ours, theirs)]
        plain.append(wasserstein_distance(*(values[~np.isnan(values)] for values in picked)))
    tail = 50 * (1 - CONFIDENCE)
    assert (found.low, found.high) == pytest.approx(tuple(np.percentile(plain, [tail, 100 - tail])), rel=1e-9)


def test_the_paired_difference_resamples_seats_common_to_both_drivers_and_the_humans():
    """Seats differ far more than the two drivers do within a seat (one is u_i m/s off the human in seat i, u_i
    between 0 and 1, the other u_i + 1): the difference of their distances is -1 m/s, and resampling the same seats
    for the three keeps it at -1 m/s where resampling each driver's seats on its own (or each side, the unpaired
    intervals) spreads it by the seats' differences."""
    from sumo_rail.evaluation.human_likeness import paired_wasserstein_interval

    rng = np.random.default_rng(2)
    humans = [np.full(10, mean) for mean in rng.normal(30.0, 5.0, 30)]
    offsets = rng.random(30)
    near = [seat + u for seat, u in zip(humans, offsets, strict=True)]
    far = [seat + 1.0 for seat in near]
    found = paired_wasserstein_interval(near, far, humans, seed=3, resamples=300)
    assert found.estimate == pytest.approx(-1.0)
    assert found.low == pytest.approx(-1.0) and found.high == pytest.approx(-1.0)
    alone = [wasserstein_interval(side, humans, seed=3, resamples=300) for side in (near, far)]
    assert min(interval.high - interval.low for interval in alone) > 1.0
    assert paired_wasserstein_interval(near, far, humans, seed=3, resamples=300) == found
    assert np.isnan(paired_wasserstein_interval(near[:1], far[:1], humans[:1]).low)
    with pytest.raises(ValueError, match="same seats"):
        paired_wasserstein_interval(near, far[:-1], humans)
