"""The driving envs of an SB3 learner (GAIL, PPO): spawned SUMO processes of respawning egos as one VecEnv.

Stable-Baselines3 is imported when the envs are built, not when a learner's module is imported.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from sumo_rail.config import Config

if TYPE_CHECKING:
    from stable_baselines3.common.vec_env import VecEnv

    from sumo_rail.learning.sb3.seat_road import SceneSeats


def driving_processes(config: Config, processes: int, egos: int, seed: int, error_dir: Path,
                      seats: SceneSeats | None = None) -> VecEnv:
    """`processes` spawned SUMO processes with `egos` respawning egos each (`shared_road.RespawningRoad`), or with
    `seats` one ego each driving a recorded scene's seats (`seat_road.SeatRoad`), as one VecEnv. A process that fails
    writes why to error_dir/env_P.txt and ends."""
    from sumo_rail.learning.sb3.vec_envs import SharedRoadVecEnv

    return SharedRoadVecEnv(config, processes, egos, seed, error_dir, seats)
