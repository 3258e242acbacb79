"""train/gail/dagger --tensorboard: every log row's numbers as TensorBoard scalars against cumulative env steps."""

import sys

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli

from sumo_rail.learning.tensorboard_log import TensorBoardLogger

SMALL = ["--set", "scenario.length_m=1500", "--set", "scenario.warmup_s=120", "--set", "scenario.snapshots=3",
         "--set", "scenario.snapshot_interval_s=10", "--set", "env.ego_start_max_m=500"]


def scalars(log_dir) -> dict[str, list[tuple[int, float]]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(str(log_dir))
    events.Reload()
    return {tag: [(event.step, event.value) for event in events.Scalars(tag)] for tag in events.Tags()["scalars"]}


@pytest.fixture(scope="module")
def demos(tmp_path_factory):
    path = tmp_path_factory.mktemp("demos") / "expert.parquet"
    result = CliRunner().invoke(cli, ["record-expert", "--episodes", "2", *SMALL, "--out", str(path)])
    assert result.exit_code == 0, result.output
    return path


def test_train_logs_each_iteration_to_tensorboard_and_resume_continues_the_steps(demos, tmp_path):
    pytest.importorskip("tensorboard", reason="--tensorboard is the package's optional extra [tensorboard]")
    run, board = tmp_path / "run", tmp_path / "board"
    common = ["train", *SMALL, "--demos", str(demos), "--set", "rail.directions=2", "--set", "rail.top=1", "--set",
              "bc.epochs=1",
              "--eval-every", "0", "--out", str(run), "--tensorboard", str(board)]
    assert (result := CliRunner().invoke(cli, [*common, "--iterations", "2"])).exit_code == 0, result.output
    assert (result := CliRunner().invoke(cli, [*common, "--iterations", "3", "--resume"])).exit_code == 0, \
        result.output
    log = pd.read_parquet(run / "log.parquet")
    logged = scalars(board)
    steps = np.cumsum(log["env_steps"]).tolist()
    assert [step for step, _ in logged["rail/return_mean"]] == steps
    assert np.allclose([value for _, value in logged["rail/return_mean"]], log["return_mean"])
    assert "rail/discriminator_accuracy" in logged and "rail/env_steps" in logged


def test_gail_logs_each_update_to_tensorboard(demos, tmp_path):
    pytest.importorskip("tensorboard", reason="--tensorboard is the package's optional extra [tensorboard]")
    pytest.importorskip("stable_baselines3", reason="gail is the package's optional extra [baselines]")
    run, board = tmp_path / "run", tmp_path / "run" / "tensorboard"  # inside the new run folder is fine
    result = CliRunner().invoke(cli, ["gail", *SMALL, "--demos", str(demos), "--timesteps", "256", "--set",
                                      "gail.n_steps=64", "--set", "gail.envs=2", "--set", "bc.epochs=1", "--out",
                                      str(run), "--tensorboard", str(board)])
    assert result.exit_code == 0, result.output
    log = pd.read_parquet(run / "log.parquet")
    logged = scalars(board)
    assert [step for step, _ in logged["gail/return_mean"]] == np.cumsum(log["env_steps"]).tolist()
    assert np.allclose([value for _, value in logged["gail/entropy"]], log["entropy"])


def test_dagger_logs_each_round_to_tensorboard_and_resume_continues_the_steps(demos, tmp_path):
    pytest.importorskip("tensorboard", reason="--tensorboard is the package's optional extra [tensorboard]")
    run, board = tmp_path / "run", tmp_path / "board"
    common = ["dagger", *SMALL, "--demos", str(demos), "--set", "dagger.episodes_per_round=1", "--set", "bc.epochs=1",
              "--eval-every", "0", "--out", str(run), "--tensorboard", str(board)]
    assert (result := CliRunner().invoke(cli, [*common, "--rounds", "1"])).exit_code == 0, result.output
    assert (result := CliRunner().invoke(cli, [*common, "--rounds", "2", "--resume"])).exit_code == 0, result.output
    log = pd.read_parquet(run / "log.parquet")
    logged = scalars(board)
    assert len(log) == 3  # BC, then two rounds
    assert [step for step, _ in logged["dagger/dataset_rows"]] == np.cumsum(log["env_steps"]).tolist()
    assert [value for _, value in logged["dagger/dataset_rows"]] == log["dataset_rows"].tolist()


def test_logger_skips_non_numbers_and_missing_tensorboard_names_the_extra(tmp_path, monkeypatch):
    pytest.importorskip("tensorboard")
    logger = TensorBoardLogger(tmp_path / "board", "rail")
    logger.log({"iteration": 0, "env_steps": 10, "return_mean": 0.5, "eval_speed": None, "flag": True,
                "nan": float("nan"), "name": "x"})
    logger.close()
    assert set(scalars(tmp_path / "board")) == {"rail/iteration", "rail/env_steps", "rail/return_mean"}
    monkeypatch.setitem(sys.modules, "tensorboard", None)
    result = CliRunner().invoke(cli, ["train", "--demos", "x.parquet", "--out", str(tmp_path / "run"),
                                      "--tensorboard", str(tmp_path / "tb")])
    assert result.exit_code == 1 and "pip install 'sumo-rail[tensorboard]'" in result.output
