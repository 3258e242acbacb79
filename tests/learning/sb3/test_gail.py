
import json
import sys
import tempfile

import gymnasium as gym
import numpy as np
import pandas as pd
import pytest
import torch
from gymnasium import spaces
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.vec_env import DummyVecEnv
from test_cli import SMALL, invoke

from sumo_rail.datasets import read_metadata
from sumo_rail.drivers.policies import PolicyShape, load_policy
from sumo_rail.learning.bc import BcSettings, behaviour_cloning
from sumo_rail.learning.rail.discriminator import Discriminator, DiscriminatorSettings
from sumo_rail.learning.rail.iteration import rollout_return
from sumo_rail.learning.rail.normalize import RunningStats
from sumo_rail.learning.sb3.actor import policy_kwargs
from sumo_rail.learning.sb3.gail import (
    INSTALL_HINT,
    REWARD_CLIP,
    FixedNormalisation,
    GailSettings,
    RewardLabeller,
    load_into_ppo,
    normalised_rewards,
    ppo_to_policy,
    set_actor_trainable,
    train_gail,
)
from sumo_rail.learning.sb3.runs import build_ppo
from sumo_rail.report.inputs import LOG_COLUMNS, read_run
from sumo_rail.runners.tables import read_demonstrations


@pytest.fixture(scope="module")
def demos(demos_path):
    return read_demonstrations(demos_path, observation_size=56)


def actor_critic(shape: PolicyShape) -> ActorCriticPolicy:
    space = spaces.Box(-np.inf, np.inf, (shape.observation_size,), np.float32)
    return ActorCriticPolicy(space, spaces.Discrete(5), lambda _: 3e-4, **policy_kwargs(shape))


def ppo_logits(ppo: ActorCriticPolicy, normalised: np.ndarray) -> np.ndarray:
    with torch.no_grad():
        return ppo.action_net(ppo.mlp_extractor.policy_net(torch.from_numpy(normalised))).numpy()


@pytest.mark.parametrize("kind", ["mlp", "linear"])
def test_the_exported_policy_acts_as_ppo_predicts(demos, kind):
    torch.manual_seed(0)
    shape = PolicyShape(kind, 56, hidden=10)
    ppo = actor_critic(shape)
    assert len(ppo.action_net.weight[0]) == (10 if kind == "mlp" else 56)  # SB3 allows an empty pi for linear
    with torch.no_grad():
        for parameter in ppo.parameters():
            parameter.normal_()  # logits far apart, not PPO's near-zero initial ones
    stats = RunningStats.of(demos.observations)
    normalisation = FixedNormalisation(stats.mean, stats.std)
    policy = ppo_to_policy(ppo, shape, normalisation)
    predicted, _ = ppo.predict(normalisation(demos.observations), deterministic=True)
    assert np.array_equal([policy.act(observation) for observation in demos.observations], predicted)
    np.testing.assert_allclose(policy.logits(demos.observations), ppo_logits(ppo, normalisation(demos.observations)),
                               rtol=1e-5, atol=1e-5)


def test_bc_weights_copied_into_ppo_give_the_same_logits(demos):
    shape = PolicyShape("mlp", 56, hidden=10)
    bc, _ = behaviour_cloning(demos, shape, BcSettings(epochs=2, seed=1))
    ppo = actor_critic(shape)
    load_into_ppo(bc, ppo)
    normalisation = FixedNormalisation(bc.observation_mean, bc.observation_std)
    np.testing.assert_allclose(ppo_logits(ppo, normalisation(demos.observations)), bc.logits(demos.observations),
                               rtol=1e-5, atol=1e-5)
    assert np.array_equal(ppo_to_policy(ppo, shape, normalisation).parameters, bc.parameters)
    with pytest.raises(ValueError, match="layout"):
        load_into_ppo(bc, actor_critic(PolicyShape("mlp", 56, hidden=4)))


