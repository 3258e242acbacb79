"""The Stable-Baselines3 vector environments GAIL and the PPO driver drive on: the shared-road VecEnv of respawning egos
(`shared_road`) and the wrapper that normalises its observations and gives PPO its rewards (`rewards.labelled_vec_env`,
`ppo.driving_vec_env`). This module imports Stable-Baselines3, so only the functions that build these import it."""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs

from sumo_rail.config import Config
from sumo_rail.learning.sb3.actor import FixedNormalisation
from sumo_rail.learning.sb3.envs import LOST_ENV
from sumo_rail.learning.sb3.seat_road import SceneSeats
from sumo_rail.learning.sb3.shared_road import _road_process, env_seeds
from sumo_rail.runners.spawning import start_shielded
from sumo_rail.sim.actions import action_space_of
from sumo_rail.sim.observation import observation_space

Rewards = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]], np.ndarray]
"""PPO's rewards from (the raw observations the actions were taken on, the actions, the env's rewards, dones, infos)."""


class SharedRoadVecEnv(VecEnv):
    """`driving_envs.driving_processes`: env i is ego i % egos of process i // egos; `processes` are the worker
    processes (for lost-env reports)."""

    def __init__(self, config: Config, processes: int, egos: int, seed: int, error_dir: Path,
                 seats: SceneSeats | None = None) -> None:
        super().__init__(processes * egos, observation_space(config), action_space_of(config.actions))
        self.egos = egos
        context = multiprocessing.get_context("spawn")
        self.remotes, self.processes = [], []
        for index, process_seed in enumerate(env_seeds(seed, processes)):
            remote, worker_remote = context.Pipe()
            process = context.Process(target=_road_process, daemon=True,
                                      args=(worker_remote, remote, config, egos, process_seed,
                                            str(error_dir / f"env_{index}.txt"), seats))
            start_shielded(process)  # a Ctrl-C while it imports must not kill it: the parent decides
            worker_remote.close()
            self.remotes.append(remote)
            self.processes.append(process)
        self._actions = np.zeros(self.num_envs, dtype=np.int64)
        self.closed = False

    def reset(self) -> np.ndarray:
        for remote in self.remotes:
            remote.send(("reset", None))
        return np.concatenate([remote.recv() for remote in self.remotes])

    def step_async(self, actions: np.ndarray) -> None:
        for index, remote in enumerate(self.remotes):
            remote.send(("step", [int(action) for action in actions[index * self.egos:(index + 1) * self.egos]]))

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        batches = [remote.recv() for remote in self.remotes]
        return (np.concatenate([batch[0] for batch in batches]), np.concatenate([batch[1] for batch in batches]),
                np.concatenate([batch[2] for batch in batches]), [info for batch in batches for info in batch[3]])

    def close(self) -> None:
        """Ask each process to close its road and wait for it; one that is gone, or does not end within 10 s,
        is terminated."""
        if self.closed:
            return
        for remote in self.remotes:
            try:
                remote.send(("close", None))
            except LOST_ENV:
                pass
        for process, remote in zip(self.processes, self.remotes, strict=True):
            process.join(10)
            if process.is_alive():
                process.kill()  # not terminate(): env processes ignore SIGTERM (`spawning.ignore_stop_signals`)
                process.join()
            remote.close()
        self.closed = True

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        if attr_name == "render_mode":  # SB3 asks; the egos do not render
            return [None for _ in self._get_indices(indices)]
        raise AttributeError(f"a shared-road VecEnv does not expose its envs' {attr_name!r}")

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        raise AttributeError(f"a shared-road VecEnv does not expose its envs' {attr_name!r}")

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any
                   ) -> list[Any]:
        raise AttributeError(f"a shared-road VecEnv does not expose its envs' {method_name!r}")

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False] * self.num_envs


class NormalisedVecEnv(VecEnvWrapper):
    """Observations through `normalisation` (terminal ones too) and PPO's rewards from `rewards` (`Rewards`), given
    the raw observations the actions were taken on; `seed` is a no-op: the env factories seed the envs."""

    def __init__(self, venv: VecEnv, normalisation: FixedNormalisation, rewards: Rewards) -> None:
        assert isinstance(venv.observation_space, spaces.Box)  # the egos' (SB3 types a VecEnv's as any space)
        shape = venv.observation_space.shape
        super().__init__(venv, observation_space=spaces.Box(-np.inf, np.inf, shape, np.float32))
        self.normalisation, self.rewards = normalisation, rewards
        self._raw: np.ndarray = np.zeros((venv.num_envs, *shape), dtype=np.float32)
        self._actions = np.zeros(venv.num_envs, dtype=np.int64)

    def seed(self, seed: int | None = None) -> list[int | None]:
        return [None] * self.num_envs

    def reset(self) -> np.ndarray:
        self._raw = _array(self.venv.reset())
        return self.normalisation(self._raw)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)
        self.venv.step_async(actions)

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        observations, env_rewards, dones, infos = self.venv.step_wait()
        raw = _array(observations)
        rewards = self.rewards(self._raw, self._actions, env_rewards, dones, infos)
        for info in infos:
            if "terminal_observation" in info:
                info["terminal_observation"] = self.normalisation(info["terminal_observation"])
        self._raw = raw
        return self.normalisation(raw), rewards, dones, infos


def _array(observations: VecEnvObs) -> np.ndarray:
    """The egos' observations, one array (SB3 types a VecEnv's as those of any space: dicts, tuples)."""
    assert isinstance(observations, np.ndarray)
    return observations
