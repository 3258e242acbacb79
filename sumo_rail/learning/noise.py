"""Seeded ARS search directions: processes exchange the integers (noise seed, iteration, index), never vectors.

Direction `index` of `iteration` is drawn by a numpy Generator (PCG64) seeded with
`SeedSequence(noise_seed, spawn_key=(iteration, index))`, so it is a pure function of its integers: the same in
every process and run with the same numpy version, and independent of every other direction.
"""

from __future__ import annotations

import numpy as np


def direction(noise_seed: int, iteration: int, index: int, size: int) -> np.ndarray:
    """Direction `index` of `iteration`: a float32 standard normal vector of shape (size,)."""
    if min(noise_seed, iteration, index, size) < 0:
        raise ValueError(f"noise seed, iteration, index and size must not be negative, "
                         f"got {noise_seed}, {iteration}, {index} and {size}")
    seed = np.random.SeedSequence(noise_seed, spawn_key=(iteration, index))
    return np.random.default_rng(seed).standard_normal(size, dtype=np.float32)


def directions(noise_seed: int, iteration: int, count: int, size: int) -> np.ndarray:
    """Directions 0 .. count - 1 of `iteration`, shape (count, size), float32; row k is `direction(..., k, size)`."""
    result = np.empty((count, size), dtype=np.float32)
    for index in range(count):
        result[index] = direction(noise_seed, iteration, index, size)
    return result
