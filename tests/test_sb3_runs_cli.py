"""gail and ppo from the outside: Ctrl-C (twice), or SIGTERM to the process group, ends a running run after its
update with the files whole and the run continues with --resume, which repeats bit for bit; --egos is counted in the
environment's decisions."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli
from test_cli import SMALL

from sumo_rail.datasets import read_metadata
from sumo_rail.drivers.policies import load_policy


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


@pytest.fixture(scope="module")
def demos(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("demos") / "demos.parquet"
    result = invoke("record-expert", *SMALL, "--episodes", "2", "--out", str(path))
    assert result.exit_code == 0, result.output
    return path


def runs(demos: Path) -> dict[str, list[str]]:
    def common(section: str) -> list[str]:
        return [*SMALL, "--set", f"{section}.envs=1", "--set", f"{section}.n_steps=32"]
    return {"ppo": ["ppo", *common("ppo")],
            "gail": ["gail", *common("gail"), "--demos", str(demos), "--set", "bc.epochs=1", "--set",
                     "gail.critic_warmup=0"]}


@pytest.mark.parametrize("command", ["ppo", "gail"])
def test_ctrl_c_twice_stops_after_the_update_with_its_files_whole_and_resume_goes_on(tmp_path, demos, command):
    run = tmp_path / "run"
    args = [*runs(demos)[command], "--out", str(run)]
    process = subprocess.Popen([sys.executable, "-m", "sumo_rail_cli", *args, "--timesteps", "100000"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not (run / "checkpoint.pt").exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        assert (run / "checkpoint.pt").exists(), "no update was saved within 120 s"
        process.send_signal(signal.SIGINT)
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 1 and "Traceback" not in stderr, stderr
    error = stderr.rstrip().splitlines()[-1]
    assert error.startswith("Error: interrupted after ") and error.endswith(
        f"PPO update{'s' * (not error.startswith('Error: interrupted after 1 '))}; {run} keeps them, continue with "
        f"--resume"), error
    updates = int(error.split()[3])
    log = pd.read_parquet(run / "log.parquet")
    assert log["iteration"].tolist() == list(range(updates))
    _, metadata = load_policy(run / "policy_latest.npz")
    assert metadata["iteration"] == updates - 1  # the policy is the last logged update's
    assert read_metadata(run / "log.parquet")["kind"] == "training_log"
    result = invoke(*args, "--timesteps", str(32 * (updates + 1)), "--resume")
    assert result.exit_code == 0, result.output
    assert f"trained {updates + 1} PPO updates" in result.output
    assert pd.read_parquet(run / "log.parquet")["iteration"].tolist() == list(range(updates + 1))


def test_a_sigterm_to_the_whole_process_group_stops_as_ctrl_c_does(tmp_path, demos):
    """GNU timeout and schedulers send SIGTERM to the command's whole process group: its environment processes
    ignore it as they ignore a Ctrl-C, so the run stops after its update with Ctrl-C's sentence (not 'environment
    process 0 was killed by signal 15')."""
    run = tmp_path / "run"
    process = subprocess.Popen([sys.executable, "-m", "sumo_rail_cli", *runs(demos)["ppo"], "--set", "ppo.envs=2",
                                "--out", str(run), "--timesteps", "100000"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while not (run / "checkpoint.pt").exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        assert (run / "checkpoint.pt").exists(), "no update was saved within 120 s"
        os.killpg(process.pid, signal.SIGTERM)
        _, stderr = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()
    assert process.returncode == 1 and "Traceback" not in stderr, stderr
    error = stderr.rstrip().splitlines()[-1]
    assert error.startswith("Error: interrupted after ") and error.endswith("continue with --resume"), error
    assert int(error.split()[3]) == len(pd.read_parquet(run / "log.parquet"))


@pytest.mark.parametrize("command", ["ppo", "gail"])
def test_a_ctrl_c_while_a_stopped_run_closes_is_ignored_and_the_run_says_what_it_keeps(tmp_path, demos, command,
                                                                                      monkeypatch):
    """Ctrl-C during the first update stops the run after it; another while its environment processes close (the
    first one already acted on) neither cuts the closing short nor changes the sentence: the folder keeps 1 update."""
    import importlib

    from sumo_rail.learning.sb3 import runs as sb3_runs

    learner, closed = importlib.import_module(f"sumo_rail.learning.sb3.{command}"), []
    save, close = learner.save_update, sb3_runs.close_envs

    def save_then_ctrl_c(*args, **kwargs):
        save(*args, **kwargs)
        os.kill(os.getpid(), signal.SIGINT)

    def ctrl_c_then_close(venv, lost):
        os.kill(os.getpid(), signal.SIGINT)
        close(venv, lost)
        closed.append(lost)

    monkeypatch.setattr(learner, "save_update", save_then_ctrl_c)
    monkeypatch.setattr(sb3_runs, "close_envs", ctrl_c_then_close)
    run = tmp_path / "run"
    result = invoke(*runs(demos)[command], "--timesteps", "96", "--out", str(run))
    assert result.exit_code == 1 and closed == [False], result.output
    assert result.output.rstrip().splitlines()[-1] == (f"Error: interrupted after 1 PPO update; {run} keeps them, "
                                                       f"continue with --resume")
    assert pd.read_parquet(run / "log.parquet")["iteration"].tolist() == [0]


@pytest.mark.parametrize("command", ["ppo", "gail"])
def test_a_ctrl_c_before_the_first_update_says_how_to_start_again(tmp_path, demos, command, monkeypatch):
    """Stopped before any update was saved, the folder holds only run.json: neither a new run into it nor --resume
    would take it, so the sentence says to remove it."""
    import importlib

    learner = importlib.import_module(f"sumo_rail.learning.sb3.{command}")
    build = learner.build_ppo

    def ctrl_c_then_build(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)
        return build(*args, **kwargs)

    monkeypatch.setattr(learner, "build_ppo", ctrl_c_then_build)
    run = tmp_path / "run"
    result = invoke(*runs(demos)[command], "--timesteps", "32", "--out", str(run))
    assert result.exit_code == 1 and not (run / "checkpoint.pt").exists(), result.output
    assert result.output.rstrip().splitlines()[-1] == (f"Error: interrupted before the first update was saved, so "
                                                       f"there is nothing to resume: remove {run} and run the "
                                                       f"command again")


@pytest.mark.parametrize("command", ["ppo", "gail"])
def test_two_egos_a_process_drive_twice_the_decisions_counted_in_the_environment(tmp_path, demos, command):
    steps = {}
    for egos in (1, 2):
        result = invoke(*runs(demos)[command], "--set", f"{command}.egos={egos}", "--timesteps", "1", "--out",
                        str(tmp_path / f"egos{egos}"))
        assert result.exit_code == 0, result.output
        steps[egos] = pd.read_parquet(tmp_path / f"egos{egos}" / "log.parquet")["env_steps"].tolist()
    assert steps == {1: [32], 2: [64]}


@pytest.mark.parametrize("command", ["ppo", "gail"])
def test_one_update_is_said_in_the_singular_and_resumed_runs_repeat_bit_for_bit(tmp_path, demos, command):
    """A run of one update, continued twice from copies of its folder to three updates: the same files both times,
    the first update kept, the progress ending at 100%."""
    args = runs(demos)[command]
    result = invoke(*args, "--timesteps", "32", "--out", str(tmp_path / "a"))
    assert result.exit_code == 0 and "trained 1 PPO update (32 timesteps" in result.output, result.output
    first, _ = load_policy(tmp_path / "a" / "policy_latest.npz")
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    for name in ("a", "b"):
        result = invoke(*args, "--timesteps", "96", "--resume", "--out", str(tmp_path / name))
        assert result.exit_code == 0 and "trained 3 PPO updates (96 timesteps" in result.output, result.output
        assert f"{command.upper()}: 96/96 timesteps (100%)" in result.output
    a, b = (pd.read_parquet(tmp_path / name / "log.parquet").drop(columns="wall_time_s") for name in "ab")
    pd.testing.assert_frame_equal(a, b)
    assert a["iteration"].tolist() == [0, 1, 2]
    assert (tmp_path / "a" / "policy_latest.npz").read_bytes() == (tmp_path / "b" / "policy_latest.npz").read_bytes()
    resumed, _ = load_policy(tmp_path / "a" / "policy_latest.npz")
    assert not np.array_equal(first.parameters, resumed.parameters)
    assert json.loads((tmp_path / "a" / "run.json").read_text())["settings"]["timesteps"] == 96



def test_a_resumed_gail_run_goes_on_from_its_saved_discriminator(tmp_path, demos):
    """Two copies of a one-update run, one with its checkpoint's discriminator weights halved, resumed to three
    updates: the discriminator's rewards, and so the logs, differ. (Updates after a resume differ from an uninterrupted
    run's by design, docs/reliability.md; two untouched copies resumed alike pass with the discriminator lost.)"""
    import torch

    args = runs(demos)["gail"]
    assert invoke(*args, "--timesteps", "32", "--out", str(tmp_path / "kept")).exit_code == 0
    shutil.copytree(tmp_path / "kept", tmp_path / "halved")
    checkpoint_path = tmp_path / "halved" / "checkpoint.pt"
    checkpoint = torch.load(checkpoint_path, weights_only=True)
    checkpoint["discriminator"]["model"] = {name: tensor / 2 for name, tensor in
                                            checkpoint["discriminator"]["model"].items()}
    with checkpoint_path.open("wb") as file:
        torch.save(checkpoint, file)
    for name in ("kept", "halved"):
        result = invoke(*args, "--timesteps", "96", "--resume", "--out", str(tmp_path / name))
        assert result.exit_code == 0, result.output
    kept, halved = (pd.read_parquet(tmp_path / name / "log.parquet") for name in ("kept", "halved"))
    assert kept["return_mean"].iloc[0] == halved["return_mean"].iloc[0]  # the saved update, as it was
    assert not np.allclose(kept["return_mean"].iloc[1:], halved["return_mean"].iloc[1:])
