"""Seeded ARS search directions (processes exchange the integers (noise seed, iteration, index), never vectors),
and the perturbation scale that changes a chosen share of a policy's decisions.

Direction `index` of `iteration` is drawn by a numpy Generator (PCG64) seeded with
`SeedSequence(noise_seed, spawn_key=(iteration, index))`, so it is a pure function of its integers: the same in
every process and run with the same numpy version, and independent of every other direction.
"""

from __future__ import annotations

import numpy as np

from sumo_rail.drivers.policies import Policy


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


def flip_rate(policy: Policy, deltas: np.ndarray, nu: float, states: np.ndarray) -> float:
    """The share of `states` (B, n) at which theta +- nu delta_k chooses another action than theta, over every
    direction k of `deltas` (N, P) and both signs: how much a perturbation of scale nu changes the decisions."""
    chosen = np.argmax(policy.logits(states), axis=1)
    changed = 0
    for delta in np.asarray(deltas, dtype=np.float32):
        for sign in (1, -1):
            perturbed = Policy(policy.shape, policy.parameters + np.float32(sign * nu) * delta,
                               policy.observation_mean, policy.observation_std)
            changed += int(np.count_nonzero(np.argmax(perturbed.logits(states), axis=1) != chosen))
    return changed / (2 * len(deltas) * len(states))


NOISE_RANGE = (1e-4, 10.0)
"""The perturbation scales `noise_for_flip_rate` searches (parameter units)."""


def noise_for_flip_rate(policy: Policy, deltas: np.ndarray, target: float, states: np.ndarray,
                        bisections: int = 30) -> float:
    """The perturbation scale nu at which `flip_rate` is `target` (0 < target < 1), found by bisection on log nu
    within NOISE_RANGE (the rate grows with nu); the range's end nearest the target where it cannot be reached
    (at all-zero weights, whose ties go to the lowest action, most perturbations change the decision at any nu: a
    linear policy's logits only scale with nu)."""
    if not 0.0 < target < 1.0:
        raise ValueError(f"the target share of changed decisions must be between 0 and 1, got {target}")
    low, high = np.log(NOISE_RANGE[0]), np.log(NOISE_RANGE[1])
    for _ in range(bisections):
        middle = 0.5 * (low + high)
        if flip_rate(policy, deltas, float(np.exp(middle)), states) < target:
            low = middle
        else:
            high = middle
    return float(np.exp(0.5 * (low + high)))