def test_a_collision_pays_the_missing_decisions_at_the_lowest_reward(demos):
    discriminator = Discriminator(56, np.zeros(56), np.ones(56), DiscriminatorSettings(seed=0))
    labeller = RewardLabeller(discriminator, envs=2, horizon=10)
    observations, actions = demos.observations[:2], np.array([0, 3])
    plain = discriminator.reward(observations, actions)
    first = labeller.label(observations, actions, np.array([False, False]), [{}, {}])
    second = labeller.label(observations, actions, np.array([True, True]),
                            [{"termination": "collision"}, {"termination": "end_of_road"}])
    np.testing.assert_allclose(first, plain, rtol=1e-6)
    assert second[0] == pytest.approx(plain[0] + 8 * labeller.lowest_reward, rel=1e-6)
    assert second[1] == pytest.approx(plain[1], rel=1e-6)
    rollout = labeller.take()
    assert rollout.collisions == 1 and rollout.observations.shape == (4, 56) and rollout.actions.tolist() == [0, 3] * 2
    expected = [rollout_return(np.array([plain[0]] * 2), True, 10, labeller.lowest_reward), plain[1]]
    np.testing.assert_allclose(rollout.returns, expected, rtol=1e-6)
    labeller.label(observations, actions, np.array([False, False]), [{}, {}])
    assert labeller.take().returns.size == 0  # episodes restart after an end; each take starts afresh


class ToyEnv(gym.Env):
    """Random observations and rewards in [-1, 1]; episodes of `length` decisions, the last one adding `final`."""

    observation_space = spaces.Box(-np.inf, np.inf, (56,), np.float32)
    action_space = spaces.Discrete(5)

    def __init__(self, seed: int, length: int = 25, final: float = 0.0) -> None:
        self.rng, self.length, self.final, self.decisions = np.random.default_rng(seed), length, final, 0

    def reset(self, *, seed=None, options=None):
        self.decisions = 0
        return self.rng.normal(size=56).astype(np.float32), {}

    def step(self, action):
        self.decisions += 1
        done = self.decisions == self.length
        reward = self.rng.uniform(-1, 1) + (self.final if done else 0.0)
        return self.rng.normal(size=56).astype(np.float32), float(reward), done, False, {}


def test_normalised_rewards_are_divided_by_the_discounted_return_std_and_clipped():
    venv = normalised_rewards(DummyVecEnv([lambda: ToyEnv(0, length=80, final=-5000.0), lambda: ToyEnv(1)]), 0.9)
    venv.reset()
    returns, history, clipped = np.zeros(2), [], []
    for _ in range(120):
        observations, rewards, dones, _ = venv.step(np.zeros(2, dtype=np.int64))
        raw = venv.get_original_reward()
        assert np.array_equal(observations, venv.get_original_obs())  # observations pass unchanged
        returns = returns * 0.9 + raw
        history += returns.tolist()
        if len(history) > 40:  # past Stable-Baselines3's prior (variance 1 with weight 1e-4)
            np.testing.assert_allclose(rewards, np.clip(raw / np.std(history), -REWARD_CLIP, REWARD_CLIP), rtol=1e-3)
        clipped += [reward for reward, original in zip(rewards, raw, strict=True) if original < -1000]
        returns[dones] = 0
    assert clipped == [-REWARD_CLIP]  # the padded final decision: -5000 / std would be about -12


def test_a_frozen_actor_stays_bit_identical_while_the_critic_learns(demos):
    shape = PolicyShape("mlp", 56, hidden=10)
    bc, _ = behaviour_cloning(demos, shape, BcSettings(epochs=1, seed=1))
    normalisation = FixedNormalisation(bc.observation_mean, bc.observation_std)
    settings = GailSettings("unused", n_steps=64, envs=1, batch_size=32, ppo_epochs=2, seed=0)
    model = build_ppo(DummyVecEnv([lambda: ToyEnv(2)]), shape, settings)
    load_into_ppo(bc, model.policy)
    critic = [*model.policy.mlp_extractor.value_net.parameters(), *model.policy.value_net.parameters()]
    before = [parameter.detach().clone() for parameter in critic]
    set_actor_trainable(model.policy, False)
    model.learn(128)  # two updates
    assert np.array_equal(ppo_to_policy(model.policy, shape, normalisation).parameters, bc.parameters)
    assert all(not torch.equal(old, new) for old, new in zip(before, critic, strict=True))
    set_actor_trainable(model.policy, True)
    model.learn(64, reset_num_timesteps=False)
    assert not np.array_equal(ppo_to_policy(model.policy, shape, normalisation).parameters, bc.parameters)


