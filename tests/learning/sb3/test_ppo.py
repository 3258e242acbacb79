import dataclasses
import json
import sys

import numpy as np
import pandas as pd
import pytest
from test_cli import SMALL, SMALL_CONFIG, invoke

from sumo_rail.datasets import read_metadata
from sumo_rail.drivers.policies import Policy, PolicyShape, load_policy, save_policy
from sumo_rail.learning.sb3.ppo import INSTALL_HINT, EpisodeTally, PpoSettings
from sumo_rail.sim.observation import observation_names


def info(overtakes: int, lane_changes: int = 0, distance_m: float = 100.0, time_s: float = 10.0,
         lane: int = 0) -> dict:
    return {"overtakes": overtakes, "lane_changes": lane_changes, "distance_m": distance_m, "time_s": time_s,
            "collisions": 0, "lane": lane}


def test_the_overtake_shaping_pays_each_new_overtake_once_and_restarts_with_the_episode():
    tally = EpisodeTally(envs=2, overtake_reward=2.0)
    no = np.array([False, False])
    first = tally.shaped(np.array([0.5, 0.5]), no, [info(0), info(1)])
    assert first.tolist() == [0.5, 2.5]
    second = tally.shaped(np.array([0.5, 0.5]), np.array([True, False]), [info(2, 1, 250.0, 10.0), info(1)])
    assert second.tolist() == [4.5, 0.5]  # env 0: two new overtakes; env 1: none since the last step
    assert tally.take() == [{"return": 5.0, "speed_kmh": pytest.approx(90.0), "overtakes": 2, "lane_changes": 1,
                             "collisions": 0}]
    third = tally.shaped(np.array([0.5, 0.5]), no, [info(1), info(1)])  # env 0's new episode counts from 0 again
    assert third.tolist() == [2.5, 0.5] and tally.take() == []


def test_the_keep_right_shaping_pays_most_in_the_rightmost_lane_and_nothing_in_the_leftmost():
    tally = EpisodeTally(envs=5, overtake_reward=0.0, keep_right_reward=0.4, lanes=5)
    shaped = tally.shaped(np.zeros(5), np.zeros(5, dtype=bool), [info(0, lane=lane) for lane in range(5)])
    np.testing.assert_allclose(shaped, [0.4, 0.3, 0.2, 0.1, 0.0], atol=1e-7)


def test_without_shaping_the_reward_is_the_envs():
    tally = EpisodeTally(envs=1, overtake_reward=0.0)
    assert tally.shaped(np.array([0.25]), np.array([False]), [info(3)]).tolist() == [0.25]


