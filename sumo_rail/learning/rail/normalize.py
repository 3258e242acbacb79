"""Running observation statistics for ARS-V2 state normalisation (RAIL, Algorithm 1, lines 6 and 19).

`RunningStats` is an immutable (count, mean, m2) triple: batches are summarised exactly with `of` and combined
with `merge` (Chan, Golub and LeVeque's parallel formula), so workers can send statistics instead of states.
Merging the same parts in the same order gives bit-identical results.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from sumo_rail.drivers.policies import MIN_STD


@dataclass(frozen=True, eq=False)
class RunningStats:
    """Statistics of `count` observations of size n; the arrays are float64 read-only copies."""

    count: int
    mean: np.ndarray
    """Mean, shape (n,)."""
    m2: np.ndarray
    """Sum of squared deviations from the mean, shape (n,)."""

    def __post_init__(self) -> None:
        mean, m2 = np.array(self.mean, dtype=np.float64), np.array(self.m2, dtype=np.float64)
        if mean.ndim != 1 or m2.shape != mean.shape:
            raise ValueError(f"mean and m2 must have the same shape (n,), got {mean.shape} and {m2.shape}")
        if int(self.count) < 0:
            raise ValueError(f"count must not be negative, got {self.count}")
        mean.setflags(write=False)
        m2.setflags(write=False)
        object.__setattr__(self, "count", int(self.count))
        object.__setattr__(self, "mean", mean)
        object.__setattr__(self, "m2", m2)

    @classmethod
    def empty(cls, size: int) -> RunningStats:
        """Statistics of no observations of size `size`."""
        return cls(0, np.zeros(size), np.zeros(size))

    @classmethod
    def of(cls, observations: np.ndarray) -> RunningStats:
        """Exact (two-pass) statistics of a batch of shape (B, n)."""
        values = np.asarray(observations, dtype=np.float64)
        if values.ndim != 2:
            raise ValueError(f"observations must have shape (B, n), got {values.shape}")
        if values.shape[0] == 0:
            return cls.empty(values.shape[1])
        mean = values.mean(axis=0)
        return cls(values.shape[0], mean, np.square(values - mean).sum(axis=0))

    @property
    def size(self) -> int:
        """Observation size n."""
        return self.mean.shape[0]

    def merge(self, other: RunningStats) -> RunningStats:
        """Statistics of the union of both sets of observations (neither operand changes)."""
        if other.size != self.size:
            raise ValueError(f"cannot merge statistics of sizes {self.size} and {other.size}")
        if other.count == 0:
            return self
        if self.count == 0:
            return other
        count = self.count + other.count
        delta = other.mean - self.mean
        mean = self.mean + delta * (other.count / count)
        m2 = self.m2 + other.m2 + np.square(delta) * (self.count * other.count / count)
        return RunningStats(count, mean, m2)

    @property
    def std(self) -> np.ndarray:
        """Population standard deviation, shape (n,); 1.0 where count < 2 or the deviation is below MIN_STD."""
        if self.count < 2:
            return np.ones(self.size)
        std = np.sqrt(self.m2 / self.count)
        return np.where(std < MIN_STD, 1.0, std)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Arrays for a checkpoint: `count` (int64, 0-d), `mean` and `m2` (float64, (n,))."""
        return {"count": np.array(self.count, dtype=np.int64), "mean": self.mean.copy(), "m2": self.m2.copy()}

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> RunningStats:
        """The inverse of `to_arrays`."""
        try:
            count, mean, m2 = np.asarray(arrays["count"]), arrays["mean"], arrays["m2"]
        except KeyError as error:
            raise ValueError(f"running statistics arrays lack {error}") from error
        if count.shape != () or not np.issubdtype(count.dtype, np.integer):
            raise ValueError(f"count must be a 0-d integer array, got shape {count.shape} and dtype {count.dtype}")
        return cls(int(count), mean, m2)
