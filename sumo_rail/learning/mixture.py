"""DAgger's mixture of a policy and a teacher (`dagger.py`: a queryable expert; `log_dagger.py`: the log): the states
a mixture visits, each labelled with the teacher's action there."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sumo_rail.drivers.policies import Policy
from sumo_rail.sim.traffic import TrafficView

Teacher = Callable[[np.ndarray, TrafficView], "int | None"]
"""Who labels a state: an action, or None where it has no label (the log past its track's end)."""


@dataclass(frozen=True)
class LabelledEpisode:
    observations: np.ndarray
    """Shape (T, n) float32: every state the mixture visited that the teacher labelled."""
    labels: np.ndarray
    """Shape (T,) int64: the teacher's action in each."""
    policy_decisions: int
    """Decisions the policy (not the teacher) made."""


class Mixture:
    """A driver that asks the teacher at every decision, keeps the state and the teacher's label, and follows the
    teacher with probability beta (a coin seeded by `seed`), else the policy (always the policy where the teacher
    has no label)."""

    def __init__(self, policy: Policy, teacher: Teacher, beta: float, seed: int) -> None:
        self.policy, self.teacher, self.beta = policy, teacher, beta
        self.coin = np.random.default_rng(seed)
        self.observations: list[np.ndarray] = []
        self.labels: list[int] = []
        self.policy_decisions = 0

    def __call__(self, observation: np.ndarray, traffic: TrafficView) -> int:
        label = self.teacher(observation, traffic)
        if label is not None:
            self.observations.append(observation)
            self.labels.append(int(label))
            if self.coin.random() < self.beta:
                return int(label)
        self.policy_decisions += 1
        return self.policy.act(observation)

    def episode(self) -> LabelledEpisode:
        observations = (np.stack(self.observations).astype(np.float32) if self.observations
                        else np.zeros((0, 0), np.float32))
        return LabelledEpisode(observations, np.array(self.labels, dtype=np.int64), self.policy_decisions)
