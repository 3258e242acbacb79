"""Reliability of long runs: a save that fails on a full disk (ENOSPC from each writer in turn) keeps the previous
complete iteration, every file of it, and says so; a killed or failing GAIL or PPO environment process is one
sentence. (The process pool's and Ray's recovery from killed workers is tested in tests/runners/ and
tests/learning/rail/test_trainer.py.)"""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import torch
from click.testing import CliRunner
from reliability import assert_one_sentence, fingerprint, train_args
from sumo_rail_cli.main import cli
from test_cli import SMALL, SMALL_CONFIG

# ---------------------------------------------------------------------------------------------------------------------
# Full disk while an iteration is saved.

WRITERS = {
    "policy_latest.npz": (np, "savez", 0),  # the first file an iteration writes
    "log.parquet": (pq, "write_table", 1),
    "checkpoint.pt": (torch, "save", 1),  # the last (discriminator.pt is written as it is)
}
"""File -> (module, writer function, index of its destination argument): one per writer."""


@pytest.mark.parametrize("file", list(WRITERS))
def test_a_full_disk_during_a_save_keeps_the_previous_iteration(workspace: Path, monkeypatch: pytest.MonkeyPatch,
                                                                 file: str):
    module, name, where = WRITERS[file]
    original = getattr(module, name)

    def write_half_then_fail(*args: Any, **kwargs: Any) -> Any:
        destination = args[where]
        target = str(getattr(destination, "name", destination))
        if file not in Path(target).name:
            return original(*args, **kwargs)
        if hasattr(destination, "write"):
            destination.write(b"PK\x03\x04 half")
        else:
            Path(target).write_bytes(b"half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    run = workspace / "run"
    before = fingerprint(run)
    monkeypatch.setattr(module, name, write_half_then_fail)
    args = [*train_args(iterations=2)]
    result = CliRunner().invoke(cli, [*args, "--out", "run", "--resume"])
    message = assert_one_sentence(result, "run")
    assert os.strerror(errno.ENOSPC) in message and "iteration 1" in message and "--resume" in message
    assert fingerprint(run) == before  # the previous complete iteration, untouched; no temporary left behind
    if file == "checkpoint.pt":  # once there is room again, resume continues
        monkeypatch.setattr(module, name, original)
        result = CliRunner().invoke(cli, [*args, "--out", "run", "--resume"])
        assert result.exit_code == 0, result.output
        assert pd.read_parquet(run / "log.parquet")["iteration"].tolist() == [0, 1]


def test_a_full_disk_during_a_gail_update_keeps_the_previous_update(workspace: Path,
                                                                    monkeypatch: pytest.MonkeyPatch):
    from sumo_rail.learning.bc import BcSettings
    from sumo_rail.learning.sb3.gail import GailSettings, train_gail
    from sumo_rail.learning.sb3.runs import BaselineError

    original, saved = pq.write_table, {}

    def fail_from_the_second_update(row: dict[str, Any]) -> None:
        saved.update(fingerprint(workspace / "gail_run"))

        def write_half_then_fail(table: pa.Table, where: Any, **kwargs: Any) -> None:
            Path(where).write_bytes(b"half")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        monkeypatch.setattr(pq, "write_table", write_half_then_fail)

    settings = GailSettings("demos.parquet", timesteps=64, envs=1, n_steps=32, batch_size=32,
                            bc=BcSettings(epochs=1))
    with pytest.raises(BaselineError) as caught:
        train_gail(workspace / "gail_run", settings, SMALL_CONFIG, on_update=fail_from_the_second_update)
    monkeypatch.setattr(pq, "write_table", original)
    message = str(caught.value)
    assert "cannot save update 2" in message and os.strerror(errno.ENOSPC) in message
    assert "keeps update 1, the last complete one: make room and continue with --resume" in message
    assert saved and fingerprint(workspace / "gail_run") == saved  # update 1's files, untouched; no temporary left
    assert pd.read_parquet(workspace / "gail_run" / "log.parquet")["iteration"].tolist() == [0]
    assert train_gail(workspace / "gail_run", settings, SMALL_CONFIG, resume=True).updates == 2  # room again
    assert pd.read_parquet(workspace / "gail_run" / "log.parquet")["iteration"].tolist() == [0, 1]


# ---------------------------------------------------------------------------------------------------------------------
# Worker loss under gail and ppo.


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(child) for child in text.split()]


def _is_env_process(pid: int) -> bool:
    try:
        command = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
    except OSError:
        return False
    return b"multiprocessing" in command and b"resource_tracker" not in command


LOSING_RUNS = {
    "GAIL": ["gail", *SMALL, "--demos", "demos.parquet", "--timesteps", "100000", "--set", "gail.envs=1", "--set",
             "gail.n_steps=32",
             "--set", "bc.epochs=1", "--out", "sb3_run"],
    "PPO": ["ppo", *SMALL, "--timesteps", "100000", "--set", "ppo.envs=1", "--set", "ppo.n_steps=32", "--out",
    "sb3_run"],
    "PPO with two egos a process": ["ppo", *SMALL, "--timesteps", "100000", "--set", "ppo.envs=1", "--set",
    "ppo.egos=2",
                                    "--set", "ppo.n_steps=32", "--out", "sb3_run"],
}


@pytest.mark.parametrize("run", sorted(LOSING_RUNS))
@pytest.mark.parametrize("how", ["killed", "failing"])
def test_a_lost_stable_baselines3_environment_process_is_one_sentence(workspace: Path, tmp_path: Path, how: str,
                                                                       run: str):
    """An env process killed mid-run (kill -9), or one that fails as it starts (its cache is a file, not a folder):
    one sentence saying which process and what the run folder holds; no EOFError, no traceback from any process."""
    environment = dict(os.environ)
    if how == "failing":
        environment["SUMO_RAIL_CACHE"] = str(tmp_path / "not_a_folder")
        (tmp_path / "not_a_folder").write_text("")
    command = [sys.executable, "-m", "sumo_rail_cli", *LOSING_RUNS[run]]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment)
    try:
        if how == "killed":
            deadline = time.time() + 120
            while not (workspace / "sb3_run" / "log.parquet").exists() and time.time() < deadline:
                time.sleep(0.2)
            assert (workspace / "sb3_run" / "log.parquet").exists(), "no update was saved within 120 s"
            envs = [pid for pid in _children(process.pid) if _is_env_process(pid)]
            assert len(envs) == 1, envs
            os.kill(envs[0], signal.SIGKILL)
        _, stderr = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 1 and "Traceback" not in stderr and "EOFError" not in stderr, stderr
    error = stderr.rstrip().splitlines()[-1]
    assert error.startswith(f"Error: {run.split()[0]} stopped during update "), error
    if how == "killed":
        assert "environment process 0 was killed by signal 9" in error and "keeps update " in error \
            and error.endswith("the last complete one: continue with --resume")
    else:
        assert "environment process 0 failed: " in error and "not_a_folder" in error and "no complete update" in error
