"""The hierarchical bootstrap over training seeds and seats (`statistics.hierarchical_interval`): on synthetic
seats whose true mean is known it covers it at about the nominal rate, it widens when the seeds disagree, a paired
difference cancels the seats' own difficulty, and it is deterministic."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from test_scene_summary import seat_rows

from sumo_rail.evaluation.scene_summary import track_table
from sumo_rail.evaluation.statistics import hierarchical_interval, interval, mean_sample


def runs(values: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """One plain-mean sample per training seed (a row of `values`, seeds x seats)."""
    return [mean_sample(row) for row in values]


def crossed(rng: np.random.Generator, seeds: int, seats: int, seed_sd: float, seat_sd: float = 2.0,
            noise_sd: float = 1.0) -> np.ndarray:
    """A measure of `seeds` training runs in the same `seats`: a run's effect + a seat's effect + noise, mean 0."""
    return (rng.normal(0.0, seed_sd, (seeds, 1)) + rng.normal(0.0, seat_sd, (1, seats))
            + rng.normal(0.0, noise_sd, (seeds, seats)))


def test_it_covers_the_true_mean_at_about_the_nominal_rate():
    """200 synthetic evaluations of 10 training seeds in 60 seats (seeds' sd 0.5, seats' 2, noise 1; true mean 0)."""
    rng = np.random.default_rng(3)
    covered = [hierarchical_interval(runs(crossed(rng, 10, 60, 0.5)), seed=k) for k in range(200)]
    coverage = np.mean([found.low <= 0.0 <= found.high for found in covered])
    assert 0.88 <= coverage <= 0.99


def test_it_widens_when_the_seeds_disagree():
    rng = np.random.default_rng(4)
    agreeing = crossed(rng, 3, 60, 0.0)
    disagreeing = agreeing + np.array([[-2.0], [0.0], [2.0]])  # the same seats, the runs 2 apart
    calm, spread = (hierarchical_interval(runs(values), seed=1) for values in (agreeing, disagreeing))
    assert spread.estimate == pytest.approx(calm.estimate)
    assert spread.high - spread.low > 2.0 * (calm.high - calm.low)


def test_one_run_is_the_seat_bootstrap_and_the_same_input_gives_the_same_interval():
    values = crossed(np.random.default_rng(5), 1, 80, 0.0)
    found, seats = hierarchical_interval(runs(values), seed=2), interval(mean_sample(values[0]), seed=2)
    assert found.estimate == pytest.approx(seats.estimate)
    assert found.high - found.low == pytest.approx(seats.high - seats.low, rel=0.15)
    assert hierarchical_interval(runs(values), seed=2) == found


def test_a_paired_difference_cancels_the_seats_difficulty():
    """A method 0.5 above its reference in every seat and run, up to small noise, on seats of sd 2: the difference's
    interval is narrow and excludes 0, the method's own is wide; a one-run reference pairs with every run."""
    rng = np.random.default_rng(6)
    reference = crossed(rng, 1, 60, 0.0)
    method = np.repeat(reference, 3, axis=0) + 0.5 + rng.normal(0.0, 0.2, (3, 60))
    difference = hierarchical_interval(runs(method), runs(np.repeat(reference, 3, axis=0)), seed=0)
    own = hierarchical_interval(runs(method), seed=0)
    assert difference.excludes_zero and difference.low < 0.5 < difference.high
    assert difference.high - difference.low < 0.25 * (own.high - own.low)
    with pytest.raises(ValueError, match="same numbers of runs and episodes"):
        hierarchical_interval(runs(method), runs(reference), seed=0)


def test_the_seat_tables_take_it_as_an_option():
    """Three BC runs 3 m worse than IDM in every seat (the seeds +-0.1 m apart): with `hierarchical` the difference
    row holds the hierarchical interval, narrower than the t factor on three seeds."""
    errors = np.random.default_rng(7).uniform(10.0, 60.0, 16)
    runs_ = [seat_rows(errors + 3.0 + offset, f"bc_s{k}") for k, offset in enumerate((-0.1, 0.0, 0.1))]
    metrics = pd.concat([seat_rows(errors, "idm"), *runs_], ignore_index=True)
    methods = {"BC": [f"bc_s{k}" for k in range(3)], "IDM": ["idm"]}
    expected = hierarchical_interval([mean_sample(run["position_error_10s_m"].to_numpy()) for run in runs_],
                                     [mean_sample(errors)] * 3)

    def cell(table: str) -> str:
        row = next(line for line in table.splitlines() if line.startswith("| BC - IDM"))
        return row.split(" | ")[4]

    hierarchical = cell(track_table(metrics, methods, [("BC", "IDM")], hierarchical=True))
    assert hierarchical == expected.format(2, signed=True) + " *"
    assert hierarchical != cell(track_table(metrics, methods, [("BC", "IDM")]))  # the default: the t factor
