"""GAIL's driving env in a recorded scene's seats (`gail.in_seats`): one ego per env process, each episode in a
train-split seat of the scene its demonstrations were read from (`recorded-demos`), the others replayed as recorded.

`SeatRoad` answers the env process's "reset" and "step" as `shared_road.RespawningRoad` does with one ego: an episode
that ends returns done, its last observation as info["terminal_observation"] and info["TimeLimit.truncated"], and the
next seat's first observation. Its seats are those `evaluate-scene --split train --lead-s --zone-m` would choose
(`recordings.seats.SeatDraw`), each drawn by the env's generator (first reset seeded by the process's seed), so the
same seed and process count give the same rollouts.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sumo_rail.config import Config
from sumo_rail.learning.train_seats import SeatNames, TrainSeats
from sumo_rail.recordings.seat import SceneEnv

GAIL_SEATS = SeatNames("gail.in_seats drives PPO's episodes in the train-split seats of", "gail.seat_lead_s",
                       "env.max_episode_s", "gail.seat_zone_m")
"""The settings a refusal of GAIL in seats names."""


@dataclass(frozen=True)
class SceneSeats:
    """Where a learner's episodes run: the train-split seats of the scene `folder`, `lead_s` [s] into each track,
    `zone_m` [m] from the road's ends."""

    folder: str
    lead_s: float
    zone_m: float

    @classmethod
    def of_demonstrations(cls, metadata: Mapping[str, Any], demos: str | Path, config: Config, lead_s: float,
                          zone_m: float) -> SceneSeats:
        """The seats of the scene the demonstrations `demos` (their `metadata`) were read from
        (`train_seats.TrainSeats`); a ValueError, one sentence, when they were not read from a scene, it cannot be
        read, changed since, or has no seat of env.max_episode_s."""
        seats = TrainSeats.of(metadata, demos, config, lead_s, config.env.max_episode_s, zone_m, GAIL_SEATS)
        return cls(str(seats.scene.folder), lead_s, zone_m)


class SeatRoad:
    """One ego driving seat after seat of a scene (see the module's docstring)."""

    def __init__(self, config: Config, seats: SceneSeats, seed: int) -> None:
        self.env = SceneEnv(config, Path(seats.folder), False, transport="libsumo", split="train",
                            lead_s=seats.lead_s, zone_m=seats.zone_m, horizon_s=config.env.max_episode_s)
        self.seed: int | None = seed

    def reset(self) -> np.ndarray:
        """The first seat's first observation, shape (1, n) (the first reset seeded by the process's seed)."""
        observation, _ = self.env.reset(seed=self.seed)
        self.seed = None
        return observation[None]

    def step(self, actions: Sequence[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        """One decision; an ended episode moves the ego to the next seat drawn."""
        observation, reward, terminated, truncated, info = self.env.step(int(actions[0]))
        done = terminated or truncated
        if done:
            info = {**info, "TimeLimit.truncated": truncated and not terminated, "terminal_observation": observation}
            observation, _ = self.env.reset()
        return observation[None], np.array([reward], dtype=np.float64), np.array([done]), [info]

    def close(self) -> None:
        self.env.close()
