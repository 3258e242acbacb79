"""GAIL's and PPO's environment processes (`shared_road`): how one that fails reports why without a traceback, and
what the parent says and does when one is lost (killed, crashed) instead of Stable-Baselines3's EOFError."""

from __future__ import annotations

import os
import time
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn, Protocol, runtime_checkable

from sumo_rail.datasets import describe

if TYPE_CHECKING:
    from stable_baselines3.common.vec_env import VecEnv


def exit_reporting(error_file: str | None, error: Exception) -> NoReturn:
    """Write `error` in one line to `error_file` and end the process (re-raise without a file)."""
    if error_file is None:
        raise error
    Path(error_file).write_text(f"{describe(error)}\n")
    os._exit(1)


LOST_ENV = (EOFError, BrokenPipeError, ConnectionResetError)
"""What Stable-Baselines3's SubprocVecEnv raises when an environment process is gone."""


@runtime_checkable
class _EnvProcesses(Protocol):
    """A VecEnv whose envs run in processes it talks to through pipes (`vec_envs.SharedRoadVecEnv`, SubprocVecEnv)."""

    processes: list[BaseProcess]
    remotes: list[Connection]
    closed: bool


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
    if not isinstance(inner, _EnvProcesses):
        return
    for process in inner.processes:
        if process.is_alive():
            process.kill()  # not terminate(): env processes ignore SIGTERM (`spawning.ignore_stop_signals`)
        process.join()
    for remote in inner.remotes:
        remote.close()
    inner.closed = True
