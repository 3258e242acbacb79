"""The floor of the distribution distances: humans half against half, and a driver's multiple of it."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from sumo_rail.evaluation.human_floor import FLOOR_DISTRIBUTIONS, floor_distances, floor_table
from sumo_rail.evaluation.scene_evaluation import HUMAN

PERIOD_S = 0.5


def _tracks(seats: int, seed: int = 3) -> pd.DataFrame:
    """Humans of `seats` seats (each its own speed level and gap), 20 decisions each, one mode."""
    rng = np.random.default_rng(seed)
    frames = []
    for seat in range(seats):
        speed = 25 + 3 * rng.standard_normal() + np.cumsum(rng.normal(0, 0.3, 20))
        frames.append(pd.DataFrame({"time_s": np.arange(20) * PERIOD_S, "speed_mps": speed, "lane": 1,
                                    "gap_m": 30 + 5 * rng.standard_normal(20), "policy": HUMAN,
                                    "mode": "non-reactive", "scene": "s", "vehicle": f"v{seat}", "start_s": 10.0}))
    return pd.concat(frames, ignore_index=True)


def _as_driver(humans: pd.DataFrame, name: str, speed_shift_mps: float = 0.0) -> pd.DataFrame:
    driver = humans.assign(policy=name)
    driver["speed_mps"] += speed_shift_mps
    return driver


def test_a_driver_that_drives_as_its_human_is_at_the_floor_and_a_faster_one_above_it() -> None:
    humans = _tracks(30)
    tracks = pd.concat([humans, _as_driver(humans, "copy"), _as_driver(humans, "faster", 5.0)])
    distances = floor_distances(tracks, {"copy": ["copy"], "faster": ["faster"]}, PERIOD_S, "non-reactive",
                                splits=20)
    for name in FLOOR_DISTRIBUTIONS.values():
        assert np.all(distances[name][HUMAN] > 0)
        np.testing.assert_allclose(distances[name]["copy"], distances[name][HUMAN])
    assert np.mean(distances["speed"]["faster"]) > np.mean(distances["speed"][HUMAN]) + 3.0
    np.testing.assert_allclose(distances["acceleration"]["faster"], distances["acceleration"][HUMAN])


def test_a_method_of_several_runs_is_their_mean_distance_and_the_splits_are_seeded() -> None:
    humans = _tracks(12)
    tracks = pd.concat([humans, _as_driver(humans, "a"), _as_driver(humans, "b", 2.0)])
    pooled = floor_distances(tracks, {"ab": ["a", "b"], "b": ["b"]}, PERIOD_S, "non-reactive", splits=10, seed=4)
    again = floor_distances(tracks, {"ab": ["a", "b"], "b": ["b"]}, PERIOD_S, "non-reactive", splits=10, seed=4)
    np.testing.assert_allclose(pooled["speed"]["ab"], (pooled["speed"][HUMAN] + pooled["speed"]["b"]) / 2)
    np.testing.assert_array_equal(pooled["speed"]["ab"], again["speed"]["ab"])


def test_the_table_states_the_floor_and_each_multiple() -> None:
    humans = _tracks(20)
    table = floor_table(pd.concat([humans, _as_driver(humans, "copy")]), {"copy": ["copy"]}, PERIOD_S, splits=10)
    copy_row = next(line for line in table.splitlines() if line.startswith("| copy |"))
    assert copy_row.count("= 1.00x [1.00, 1.00]") == len(FLOOR_DISTRIBUTIONS)


def test_one_seat_of_humans_is_refused() -> None:
    with pytest.raises(ValueError, match="at least 2 seats"):
        floor_distances(_tracks(1), {}, PERIOD_S, "non-reactive")
