"""DART (Laskey et al. 2017, "Disturbances for Augmenting Robot Trajectories"): record the expert while noise
perturbs what the car executes, so the demonstrations visit the states a learner's own errors lead to, each labelled
with the expert's own decision there; the expert is needed only while recording, not online as in DAgger.

The noise form: at each decision, with probability epsilon, the car executes a uniformly random action (any of the
five, the expert's own included) instead of the expert's. Why this form: the learners' errors are discrete (a wrong
set-point step that compounds, a lane change the expert would not make), and a random action is exactly one such
error, in the longitudinal and the lateral part alike, with one parameter to match to the learner's error rate. The
draws come from the episode's own noise stream (`seeding.noise_generator`), so a recording does not depend on the
number of workers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from sumo_rail.seeding import NOISE_STREAM, noise_generator
from sumo_rail.sim.actions import Action

NOISE_FORM = "random_action"


@dataclass(frozen=True)
class ActionNoise:
    """With probability `epsilon` a decision's executed action is a uniformly random one."""

    epsilon: float

    def __post_init__(self) -> None:
        if not 0.0 <= self.epsilon < 1.0:
            raise ValueError(f"the DART noise level must be in [0, 1), got {self.epsilon}")

    def perturbation(self, seed: int, actions: int = len(Action)) -> Callable[[int], int]:
        """The executed action for each decided one of `actions`, in the episode with reset seed `seed` (one uniform
        draw a decision, a second for the random action when it is taken)."""
        rng, epsilon = noise_generator(seed), self.epsilon

        def perturb(action: int) -> int:
            return int(rng.integers(actions)) if rng.random() < epsilon else action

        return perturb

    def provenance(self) -> dict[str, Any]:
        """What a recording's metadata says of its noise."""
        return {"method": "DART", "form": NOISE_FORM, "epsilon": self.epsilon, "noise_stream": NOISE_STREAM,
                "labels": "the expert's decision in the state the car is in; the executed action may differ"}
