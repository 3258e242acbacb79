"""Episode seeds: one integer per episode, from a base seed, in disjoint classes per purpose.

Episode k of a job with base seed s gets reset seed 3 * (s + k) + purpose, so recording (purpose 0),
evaluation (1) and training (2) never share an episode, whatever base seeds and episode counts are used.
"""

from __future__ import annotations

from enum import IntEnum

EVALUATION_EPISODES = 250
"""Default number of evaluation episodes per driver: enough for the expert's mean overtakes to have a 95% interval
within +-10% of itself (docs/results.md, "How many evaluation episodes")."""


class Purpose(IntEnum):
    RECORD = 0
    EVALUATE = 1
    TRAIN = 2


def episode_seeds(purpose: Purpose, base_seed: int, episodes: int) -> list[int]:
    """Reset seeds of `episodes` episodes starting at `base_seed` (>= 0)."""
    if base_seed < 0:
        raise ValueError(f"seeds must not be negative, got {base_seed}")
    return [len(Purpose) * (base_seed + k) + int(purpose) for k in range(episodes)]
