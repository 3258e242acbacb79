"""The floor of the distribution distances: how far one half of the held-out humans is from the other half, and
every driver's distance as a multiple of it.

A driver's Wasserstein-1 distance to the humans is never 0, even for a perfect imitator: two finite samples of the
same drivers differ. The floor measures that: the seats (one human each) are split at random into halves A and B,
and the floor is the distance between the humans of A and the humans of B. A driver is compared the same way, its
episodes in the seats of A against the humans of B, so both distances compare samples of the same size from
different seats; the driver's multiple is its distance over the floor (1 = as close to the humans as other humans
are). Each number is the mean over `splits` random half splits (seeded); the bracket holds the middle 95% of the
split-to-split multiples, how much the answer depends on which seats fall in which half (not a confidence interval
over new seats).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from sumo_rail.evaluation.human_likeness import wasserstein
from sumo_rail.evaluation.scene_evaluation import HUMAN
from sumo_rail.evaluation.scene_summary import DISTRIBUTIONS, SEAT_KEYS, distribution_samples

FLOOR_DISTRIBUTIONS = {heading: name for heading, name in DISTRIBUTIONS.items() if name != "lane_change_gap"}
"""The distributions the floor is measured on: speed, acceleration and gap to the leader."""
SPLITS = 200
"""Random half splits of the seats a floor averages."""


def _halves_distance(episodes: Mapping[tuple, dict[str, np.ndarray]], humans: Mapping[tuple, dict[str, np.ndarray]],
                     half_a: Sequence[tuple], half_b: Sequence[tuple], name: str) -> float:
    """The distance between the `name` samples of `episodes` in the seats `half_a` and the humans' in `half_b`."""
    ours = [episodes[seat][name] for seat in half_a if seat in episodes]
    theirs = [humans[seat][name] for seat in half_b]
    if not ours or not theirs:
        return np.nan
    return wasserstein(np.concatenate(ours), np.concatenate(theirs))


def floor_distances(tracks: pd.DataFrame, methods: Mapping[str, Sequence[str]], period_s: float, mode: str,
                    splits: int = SPLITS, seed: int = 0) -> dict[str, dict[str, np.ndarray]]:
    """For each distribution (FLOOR_DISTRIBUTIONS' names), the distances of each random half split in `mode`: key
    HUMAN the floor (humans of A to humans of B), each method its training runs' mean distance (each run's episodes in
    A to the humans of B). Arrays of length `splits`; at least 2 seats of humans needed."""
    in_mode = tracks[tracks["mode"] == mode]
    by_driver: dict[str, dict[tuple, dict[str, np.ndarray]]] = {}
    for key, group in in_mode.groupby(["policy", *SEAT_KEYS], sort=True):
        by_driver.setdefault(str(key[0]), {})[tuple(key[1:])] = distribution_samples(group, period_s)
    humans = by_driver.get(HUMAN, {})
    seats = sorted(humans)
    if len(seats) < 2:
        raise ValueError(f"the floor needs the humans of at least 2 seats in mode {mode!r}, found {len(seats)}")
    rng = np.random.default_rng(seed)
    half = len(seats) // 2
    result = {name: {driver: np.empty(splits) for driver in (HUMAN, *methods)}
              for name in FLOOR_DISTRIBUTIONS.values()}
    for split in range(splits):
        order = rng.permutation(len(seats))
        half_a, half_b = [seats[k] for k in order[:half]], [seats[k] for k in order[half:2 * half]]
        for name, distances in result.items():
            distances[HUMAN][split] = _halves_distance(humans, humans, half_a, half_b, name)
            for method, runs in methods.items():
                distances[method][split] = np.nanmean(
                    [_halves_distance(by_driver.get(run, {}), humans, half_a, half_b, name) for run in runs])
    return result


def floor_table(tracks: pd.DataFrame, methods: Mapping[str, Sequence[str]], period_s: float,
                splits: int = SPLITS, seed: int = 0) -> str:
    """Markdown: per mode, the humans' floor of each distribution, then every method's distance and its multiple of
    the floor with the middle 95% of the split-to-split multiples."""
    headings = list(FLOOR_DISTRIBUTIONS)
    lines = ["| driver | mode | " + " | ".join(headings) + " |", "|---|---|" + "---|" * len(headings)]
    for mode in sorted(tracks["mode"].unique()):
        distances = floor_distances(tracks, methods, period_s, mode, splits, seed)
        floors = [distances[name][HUMAN] for name in FLOOR_DISTRIBUTIONS.values()]
        lines.append(f"| humans, half vs half (the floor) | {mode} | "
                     + " | ".join(f"{np.nanmean(floor):.3f}" for floor in floors) + " |")
        for method in methods:
            cells = []
            for name, floor in zip(FLOOR_DISTRIBUTIONS.values(), floors, strict=True):
                ours = distances[name][method]
                multiples = ours / floor
                low, high = np.nanpercentile(multiples, [2.5, 97.5])
                cells.append(f"{np.nanmean(ours):.3f} = {np.nanmean(ours) / np.nanmean(floor):.2f}x "
                             f"[{low:.2f}, {high:.2f}]")
            lines.append(f"| {method} | {mode} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
