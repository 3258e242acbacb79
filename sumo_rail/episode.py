"""Run one episode with a simple driver and summarise it as a row of metrics."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sumo_rail.actions import Action
from sumo_rail.env import HighwayEnv

Driver = Callable[[np.ndarray, np.random.Generator], int]

DRIVERS: dict[str, Driver] = {
    "keep": lambda observation, rng: int(Action.KEEP),
    "random": lambda observation, rng: int(rng.integers(len(Action))),
}


def run_episode(env: HighwayEnv, driver: Driver, seed: int) -> dict[str, float | int | str]:
    """Reset with `seed`, drive until the episode ends, and return its metrics."""
    observation, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    info: dict = {}
    done = False
    while not done:
        observation, _, terminated, truncated, info = env.step(driver(observation, rng))
        done = terminated or truncated
    m = env.metrics
    return {
        "seed": seed,
        "decisions": m.decisions,
        "simulated_s": m.simulated_s,
        "distance_m": m.distance_m,
        "average_speed_kmh": m.average_speed_mps * 3.6,
        "overtakes": m.overtakes,
        "lane_changes": m.lane_changes,
        "longitudinal_reward": m.longitudinal_reward,
        "lateral_reward": m.lateral_reward,
        "collisions": m.collisions,
        "hard_braking": m.hard_braking,
        "teleports": m.teleports,
        "invalid_actions": m.invalid_actions,
        "termination": info.get("termination", ""),
    }
