"""The project's ARS through experiments/ars_reference.py solves CartPole-v1; with the returns' sign flipped (the
update climbing down instead of up) it does not."""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from sumo_rail.learning.rail.ars import ArsStep, ars_update

sys.path.insert(0, str(Path(__file__).parent.parent / "experiments"))
import ars_reference

TASK = "CartPole-v1"
BUDGET = 20_000
"""Training steps [environment steps]; on seed 0 the threshold is reached after about 8,000."""


def curve(seed: int) -> list[tuple[int, float]]:
    """(environment steps, mean test return) of each evaluation of a BUDGET-step run on CartPole-v1."""
    found: list[tuple[int, float]] = []
    ars_reference.train_project(TASK, ars_reference.TASKS[TASK], seed, BUDGET,
                                lambda steps, value: found.append((steps, value)))
    return found


def flipped(parameters: np.ndarray, deltas: np.ndarray, returns_plus: np.ndarray, returns_minus: np.ndarray,
            top: int, step_size: float) -> ArsStep:
    """`ars_update` with r+ and r- exchanged: every step goes against the estimated gradient."""
    return ars_update(parameters, deltas, returns_minus, returns_plus, top, step_size)


def test_project_ars_solves_cartpole_and_is_seeded():
    found = curve(seed=0)
    threshold = ars_reference.TASKS[TASK].threshold
    assert threshold == 475.0 and found[0][0] == 0 and found[-1][0] >= BUDGET
    assert found[-1][1] >= threshold  # the mean over 10 test episodes at the end of the budget
    assert ars_reference.steps_to_threshold(pd.DataFrame(found, columns=["env_steps", "return"]), threshold) <= 12_000
    assert curve(seed=0) == found  # same seed, same curve


def test_a_wrong_update_does_not_learn(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(ars_reference, "ars_update", flipped)
    found = curve(seed=0)
    assert max(value for _, value in found) < 100