def test_ppo_updates_leave_no_logger_directories_behind_and_keep_their_values(tmp_path, monkeypatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # where SB3's default logger makes its directories
    settings = GailSettings("unused", n_steps=64, envs=1, batch_size=32, ppo_epochs=1, seed=0)
    model = build_ppo(DummyVecEnv([lambda: ToyEnv(2)]), PolicyShape("linear", 56), settings)
    for _ in range(3):
        model.learn(64, reset_num_timesteps=False)  # as the training commands call it: once an update
    assert list(tmp_path.iterdir()) == []
    assert np.isfinite(model.logger.name_to_value["train/entropy_loss"])


def tiny_settings(demos_path) -> GailSettings:
    return GailSettings(str(demos_path), timesteps=256, n_steps=64, envs=2, bc=BcSettings(epochs=2), critic_warmup=1,
                        seed=3, discriminator=DiscriminatorSettings(seed=3, steps_per_iteration=2))


@pytest.fixture(scope="module")
def runs(tmp_path_factory, demos_path, small_config_module):
    """Two identical runs of two updates (the first a critic warm-up); the first run's policy after each update."""
    folders = [tmp_path_factory.mktemp("gail") / name for name in ("a", "b")]
    snapshots = []

    def snapshot(row):
        snapshots.append(load_policy(folders[0] / "policy_latest.npz")[0].parameters)

    results = [train_gail(folder, tiny_settings(demos_path), small_config_module,
                          on_update=snapshot if folder == folders[0] else None) for folder in folders]
    return folders, results, snapshots


def test_the_same_seed_gives_the_same_policy_bit_for_bit(runs):
    (a, b), results, _ = runs
    assert all(result.updates == 2 and result.timesteps == 256 and not result.interrupted for result in results)
    first, _ = load_policy(a / "policy_latest.npz")
    second, _ = load_policy(b / "policy_latest.npz")
    bc, _ = load_policy(a / "policy_bc.npz")
    assert np.array_equal(first.parameters, second.parameters)
    assert not np.array_equal(first.parameters, bc.parameters)
    assert np.array_equal(first.observation_mean, bc.observation_mean)  # fixed normalisation: BC's
    pd.testing.assert_frame_equal(pd.read_parquet(a / "log.parquet").drop(columns="wall_time_s"),
                                  pd.read_parquet(b / "log.parquet").drop(columns="wall_time_s"))


def test_the_run_folder_is_read_by_report_and_evaluate(runs, demos_path):
    folder = runs[0][0]
    assert sorted(path.name for path in folder.iterdir()) == ["checkpoint.pt", "log.parquet", "policy_bc.npz",
                                                              "policy_latest.npz", "run.json"]
    log = pd.read_parquet(folder / "log.parquet")
    assert set(LOG_COLUMNS) | {"discriminator_loss", "discriminator_accuracy", "collisions"} <= set(log.columns)
    assert log["iteration"].tolist() == [0, 1] and log["env_steps"].tolist() == [128, 128]
    assert read_metadata(folder / "log.parquet")["kind"] == "training_log"
    record = json.loads((folder / "run.json").read_text())
    assert record["settings"]["demos"] == str(demos_path) and record["kind"] == "gail_run"
    assert record["settings"]["normalize_reward"] is True and record["settings"]["critic_warmup"] == 1
    assert read_run(folder, "gail").kind == "mlp (10 hidden)"
    result = invoke("evaluate", *SMALL, "--policy", str(folder / "policy_latest.npz"), "--episodes", "1")
    assert result.exit_code == 0, result.output
    assert "policy_latest" in result.output


def test_the_critic_warms_up_before_the_actor_moves(runs):
    (folder, _), _, snapshots = runs
    bc, _ = load_policy(folder / "policy_bc.npz")
    log = pd.read_parquet(folder / "log.parquet")
    assert log["actor_frozen"].tolist() == [True, False]
    assert np.array_equal(snapshots[0], bc.parameters) and not np.array_equal(snapshots[1], bc.parameters)
    assert (log["reward_std"] > 0).all() and (log["reward_std"] != 1.0).all()  # normalised: the running std


def test_missing_stable_baselines3_is_a_one_line_hint(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)
    result = invoke("gail", "--demos", str(tmp_path / "demos.parquet"), "--out", str(tmp_path / "run"))
    assert result.exit_code == 1 and INSTALL_HINT in result.output and "Traceback" not in result.output
    assert not (tmp_path / "run").exists()


def test_gail_refuses_a_non_empty_out_and_bad_sizes(tmp_path, demos_path):
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "precious.txt").write_text("keep")
    result = invoke("gail", *SMALL, "--demos", str(demos_path), "--out", str(tmp_path / "run"))
    assert result.exit_code == 1 and "not empty" in result.output and "Traceback" not in result.output
    assert [path.name for path in (tmp_path / "run").iterdir()] == ["precious.txt"]
    result = invoke("gail", "--demos", str(demos_path), "--set", "gail.envs=1", "--set", "gail.n_steps=1", "--out",
                    str(tmp_path / "x"))
    assert result.exit_code == 2
    assert "an update must hold at least 2 decisions (gail.n_steps x gail.envs x gail.egos)" in result.output
    result = invoke("gail", "--demos", str(demos_path), "--set", "gail.critic_warmup=-1", "--out", str(tmp_path / "x"))
    assert result.exit_code == 2 and "gail.critic_warmup" in result.output and "Traceback" not in result.output


