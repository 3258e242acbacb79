import dataclasses
import json

import numpy as np
import pandas as pd
import pytest
import torch
from rail_runs import run_settings
from test_cli import SMALL, hand_made_policy, invoke

from sumo_rail.drivers.policies import MIN_STD, load_policy
from sumo_rail.evaluation.summary import intervals
from sumo_rail.learning.bc import BcSettings
from sumo_rail.learning.rail.discriminator import DiscriminatorSettings
from sumo_rail.learning.rail.iteration import RailSettings, rollout_return
from sumo_rail.learning.rail.trainer import RunSettings, train
from sumo_rail.learning.run_folder import RunError
from sumo_rail.learning.validation import VALIDATION_BASE_SEED, VALIDATION_INTERVAL, Validation, validate
from sumo_rail.runners.backends import ProcessPoolBackend, SerialBackend
from sumo_rail.runners.rollout import ExpertDriver


def test_a_collision_never_pays_by_ending_early():
    rewards = np.array([-0.5, -0.5])
    lowest = -6.9
    early = rollout_return(rewards, collided=True, horizon=10, lowest_reward=lowest)
    assert early < rollout_return(np.full(10, -0.5), collided=False, horizon=10, lowest_reward=lowest)
    assert early == pytest.approx((-1.0 + 8 * lowest) / 10)
    assert rollout_return(rewards, collided=False, horizon=10, lowest_reward=lowest) == -0.5  # a mean, not a sum


def test_settings_reject_top_above_directions():
    with pytest.raises(ValueError, match=r"rail\.top must be between 1 and rail\.directions"):
        RailSettings(directions=4, top=5)


@pytest.mark.parametrize(("remedies", "respawning"), [(False, False), (True, False), (False, True)],
                         ids=["paper", "remedies", "respawning"])
def test_same_weights_with_one_or_two_workers_and_after_resuming(tmp_path, demos_path, small_config_module, remedies,
                                                                 respawning):
    settings = run_settings(demos_path, remedies=remedies, respawning=respawning)
    validation = Validation(every=2, episodes=1)
    with ProcessPoolBackend(1) as one:
        train(tmp_path / "one", settings, small_config_module, 3, one, resume=False, validation=validation)
    with ProcessPoolBackend(2) as two:
        train(tmp_path / "split", settings, small_config_module, 2, two, resume=False, validation=validation)
        train(tmp_path / "split", settings, small_config_module, 3, two, resume=True, validation=validation)
    uninterrupted, _ = load_policy(tmp_path / "one" / "policy_latest.npz")
    resumed, _ = load_policy(tmp_path / "split" / "policy_latest.npz")
    bc, _ = load_policy(tmp_path / "one" / "policy_bc.npz")
    assert np.array_equal(uninterrupted.parameters, resumed.parameters)
    assert np.array_equal(uninterrupted.observation_mean, resumed.observation_mean)
    assert not np.array_equal(uninterrupted.parameters, bc.parameters)
    log = pd.read_parquet(tmp_path / "one" / "log.parquet")
    assert log["iteration"].tolist() == [0, 1, 2] and (log["env_steps"] > 0).all()
    assert log["eval_average_speed_kmh"].isna().tolist() == [True, False, False]  # every 2nd and the last
    assert (log["eval_average_speed_kmh"].dropna() > 30).all()
    pd.testing.assert_frame_equal(log.drop(columns="wall_time_s"),
                                  pd.read_parquet(tmp_path / "split" / "log.parquet").drop(columns="wall_time_s"))
    stored = json.loads((tmp_path / "one" / "run.json").read_text())["settings"]
    assert stored == json.loads(json.dumps(settings.to_dict()))
    if respawning:  # every rollout is its budget of decisions, whatever its episodes
        assert (log["env_steps"] == 2 * 3 * 150).all()
    if remedies:  # nu is set by the flip rate at every iteration, not by the paper's schedule
        assert log["nu"].nunique() == 3 and not np.isclose(log["nu"], settings.rail.noise.initial).any()


