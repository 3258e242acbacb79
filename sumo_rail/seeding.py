"""Episode seeds: one integer per episode, from a base seed, in disjoint classes per purpose.

Episode k of a job with base seed s gets reset seed 3 * (s + k) + purpose, so recording (purpose 0),
evaluation (1) and training (2) never share an episode, whatever base seeds and episode counts are used.
A driver that draws random numbers in an episode (a sampled policy) uses `driver_generator(reset seed)`.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np

EVALUATION_EPISODES = 250
"""Default number of evaluation episodes per driver: enough for the expert's mean overtakes to have a 95% interval
within +-10% of itself (docs/results.md, "How many evaluation episodes")."""


DRIVER_STREAM = 1
"""Spawn key of a driver's generator: its stream differs from the env's, which is seeded with the reset seed itself
(gymnasium: SeedSequence(seed)), so the driver's draws and the traffic's are independent."""


NOISE_STREAM = 2
"""Spawn key of the generator of the noise injected into what the car executes (DART, `runners.dart`)."""


class Purpose(IntEnum):
    RECORD = 0
    EVALUATE = 1
    TRAIN = 2


def episode_seeds(purpose: Purpose, base_seed: int, episodes: int) -> list[int]:
    """Reset seeds of `episodes` episodes starting at `base_seed` (>= 0)."""
    if base_seed < 0:
        raise ValueError(f"seeds must not be negative, got {base_seed}")
    return [len(Purpose) * (base_seed + k) + int(purpose) for k in range(episodes)]


def driver_generator(seed: int) -> np.random.Generator:
    """The random generator of a driver in the episode with reset seed `seed` (the same whatever process runs it)."""
    return _stream(seed, DRIVER_STREAM)


def noise_generator(seed: int) -> np.random.Generator:
    """The generator of the noise injected into the executed actions of the episode with reset seed `seed`."""
    return _stream(seed, NOISE_STREAM)


def _stream(seed: int, stream: int) -> np.random.Generator:
    """A generator of the episode with reset seed `seed`, on a stream of its own (never the env's)."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(stream,)))
