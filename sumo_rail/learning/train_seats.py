"""The train-split seats of the recorded scene that demonstrations were read from (recorded-demos), where a learner
rolls out in that scene: DAgger against the log (`log_dagger`) and RAIL in seats (`rail.rollout_seats`,
`rail/seat_rollouts.py`); and the seats a round or an iteration draws from them.

A seat's episode is `recordings.seat.SceneEnv`'s: the ego in the seated car's place `lead_s` into its track (where
traffic is established with `zone_m`, `recordings.seats.choose_seats`), the other vehicles replayed as
recorded, for the seat's length (the config's env.max_episode_s).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError
from sumo_rail.recordings.scene import Scene, check_scene, read_scene, scene_sources
from sumo_rail.recordings.seat import SceneEnv
from sumo_rail.recordings.seats import Seat, choose_seats
from sumo_rail.runners.backends import WorkerContext
from sumo_rail.runners.experts import RECORDED_SCENE


class SceneSeatsError(ValueError):
    """A learner cannot roll out in the seats of the scene its demonstrations were read from."""


@dataclass(frozen=True)
class SeatNames:
    """The settings a refusal names: who asks for seats, their lead, length and zone."""

    asker: str
    lead: str
    length: str
    zone: str


def demos_scene(metadata: Mapping[str, Any], demos: str | Path, asker: str) -> Path:
    """The folder of the scene the demonstrations `demos` (their `metadata`) were read from; a SceneSeatsError naming
    `asker` (what needs the scene) when they were not read from one."""
    record = metadata.get(RECORDED_SCENE)
    if not isinstance(record, Mapping):
        raise SceneSeatsError(f"{asker} the scene demonstrations were read from (recorded-demos), and {demos} were "
                              f"not read from a recorded scene")
    return Path(str(record.get("folder")))


@dataclass(frozen=True)
class TrainSeats:
    """The train-split seats of a scene, in id order, and the configuration their episodes run with."""

    config: Config
    """The run's configuration with the seat's length as env.max_episode_s."""
    scene: Scene
    seats: tuple[Seat, ...]

    @classmethod
    def of(cls, metadata: Mapping[str, Any], demos: str | Path, config: Config, lead_s: float, seat_s: float,
           zone_m: float, names: SeatNames) -> TrainSeats:
        """The train-split seats (`lead_s` into each track, `seat_s` long, `zone_m` from the road's ends [s, s, m])
        of the scene the demonstrations `demos` (their `metadata`) were read from; a SceneSeatsError (one sentence,
        naming the settings `names`) when they are not a scene's, the scene cannot be read, changed since or has no
        seat that long."""
        folder = demos_scene(metadata, demos, names.asker)
        try:
            scene = read_scene(folder)
        except DatasetError as error:
            raise SceneSeatsError(f"the scene {demos} were read from cannot be read: {error}") from error
        if scene_sources(scene) != metadata[RECORDED_SCENE].get("files"):
            raise SceneSeatsError(f"the scene {folder} has changed since {demos} were read from it (its files' "
                                  f"sha256 differ): read the demonstrations again")
        config = config.with_overrides({"env": {"max_episode_s": seat_s}})
        check_scene(scene, config, "train")
        chosen = choose_seats(scene, "train", seat_s, lead_s, None, 0, zone_m=zone_m,
                              earliest_s=config.scenario.step_length_s)
        if not chosen:
            zone = f" with {names.zone} = {zone_m:g} m" if zone_m > 0 else ""
            raise SceneSeatsError(f"no train-split car of the scene {folder} has a track of {names.lead} + "
                                  f"{names.length} = {lead_s + seat_s:g} s{zone}")
        return cls(config, scene, tuple(chosen))

    def draw(self, count: int, key: Sequence[int]) -> list[tuple[int, int]]:
        """`count` seats drawn by `key` (the run's seed and the round or iteration), without replacement while there
        are enough: (the seat's index in `seats`, its episode's seed) each."""
        rng = np.random.default_rng(list(key))
        chosen = rng.choice(len(self.seats), count, replace=count > len(self.seats))
        seeds = rng.integers(2**31 - 1, size=count)
        return [(int(index), int(seed)) for index, seed in zip(chosen, seeds, strict=True)]


def seat_env(context: WorkerContext, config: Config, seat: Seat) -> SceneEnv:
    """The worker's env of `seat`'s scene (non-reactive: the others replayed as recorded), kept for later seats of the
    same scene and configuration."""
    env = context.custom_env(("scene", config, seat.scene, False),
                             lambda: SceneEnv(config, Path(seat.scene), False, transport="libsumo",
                                              horizon_s=config.env.max_episode_s))
    assert isinstance(env, SceneEnv)
    return env
