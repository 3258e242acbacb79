"""The driving envs of Stable-Baselines3's learners (`gail`, `ppo`, with `--egos K`), the roads behind
`driving_envs.driving_processes`.

SB3 steps every env of a VecEnv at once and restarts one as soon as its episode ends; in a shared simulation an ego
cannot restart alone by a reset, so the egos of a `RespawningRoad` respawn instead
(`sumo_rail.sim.respawning.RespawningEgos`): an ego that ends is replaced at once by a new one in the start window
while the others drive on, and when no ego is left on the road (always, with one ego) the road itself resets,
drawing its next start from its `np_random` as a single-ego env's reset does. When the egos jam the road's start so
that one finds no place to respawn (learners stopped on a one-lane ramp), every ego's episode is cut there (a
truncation) and the road resets. Each env index always has an ego driving, and the step that ends an ego's episode
returns what SB3's own auto-resetting `SubprocVecEnv` returns: done, the episode's last observation as
info["terminal_observation"], info["TimeLimit.truncated"] for a truncation (end of road, time limit), and the new
episode's first observation; rewards are float64 as SubprocVecEnv stacks them. With K = 1 this is bit for bit what
SubprocVecEnv gives for a `HighwayEnv` whose first reset is seeded.

Env index i is ego i % K of process i // K. Process p's road is first reset with the seed of `env_seeds(seed,
processes)[p]`, and every respawn and later reset draws from that road's `np_random`, so the same seed, K and
process count give the same rollouts bit for bit. A process that fails writes why to error_dir/env_P.txt and ends
(`envs.exit_reporting`); the parent then reports the lost process in one sentence (`runs.env_processes`).
"""

from __future__ import annotations

from collections.abc import Sequence
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from sumo_rail.config import Config
from sumo_rail.learning.sb3.envs import LOST_ENV, exit_reporting
from sumo_rail.learning.sb3.seat_road import SceneSeats, SeatRoad
from sumo_rail.runners.spawning import die_with_parent, ignore_stop_signals
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.parallel_env import ParallelHighwayEnv
from sumo_rail.sim.respawning import RespawningEgos

StepBatch = tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]
"""(observations (K, n), rewards (K,), dones (K,), infos) of one step of the K egos, SB3's VecEnv layout."""


def env_seeds(seed: int, envs: int) -> list[int]:
    """Seeds of the envs' first episodes: disjoint for different seeds with the same number of envs."""
    return episode_seeds(Purpose.TRAIN, seed * envs, envs)


class RespawningRoad:
    """K egos on one road that never stop: each that ends respawns at once (see the module's docstring)."""

    def __init__(self, config: Config, egos: int, seed: int) -> None:
        self.env = ParallelHighwayEnv(egos, config, transport="libsumo")
        self.egos = RespawningEgos(self.env, seed, reset_when_empty=True)

    def reset(self) -> np.ndarray:
        """Reset the road (the first time with the road's seed); an ego that could not enter respawns. Returns the
        egos' first observations (K, n)."""
        observations, _ = self.egos.start()
        return np.stack([observations[agent] for agent in self.env.possible_agents])

    def step(self, actions: Sequence[int]) -> StepBatch:
        """One decision of every ego (`actions` in agent order); an ego whose episode ended respawns, or the road
        resets when none is left on it."""
        agents = self.env.possible_agents
        step = self.egos.step(dict(zip(agents, actions, strict=True)))
        for agent in step.ended:
            step.infos[agent]["TimeLimit.truncated"] = step.truncated(agent) and not step.terminations[agent]
            step.infos[agent]["terminal_observation"] = step.observations[agent]
        return (np.stack([step.next_observations[agent] for agent in agents]),
                np.array([step.rewards[agent] for agent in agents]),
                np.array([agent in step.ended for agent in agents]), [step.infos[agent] for agent in agents])

    def close(self) -> None:
        self.env.close()


def _road_process(remote: Connection, parent_remote: Connection, config: Config, egos: int, seed: int,
                  error_file: str, seats: SceneSeats | None = None) -> None:
    """A worker process: one `RespawningRoad` (with `seats`: a `seat_road.SeatRoad`) answering "reset", "step" and
    "close" over `remote`."""
    ignore_stop_signals()  # Ctrl-C and a SIGTERM reach the whole process group: the parent decides
    die_with_parent()
    parent_remote.close()
    try:
        road: RespawningRoad | SeatRoad = (RespawningRoad(config, egos, seed) if seats is None
                                           else SeatRoad(config, seats, seed))
        while True:
            command, data = remote.recv()
            if command == "reset":
                remote.send(road.reset())
            elif command == "step":
                remote.send(road.step(data))
            else:
                road.close()
                remote.close()
                return
    except LOST_ENV:  # the parent is gone
        return
    except Exception as error:
        exit_reporting(error_file, error)

