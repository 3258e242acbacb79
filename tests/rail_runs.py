"""Small RAIL run settings, shared by the trainer's tests and the Ray backend's (tests/learning/rail/test_trainer.py,
tests/runners/test_ray_backend.py)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from sumo_rail.learning.bc import BcSettings
from sumo_rail.learning.rail.discriminator import DiscriminatorSettings
from sumo_rail.learning.rail.iteration import RailSettings
from sumo_rail.learning.rail.trainer import RunSettings

RESPAWNING = {"egos": 3, "rollout_decisions": 150}
"""Rollouts of 150 decisions (two to three lives on the small road), three egos a road."""


def run_settings(demos_path: Path | str, kind: str = "mlp", remedies: bool = False,
                 respawning: bool = False) -> RunSettings:
    """Small settings; `remedies`: every option that issue 25 added away from its default; `respawning`: rollouts
    of a budget of decisions on respawning egos (`RESPAWNING`)."""
    rail = RailSettings(directions=3, top=2, step_size=0.01, seed=1, **(RESPAWNING if respawning else {}))
    discriminator = DiscriminatorSettings(seed=1, steps_per_iteration=2)
    if remedies:
        rail = dataclasses.replace(rail, fitness="rank", flip_rate=0.1, episodes_per_rollout=2, egos=2)
        discriminator = dataclasses.replace(discriminator, reward_form="contrast", balance=1.0, gradient_penalty=1.0,
                                            replay=2)
    return RunSettings(str(demos_path), kind, 4, rail, discriminator, BcSettings(epochs=3))
