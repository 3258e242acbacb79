"""GAIL's environment processes: how each is built, how one that fails reports why without a traceback, and what
the parent says and does when one is lost (killed, crashed) instead of Stable-Baselines3's EOFError."""

from __future__ import annotations

import os
import signal
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import gymnasium as gym
from gymnasium.utils import seeding

from sumo_rail.config import Config
from sumo_rail.datasets import describe
from sumo_rail.sim.env import HighwayEnv

if TYPE_CHECKING:
    from stable_baselines3.common.vec_env import VecEnv


@dataclass(frozen=True)
class EnvFactory:
    """Builds one env in its worker process; its first episode is that of reset(seed=seed). With `error_file`, an
    exception in the env ends the process quietly after writing its one-line description there (no traceback on the
    terminal; the parent reports it)."""

    config: Config
    seed: int
    error_file: str | None = None

    def __call__(self) -> gym.Env:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group; the parent decides
        try:
            env = HighwayEnv(self.config, transport="libsumo")
        except Exception as error:
            exit_reporting(self.error_file, error)
        env.np_random, _ = seeding.np_random(self.seed)
        return env if self.error_file is None else _ReportingEnv(env, self.error_file)


class _ReportingEnv(gym.Wrapper):
    """Passes everything through; an exception in reset or step ends the process via `exit_reporting`."""

    def __init__(self, env: gym.Env, error_file: str) -> None:
        super().__init__(env)
        self._error_file = error_file

    def reset(self, **kwargs: Any) -> Any:
        try:
            return self.env.reset(**kwargs)
        except Exception as error:
            exit_reporting(self._error_file, error)

    def step(self, action: Any) -> Any:
        try:
            return self.env.step(action)
        except Exception as error:
            exit_reporting(self._error_file, error)


def exit_reporting(error_file: str | None, error: Exception) -> NoReturn:
    """Write `error` in one line to `error_file` and end the process (re-raise without a file)."""
    if error_file is None:
        raise error
    Path(error_file).write_text(f"{describe(error)}\n")
    os._exit(1)


LOST_ENV = (EOFError, BrokenPipeError, ConnectionResetError)
"""What Stable-Baselines3's SubprocVecEnv raises when an environment process is gone."""


def lost_env_message(venv: VecEnv | None, error_dir: Path, folder: Path, updates: int, run: str = "GAIL") -> str:
    """One sentence: which environment process ended and how, and what the run folder (of a `run` run) holds."""
    processes = list(getattr(venv.unwrapped, "processes", [])) if venv is not None else []
    deadline = time.monotonic() + 2.0
    while processes and all(process.exitcode is None for process in processes) and time.monotonic() < deadline:
        time.sleep(0.05)
    reports = {int(path.stem.removeprefix("env_")): path.read_text().strip() for path in error_dir.glob("env_*.txt")}
    causes = []
    for index in sorted(set(reports) | set(range(len(processes)))):
        code = processes[index].exitcode if index < len(processes) else None
        if index in reports:
            causes.append(f"environment process {index} failed: {reports[index]}")
        elif code is not None and code < 0:
            causes.append(f"environment process {index} was killed by signal {-code}")
        elif code is not None:
            causes.append(f"environment process {index} exited with code {code}")
    cause = causes[0] if causes else "an environment process was lost"
    kept = (f"{folder} keeps update {updates}, the last complete one: continue with --resume" if updates
            else f"{folder} holds no complete update yet")
    return f"{run} stopped during update {updates + 1}: {cause}; {kept}"


def close_envs(venv: VecEnv, lost: bool) -> None:
    """Close the envs. After a lost env SubprocVecEnv's own close would wait forever for answers that never come,
    so the remaining env processes are stopped instead."""
    if not lost:
        venv.close()
        return
    inner = venv.unwrapped
    for process in getattr(inner, "processes", []):
        if process.is_alive():
            process.terminate()
        process.join(5)
        if process.is_alive():
            process.kill()
            process.join()
    for remote in getattr(inner, "remotes", []):
        remote.close()
    inner.closed = True