def test_gail_without_reward_normalisation_and_a_warmup_longer_than_the_run(tmp_path, demos_path):
    run = tmp_path / "run"
    result = invoke("gail", *SMALL, "--demos", str(demos_path), "--timesteps", "64", "--set", "gail.envs=1", "--set",
                    "gail.n_steps=64", "--set", "bc.epochs=1", "--set", "gail.normalize_reward=false", "--out",
                    str(run))
    assert result.exit_code == 0, result.output
    assert ("trained 1 PPO update (64 timesteps; the actor frozen in it for the critic's warm-up, so the policy is "
            "the initial one)") in result.output
    settings = json.loads((run / "run.json").read_text())["settings"]
    assert settings["normalize_reward"] is False and settings["critic_warmup"] == 5
    log = pd.read_parquet(run / "log.parquet")
    assert log["reward_std"].tolist() == [1.0] and log["actor_frozen"].tolist() == [True]
    latest, bc = load_policy(run / "policy_latest.npz")[0], load_policy(run / "policy_bc.npz")[0]
    assert np.array_equal(latest.parameters, bc.parameters)


def test_the_network_bc_discriminator_and_gail_settings_reach_the_run(tmp_path, demos_path):
    """Each section gail takes lands in run.json and the run (a dropped one fails): the policy file has the hidden
    units network.hidden asks for; the run's seed is BC's and the discriminator's."""
    run = tmp_path / "run"
    result = invoke("gail", *SMALL, "--demos", str(demos_path), "--timesteps", "32", "--set", "gail.envs=1", "--set",
                    "gail.n_steps=32", "--set", "gail.critic_warmup=0", "--set", "gail.gamma=0.9", "--set",
                    "network.hidden=7", "--set", "bc.epochs=1", "--set", "bc.class_balance=0.3", "--set",
                    "discriminator.hidden=9", "--seed", "13", "--out", str(run))
    assert result.exit_code == 0, result.output
    settings = json.loads((run / "run.json").read_text())["settings"]
    assert (settings["kind"], settings["hidden"], settings["gamma"], settings["n_steps"]) == ("mlp", 7, 0.9, 32)
    assert (settings["bc"]["epochs"], settings["bc"]["class_balance"], settings["discriminator"]["hidden"]) == (
        1, 0.3, 9)
    assert settings["seed"] == settings["bc"]["seed"] == settings["discriminator"]["seed"] == 13
    assert read_run(run, "gail").kind == "mlp (7 hidden)"
    assert load_policy(run / "policy_latest.npz")[0].shape.hidden == 7