def test_a_run_started_before_the_newer_options_resumes_at_their_defaults(tmp_path, demos_path, small_config_module):
    settings = run_settings(demos_path)
    with SerialBackend() as backend:
        train(tmp_path / "run", settings, small_config_module, 1, backend, resume=False)
        record = json.loads((tmp_path / "run" / "run.json").read_text())
        for key in ("fitness", "flip_rate", "roads"):
            del record["settings"]["rail"][key]
        del record["settings"]["discriminator"]["reward_form"]
        (tmp_path / "run" / "run.json").write_text(json.dumps(record))
        checkpoint = torch.load(tmp_path / "run" / "checkpoint.pt", weights_only=True)  # a log without the interval
        checkpoint["log"] = [{key: value for key, value in row.items() if key not in VALIDATION_INTERVAL}
                             for row in checkpoint["log"]]
        torch.save(checkpoint, tmp_path / "run" / "checkpoint.pt")
        train(tmp_path / "run", settings, small_config_module, 2, backend, resume=True)
        with pytest.raises(RunError, match="other settings"):
            train(tmp_path / "run", dataclasses.replace(settings, rail=dataclasses.replace(settings.rail,
                                                                                          fitness="rank")),
                  small_config_module, 3, backend, resume=True)
    log = pd.read_parquet(tmp_path / "run" / "log.parquet")
    assert len(log) == 2 and log["eval_agreement_low"].isna().all()


def test_without_bc_a_frozen_normaliser_holds_the_demonstrations_statistics(tmp_path, demos_path,
                                                                            small_config_module):
    from sumo_rail.runners.tables import read_demonstrations

    settings = RunSettings(str(demos_path), "linear", 4, RailSettings(directions=2, top=1, seed=1),
                           DiscriminatorSettings(seed=1, steps_per_iteration=1), BcSettings(epochs=0))
    with SerialBackend() as backend:
        train(tmp_path / "run", settings, small_config_module, 1, backend, resume=False,
              validation=Validation(every=0, episodes=1))
    policy, _ = load_policy(tmp_path / "run" / "policy_latest.npz")
    observations = read_demonstrations(demos_path).observations.astype(np.float64)
    assert np.allclose(policy.observation_mean, observations.mean(axis=0))
    varying = observations.std(axis=0) >= MIN_STD  # a (nearly) constant feature keeps a unit scale
    assert np.allclose(policy.observation_std[varying], observations.std(axis=0)[varying])
    assert not (tmp_path / "run" / "policy_bc.npz").exists()


def test_a_worker_killed_mid_iteration_changes_nothing(tmp_path, demos_path, small_config_module):
    """kill -9 of a worker during an iteration: it is replaced, its rollout runs again, the weights are the same."""
    import os
    import signal

    settings = run_settings(demos_path)
    with SerialBackend() as serial:
        train(tmp_path / "serial", settings, small_config_module, 2, serial, resume=False)
    killed: list[int] = []
    with ProcessPoolBackend(2) as pool:
        def kill_once(index, result):
            if not killed and len(pool.pids) == 2:  # after the first rollout of the first iteration
                killed.append(pool.pids[1])
                os.kill(killed[0], signal.SIGKILL)
        train(tmp_path / "killed", settings, small_config_module, 2, pool, resume=False, on_rollout=kill_once)
        assert killed and killed[0] not in pool.pids
    expected, _ = load_policy(tmp_path / "serial" / "policy_latest.npz")
    survived, _ = load_policy(tmp_path / "killed" / "policy_latest.npz")
    assert np.array_equal(expected.parameters, survived.parameters)
    steps = [pd.read_parquet(tmp_path / name / "log.parquet")["env_steps"].tolist() for name in ("serial", "killed")]
    assert steps[0] == steps[1]  # every rollout counted exactly once


def test_validation_schedule():
    assert [i for i in range(7) if Validation(every=3).due(i, last=6)] == [2, 5, 6]
    assert not any(Validation(every=0).due(i, last=6) for i in range(7))
    with pytest.raises(ValueError):
        Validation(every=1, episodes=0)