def test_bad_settings_are_usage_errors(tmp_path):
    with pytest.raises(ValueError, match="overtake_reward"):
        PpoSettings(overtake_reward=-1.0)
    result = invoke("ppo", "--set", "ppo.envs=1", "--set", "ppo.n_steps=1", "--out", str(tmp_path / "x"))
    assert result.exit_code == 2 and not (tmp_path / "x").exists()
    assert "an update must hold at least 2 decisions (ppo.n_steps x ppo.envs x ppo.egos)" in result.output
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "precious.txt").write_text("keep")
    result = invoke("ppo", *SMALL, "--out", str(tmp_path / "run"))
    assert result.exit_code == 1 and "not empty" in result.output and "Traceback" not in result.output
    assert [path.name for path in (tmp_path / "run").iterdir()] == ["precious.txt"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The same small PPO run twice, and once with another seed and the overtake shaping."""
    root = tmp_path_factory.mktemp("ppo")
    common = ("ppo", *SMALL, "--timesteps", "128", "--set", "ppo.envs=1", "--set", "ppo.n_steps=64", "--set",
              "ppo.batch_size=32")
    folders = []
    for name, extra in (("a", ()), ("b", ()), ("c", ("--seed", "1", "--set", "ppo.overtake_reward=1"))):
        result = invoke(*common, *extra, "--out", str(root / name))
        assert result.exit_code == 0, result.output
        folders.append(root / name)
    return folders


def test_the_same_seed_gives_the_same_driver_bit_for_bit(runs):
    a, b, c = runs
    first, _ = load_policy(a / "policy_latest.npz")
    second, _ = load_policy(b / "policy_latest.npz")
    other, _ = load_policy(c / "policy_latest.npz")
    assert np.array_equal(first.parameters, second.parameters)
    assert not np.array_equal(first.parameters, other.parameters)
    pd.testing.assert_frame_equal(pd.read_parquet(a / "log.parquet").drop(columns="wall_time_s"),
                                  pd.read_parquet(b / "log.parquet").drop(columns="wall_time_s"))


def test_the_run_folder_holds_a_policy_that_drives_and_serves_as_the_expert(runs, tmp_path):
    folder = runs[2]
    assert sorted(path.name for path in folder.iterdir()) == ["checkpoint.pt", "log.parquet", "policy_latest.npz",
                                                               "run.json"]
    record = json.loads((folder / "run.json").read_text())
    assert record["kind"] == "ppo_run" and record["settings"]["overtake_reward"] == 1.0 and record["seed"] == 1
    assert record["settings"]["critic_warmup"] == 0  # no warm-up without --init, and run.json says so
    log = pd.read_parquet(folder / "log.parquet")
    assert log["iteration"].tolist() == [0, 1] and log["env_steps"].tolist() == [64, 64]
    assert read_metadata(folder / "log.parquet")["kind"] == "training_log"
    assert (log["entropy"] > 0).all() and (log["reward_std"] != 1.0).all()
    policy, metadata = load_policy(folder / "policy_latest.npz")
    assert policy.shape.kind == "mlp" and policy.shape.hidden == 10 and metadata["iteration"] == 1
    assert np.array_equal(policy.observation_mean, np.zeros(56)) and np.array_equal(policy.observation_std, np.ones(56))
    expert = str(folder / "policy_latest.npz")
    result = invoke("evaluate", *SMALL, "--policy", expert, "--expert", expert, "--episodes", "1",
                    "--out", str(tmp_path / "evaluation.parquet"))
    assert result.exit_code == 0, result.output
    assert pd.read_parquet(tmp_path / "evaluation.parquet")["agreement"].tolist() == [1.0]


def test_missing_stable_baselines3_is_a_one_line_hint(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)
    result = invoke("ppo", "--out", str(tmp_path / "run"))
    assert result.exit_code == 1 and INSTALL_HINT in result.output and "Traceback" not in result.output
    assert not (tmp_path / "run").exists()


def cloned_driver(path, observation_size: int = 56):
    """A random two-layer policy on non-trivial observation statistics, as a BC run would save it."""
    rng = np.random.default_rng(7)
    shape = PolicyShape("mlp", observation_size, 10)
    policy = Policy(shape, rng.normal(0, 0.3, shape.parameter_count).astype(np.float32),
                    rng.normal(0, 0.5, observation_size), rng.uniform(0.5, 2.0, observation_size))
    save_policy(policy, path, {"observation_names": observation_names(SMALL_CONFIG)[:observation_size]})
    return policy


@pytest.mark.parametrize("warmup", [2, 0, None])
def test_init_starts_the_actor_from_the_policy_file_and_the_critic_warmup_keeps_it_there(tmp_path, warmup):
    """ppo.critic_warmup as set, and with --init and no ppo.critic_warmup (None) its default there, 5 updates."""
    initial = cloned_driver(tmp_path / "bc.npz")
    chosen = () if warmup is None else ("--set", f"ppo.critic_warmup={warmup}")
    result = invoke("ppo", *SMALL, "--timesteps", "128", "--set", "ppo.envs=1", "--set", "ppo.n_steps=64", "--set",
                    "ppo.batch_size=32",
                    "--init", str(tmp_path / "bc.npz"), *chosen, "--out", str(tmp_path / "run"))
    assert result.exit_code == 0, result.output
    frozen = warmup != 0
    assert ("the actor frozen in all 2 for the critic's warm-up, so the policy is the initial one" in result.output
            ) == frozen
    trained, _ = load_policy(tmp_path / "run" / "policy_latest.npz")
    assert np.array_equal(trained.observation_mean, initial.observation_mean)
    assert np.array_equal(trained.observation_std, initial.observation_std)
    assert np.array_equal(trained.parameters, initial.parameters) == frozen
    assert pd.read_parquet(tmp_path / "run" / "log.parquet")["actor_frozen"].tolist() == [frozen] * 2
    stored = json.loads((tmp_path / "run" / "run.json").read_text())["settings"]
    assert stored["init"] == str(tmp_path / "bc.npz") and stored["critic_warmup"] == (5 if warmup is None else warmup)


def test_an_init_policy_of_another_shape_or_observation_is_refused_before_any_work(tmp_path):
    cloned_driver(tmp_path / "bc.npz")
    result = invoke("ppo", *SMALL, "--init", str(tmp_path / "bc.npz"), "--set", "network.shape=linear", "--out",
                    str(tmp_path / "run"))
    assert result.exit_code == 2 and "is a mlp (10 hidden units) policy but the run asks for a linear" in result.output
    cloned_driver(tmp_path / "short.npz", observation_size=30)
    result = invoke("ppo", *SMALL, "--init", str(tmp_path / "short.npz"), "--out", str(tmp_path / "run"))
    assert result.exit_code == 1 and "reads 30 observation values" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "run").exists()
    shape = PolicyShape("mlp", 56, 10, actions=111)  # a policy of the acceleration interface, a run of the paper's
    save_policy(Policy(shape, np.zeros(shape.parameter_count)), tmp_path / "acceleration.npz", {})
    result = invoke("ppo", *SMALL, "--init", str(tmp_path / "acceleration.npz"), "--out", str(tmp_path / "run"))
    assert result.exit_code == 2 and "chooses among 111 actions" in result.output and not (tmp_path / "run").exists()


def test_ppo_refuses_a_warmup_without_init_and_a_batch_larger_than_an_update_before_any_work(tmp_path):
    common = ("ppo", *SMALL, "--set", "ppo.envs=1", "--set", "ppo.n_steps=32", "--out", str(tmp_path / "run"))
    result = invoke(*common, "--set", "ppo.critic_warmup=3")
    assert result.exit_code == 2 and "ppo.critic_warmup needs --init" in result.output
    result = invoke(*common, "--set", "ppo.batch_size=33")
    assert result.exit_code == 2
    assert "ppo.batch_size must be at least 2 and at most an update's 32 decisions" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "run").exists()


def test_resume_refuses_other_settings_a_damaged_checkpoint_and_nothing_to_resume(tmp_path):
    common = ("ppo", *SMALL, "--set", "ppo.envs=1", "--set", "ppo.n_steps=32", "--set", "ppo.batch_size=16", "--resume")
    result = invoke(*common, "--out", str(tmp_path / "none"))
    assert result.exit_code == 1 and "nothing to resume" in result.output
    run = tmp_path / "run"
    assert invoke(*common[:-1], "--timesteps", "32", "--out", str(run)).exit_code == 0
    result = invoke(*common, "--timesteps", "64", "--set", "ppo.gamma=0.9", "--out", str(run))
    assert result.exit_code == 1 and "was started with other settings" in result.output
    (run / "checkpoint.pt").write_bytes((run / "checkpoint.pt").read_bytes()[:500])
    result = invoke(*common, "--timesteps", "64", "--out", str(run))
    assert result.exit_code == 1 and "checkpoint" in result.output and "Traceback" not in result.output


def test_the_ppo_and_gail_defaults_are_their_settings(tmp_path):
    """Each default is written once, in PpoSettings and GailSettings: --timesteps reads it, and a run without a
    setting stores the dataclass's values in run.json (the minibatch as used, the seed the run's)."""
    from sumo_rail_cli.gail_command import gail_command
    from sumo_rail_cli.ppo_command import ppo_command

    from sumo_rail.learning.sb3.gail import GailSettings

    assert ppo_command.make_context("ppo", ["--out", "run"]).params["timesteps"] == PpoSettings().timesteps
    gail = gail_command.make_context("gail", ["--demos", "d.parquet", "--out", "run"]).params
    assert gail["timesteps"] == GailSettings("d.parquet").timesteps
    result = invoke("ppo", *SMALL, "--timesteps", "1", "--set", "ppo.n_steps=8", "--out", str(tmp_path / "run"))
    assert result.exit_code == 0, result.output
    stored = json.loads((tmp_path / "run" / "run.json").read_text())["settings"]
    expected = dataclasses.asdict(PpoSettings(n_steps=8, timesteps=1, batch_size=16))
    assert stored == expected


def test_the_finished_lines_say_the_critics_warm_up_in_words():
    from pathlib import Path
    from types import SimpleNamespace

    from sumo_rail_cli.running import sb3_outcome

    def said(updates: int, warmup: int) -> str:
        result = SimpleNamespace(updates=updates, timesteps=64 * updates, interrupted=False)
        return sb3_outcome(result, Path("run"), warmup).split(" (", 1)[1].split(")")[0]

    assert said(2, 1) == "128 timesteps; the actor frozen in the first update for the critic's warm-up"
    assert said(3, 2) == "192 timesteps; the actor frozen in the first 2 updates for the critic's warm-up"
    assert said(1, 0) == "64 timesteps"
