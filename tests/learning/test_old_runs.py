"""Run folders made before the settings system (tests/data/old_runs, written by the code of 44d57a2: run.json with
`bc_epochs` and `bc_class_balance` in place of the `bc` section) resume with today's code under today's settings
words, and go on exactly as a run started today with those settings does; other settings are refused."""

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_cli import SMALL, invoke

from sumo_rail.drivers.policies import load_policy
from sumo_rail.learning.run_folder import upgraded

OLD_RUNS = Path(__file__).parents[1] / "data" / "old_runs"
SETTINGS = {
    "train": ["--set", "network.shape=linear", "--set", "rail.directions=2", "--set", "rail.top=1", "--set",
              "discriminator.hidden=4", "--iterations", "2", "--eval-every", "0"],
    "gail": ["--set", "gail.envs=1", "--set", "gail.n_steps=32", "--set", "gail.critic_warmup=0", "--timesteps", "64"],
}
"""Today's words for the settings each old run was made with, and a longer run."""


def old_run(tmp_path: Path, command: str) -> tuple[Path, list[str]]:
    """A copy of the old run of `command` and the arguments (demonstrations, settings) that continue it."""
    shutil.copy(OLD_RUNS / "demos.parquet", tmp_path / "demos.parquet")
    run = shutil.copytree(OLD_RUNS / f"{command}_run", tmp_path / "old")
    return run, [command, *SMALL, "--demos", str(tmp_path / "demos.parquet"), "--set", "bc.epochs=1", "--set",
                 "bc.class_balance=0.5", "--seed", "3", *SETTINGS[command]]


FLOAT_TOLERANCE = 1e-5
"""How far [relative] the old run's numbers may lie from today's: its files were written by the old code on another
machine with other library builds, whose float rounding differs (its BC weights differ from today's by 1e-9 on a
machine of 2026-12-07 with the same torch); a run with other settings differs by orders of magnitude more. That a
resume continues a run bit for bit on one machine is tested on today's runs (tests/learning/rail)."""


def same_run(folder: Path, policy: Path, log: Path) -> None:
    """The run in `folder` ended with the policy file `policy` and the log `log` (timing columns aside), up to
    `FLOAT_TOLERANCE`."""
    np.testing.assert_allclose(load_policy(folder / "policy_latest.npz")[0].parameters,
                               load_policy(policy)[0].parameters, rtol=FLOAT_TOLERANCE, atol=FLOAT_TOLERANCE)
    timing = ["wall_time_s", "seconds"]
    pd.testing.assert_frame_equal(pd.read_parquet(folder / "log.parquet").drop(columns=timing, errors="ignore"),
                                  pd.read_parquet(log).drop(columns=timing, errors="ignore"), check_exact=False,
                                  rtol=FLOAT_TOLERANCE, atol=FLOAT_TOLERANCE)


def test_an_old_train_run_resumes_and_goes_on_as_a_run_started_today(tmp_path):
    """A resumed RAIL run is the uninterrupted run, so the old run's second iteration is today's (`same_run`)."""
    run, args = old_run(tmp_path, "train")
    resumed = invoke(*args, "--out", str(run), "--resume")
    assert resumed.exit_code == 0 and "trained 2 iterations" in resumed.output, resumed.output
    fresh = invoke(*args, "--out", str(tmp_path / "fresh"))
    assert fresh.exit_code == 0, fresh.output
    same_run(run, tmp_path / "fresh" / "policy_latest.npz", tmp_path / "fresh" / "log.parquet")
    np.testing.assert_allclose(load_policy(run / "policy_bc.npz")[0].parameters,
                               load_policy(tmp_path / "fresh" / "policy_bc.npz")[0].parameters,
                               rtol=FLOAT_TOLERANCE, atol=FLOAT_TOLERANCE)


def test_an_old_gail_run_resumes_as_the_old_code_resumed_it(tmp_path):
    """A resumed SB3 run draws new environment seeds (docs/reliability.md), so it is compared with the same old run
    resumed by the code that wrote it (gail_resumed_*, made with --timesteps 64 --resume at 44d57a2)."""
    pytest.importorskip("stable_baselines3", reason="gail is the package's optional extra [baselines]")
    run, args = old_run(tmp_path, "gail")
    resumed = invoke(*args, "--out", str(run), "--resume")
    assert resumed.exit_code == 0 and "trained 2 PPO updates" in resumed.output, resumed.output
    same_run(run, OLD_RUNS / "gail_resumed_policy_latest.npz", OLD_RUNS / "gail_resumed_log.parquet")


@pytest.mark.parametrize("command", ["train", "gail"])
def test_an_old_run_refuses_to_resume_with_other_bc_settings(tmp_path, command):
    run, args = old_run(tmp_path, command)
    result = invoke(*args, "--set", "bc.class_balance=0.75", "--out", str(run), "--resume")
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert "other settings (bc.class_balance was 0.5, now 0.75)" in result.output


def test_an_old_layout_is_read_as_the_whole_bc_section_with_the_defaults_of_the_time():
    assert upgraded({"bc_epochs": 7, "seed": 2})["bc"] == {"epochs": 7, "class_balance": 0.0, "batch_size": 256,
                                                           "learning_rate": 1e-3, "holdout_fraction": 0.2, "seed": 2}
    assert upgraded({"bc_epochs": 7, "bc_class_balance": 0.3, "rail": {"seed": 5}})["bc"]["seed"] == 5
    today = {"bc": {"epochs": 1}, "rail": {}}
    assert upgraded(today) is today