def test_validation_is_what_evaluate_gives_on_the_validation_episodes(tmp_path, small_config_module):
    path = hand_made_policy(tmp_path / "keep.npz", action=0)
    policy, _ = load_policy(path)
    with SerialBackend() as backend:
        row = validate(policy, small_config_module, backend, Validation(every=1, episodes=3), ExpertDriver("normal"))
    result = invoke("evaluate", *SMALL, "--policy", str(path), "--pool", "validation", "--seed",
                    str(VALIDATION_BASE_SEED), "--episodes", "3", "--out", str(tmp_path / "m.parquet"))
    assert result.exit_code == 0, result.output
    evaluated = intervals(pd.read_parquet(tmp_path / "m.parquet")).set_index("measure").loc["agreement"]
    assert (row["eval_agreement"], row["eval_agreement_low"], row["eval_agreement_high"]) == (
        evaluated["estimate"], evaluated["low"], evaluated["high"])
    assert row["eval_agreement_low"] <= row["eval_agreement"] <= row["eval_agreement_high"]


def test_run_folder_rules(tmp_path, demos_path, small_config_module):
    settings = run_settings(demos_path, kind="linear")
    with SerialBackend() as backend:
        with pytest.raises(RunError, match="nothing to resume"):
            train(tmp_path / "empty", settings, small_config_module, 1, backend, resume=True)
        train(tmp_path / "run", settings, small_config_module, 1, backend, resume=False)
        log = pd.read_parquet(tmp_path / "run" / "log.parquet")
        assert log["eval_lane_changes"].isna().all() and log["eval_lane_changes"].dtype == np.float64
        with pytest.raises(RunError, match="not empty"):
            train(tmp_path / "run", settings, small_config_module, 2, backend, resume=False)
        other = RunSettings(settings.demos, "mlp", 4, settings.rail, settings.discriminator, BcSettings(epochs=3))
        with pytest.raises(RunError, match="other settings"):
            train(tmp_path / "run", other, small_config_module, 2, backend, resume=True)
        (tmp_path / "run" / "checkpoint.pt").write_bytes(b"garbage")
        with pytest.raises(RunError, match="unreadable"):
            train(tmp_path / "run", settings, small_config_module, 2, backend, resume=True)


def test_the_demonstrations_are_kept_by_absolute_path_and_content_so_a_run_resumes_from_any_folder(
        tmp_path, demos_path, small_config_module, monkeypatch):
    import shutil

    import pyarrow.parquet as pq

    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    typed = tmp_path / "a" / "demos.parquet"
    shutil.copy(demos_path, typed)
    run, validation = tmp_path / "run", Validation(every=0, episodes=1)
    monkeypatch.chdir(tmp_path / "b")
    with SerialBackend() as backend:
        def resume(demos):
            train(run, run_settings(demos), small_config_module, 1, backend, resume=True, validation=validation)

        train(run, run_settings("../a/demos.parquet"), small_config_module, 1, backend, resume=False,
              validation=validation)
        record = json.loads((run / "run.json").read_text())
        assert record["settings"]["demos"] == str(typed.resolve()) and len(record["demos_sha256"]) == 64
        monkeypatch.chdir(tmp_path)
        resume("a/demos.parquet")  # the same file, typed from another folder
        # a run.json written before: the path as typed, no hash; it resumes from the folder it was started in
        older = {**record, "settings": {**record["settings"], "demos": "../a/demos.parquet"}}
        del older["demos_sha256"]
        (run / "run.json").write_text(json.dumps(older))
        with pytest.raises(RunError, match=r"demonstrations \.\./a/demos\.parquet \(a path relative to the folder"):
            resume("a/demos.parquet")
        monkeypatch.chdir(tmp_path / "b")
        resume("../a/demos.parquet")
        (run / "run.json").write_text(json.dumps(record))
        shutil.move(typed, tmp_path / "moved.parquet")
        resume(tmp_path / "moved.parquet")  # moved: the same content
        pq.write_table(pq.read_table(tmp_path / "moved.parquet"), typed, compression="gzip")  # other bytes
        with pytest.raises(RunError, match=rf"the demonstrations {typed.resolve()} have changed since run "):
            resume(typed)
        typed.unlink()
        with pytest.raises(RunError, match=rf"started with the demonstrations {typed.resolve()}, which are gone from "
                                           r"there \(moved or deleted\)"):
            resume(_changed_copy(tmp_path))


def _changed_copy(tmp_path):
    """A demonstrations file at another path whose bytes differ from the run's."""
    import pyarrow.parquet as pq

    path = tmp_path / "other.parquet"
    pq.write_table(pq.read_table(tmp_path / "moved.parquet"), path, compression="zstd")
    return path
