"""What a gail or ppo checkpoint restores: the learner's weights, Adam's state, the timestep count, the reward
normaliser and the global generators PPO draws from, exactly (on CartPole: no SUMO needed)."""

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.vec_env import DummyVecEnv

from sumo_rail.drivers.policies import PolicyShape
from sumo_rail.learning.run_folder import load_checkpoint
from sumo_rail.learning.sb3.actor import FixedNormalisation
from sumo_rail.learning.sb3.ppo import PpoSettings
from sumo_rail.learning.sb3.resume import CHECKPOINT_FORMAT, learner_checkpoint, restore_learner
from sumo_rail.learning.sb3.rewards import normalised_rewards
from sumo_rail.learning.sb3.runs import build_ppo

SETTINGS = PpoSettings(n_steps=32, envs=1, batch_size=16, ppo_epochs=2, seed=4)
SHAPE = PolicyShape("mlp", 4, 10)


def learner():
    venv = normalised_rewards(DummyVecEnv([lambda: gym.make("CartPole-v1")]), SETTINGS.gamma)
    return build_ppo(venv, SHAPE, SETTINGS)


def test_a_checkpoint_restores_the_learner_and_the_generators_exactly(tmp_path):
    model = learner()
    model.learn(64, reset_num_timesteps=False)
    normalisation = FixedNormalisation(np.arange(4.0), np.full(4, 2.0))
    torch.save(learner_checkpoint(model, normalisation, [{"iteration": 0}]), tmp_path / "checkpoint.pt")
    draws = torch.rand(3), np.random.rand(3)  # what the run would draw next
    checkpoint = load_checkpoint(tmp_path / "checkpoint.pt", CHECKPOINT_FORMAT)  # weights_only: plain values
    resumed = learner()
    assert not torch.equal(next(iter(resumed.policy.state_dict().values())),
                           next(iter(model.policy.state_dict().values())))
    restore_learner(resumed, checkpoint, tmp_path / "checkpoint.pt")
    assert torch.equal(torch.rand(3), draws[0]) and np.array_equal(np.random.rand(3), draws[1])
    for name, tensor in model.policy.state_dict().items():
        assert torch.equal(resumed.policy.state_dict()[name], tensor), name
    ours, theirs = model.policy.optimizer.state_dict(), resumed.policy.optimizer.state_dict()
    for index, state in ours["state"].items():
        for key, value in state.items():
            assert torch.equal(theirs["state"][index][key], value), (index, key)
    assert resumed.num_timesteps == model.num_timesteps == 64
    original, restored = model.get_vec_normalize_env().ret_rms, resumed.get_vec_normalize_env().ret_rms
    assert (restored.mean, restored.var, restored.count) == (original.mean, original.var, original.count)
    assert checkpoint["observation_mean"].tolist() == [0.0, 1.0, 2.0, 3.0]
