from pathlib import Path

import numpy as np
import pytest
import torch

from sumo_rail.learning.rail.discriminator import Discriminator, DiscriminatorSettings, lsgan_loss

N = 8


def pairs(rows: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Expert pairs (centred observations, action = sign of feature 0 -> 1 or 2) and policy pairs (shifted
    observations, uniform actions), each (rows, N) float32 and (rows,) int64."""
    rng = np.random.default_rng(seed)
    expert = rng.normal(size=(rows, N)).astype(np.float32)
    policy = (rng.normal(size=(rows, N)) + np.linspace(-2.0, 2.0, N)).astype(np.float32)
    return expert, np.where(expert[:, 0] > 0, 1, 2), policy, rng.integers(0, 5, rows)


def make(settings: DiscriminatorSettings | None = None) -> Discriminator:
    stats = np.random.default_rng(9)
    return Discriminator(N, stats.normal(size=N), stats.uniform(0.5, 2.0, N), settings or DiscriminatorSettings())


def test_training_separates_expert_from_policy_pairs():
    data = pairs(2000, seed=0)
    discriminator = make(DiscriminatorSettings(learning_rate=3e-3))
    first = discriminator.train(*data)
    for _ in range(9):
        report = discriminator.train(*data)
    assert report.accuracy > 0.9 and report.loss < first.loss
    expert, expert_actions, policy, policy_actions = pairs(500, seed=1)  # fresh pairs of both distributions
    expert_reward = discriminator.reward(expert, expert_actions)
    policy_reward = discriminator.reward(policy, policy_actions)
    assert expert_reward.dtype == np.float64 and expert_reward.shape == (500,)
    assert expert_reward.mean() > policy_reward.mean() + 1.0
    assert np.mean(discriminator.probability(expert, expert_actions) > 0.5) > 0.9


def test_reward_is_the_clipped_log_odds():
    expert, actions, _, _ = pairs(64, seed=2)
    discriminator = make()
    d = discriminator.probability(expert, actions)
    assert d.dtype == np.float64 and np.all((d > 0) & (d < 1))
    clipped = np.clip(d, 1e-3, 1 - 1e-3)
    assert np.allclose(discriminator.reward(expert, actions), np.log(clipped) - np.log(1 - clipped), rtol=1e-12)
    bound = np.log((1 - 1e-3) / 1e-3)
    for bias, expected in ((1e4, bound), (-1e4, -bound)):  # saturate D at 1 and at 0
        state = discriminator.state()
        state["model"]["4.weight"].zero_()
        state["model"]["4.bias"].fill_(bias)
        discriminator.load_state(state)
        reward = discriminator.reward(expert, actions)
        assert np.all(np.isfinite(reward)) and np.allclose(reward, expected, rtol=1e-9)


def test_lsgan_loss_matches_a_hand_computation():
    d_expert, d_policy = torch.tensor([0.9, 0.5]), torch.tensor([0.2, 0.6, 0.0])
    expected = 0.5 * (0.1**2 + 0.5**2) / 2 + 0.5 * (0.2**2 + 0.6**2 + 0.0) / 3
    assert float(lsgan_loss(d_expert, d_policy)) == pytest.approx(expected, rel=1e-6)
    assert float(lsgan_loss(torch.ones(3), torch.zeros(2))) == 0.0


def test_training_is_deterministic():
    data = pairs(300, seed=3)
    first, second = make(DiscriminatorSettings(batch_size=64)), make(DiscriminatorSettings(batch_size=64))
    rng_state = torch.get_rng_state()
    assert first.train(*data) == second.train(*data)
    assert torch.equal(rng_state, torch.get_rng_state())
    assert np.array_equal(first.probability(*data[:2]), second.probability(*data[:2]))
    other = make(DiscriminatorSettings(batch_size=64, seed=1))
    assert not np.array_equal(other.probability(*data[:2]), first.probability(*data[:2]))


def test_resume_from_a_saved_state_is_bit_identical(tmp_path: Path):
    data = pairs(300, seed=4)
    settings = DiscriminatorSettings(batch_size=64)
    uninterrupted, interrupted = make(settings), make(settings)
    uninterrupted.train(*data)
    interrupted.train(*data)
    torch.save(interrupted.state(), tmp_path / "discriminator.pt")
    interrupted.train(*data)  # must not leak into the saved state
    resumed = make(settings)
    resumed.load_state(torch.load(tmp_path / "discriminator.pt", weights_only=True))
    reports = [uninterrupted.train(*data), uninterrupted.train(*data)]
    assert [resumed.train(*data), resumed.train(*data)] == reports
    for name, tensor in uninterrupted.state()["model"].items():
        assert torch.equal(tensor, resumed.state()["model"][name])
    assert np.array_equal(uninterrupted.reward(*data[:2]), resumed.reward(*data[:2]))


def test_bad_input_is_rejected():
    with pytest.raises(ValueError, match="reward_clip"):
        make(DiscriminatorSettings(reward_clip=0.5))
    discriminator = make()
    with pytest.raises(ValueError, match="shape"):
        discriminator.reward(np.zeros((3, N + 1)), np.zeros(3, np.int64))
    with pytest.raises(ValueError, match="actions must be in"):
        discriminator.reward(np.zeros((1, N)), np.array([5]))


def test_the_contrast_reward_removes_what_depends_on_the_state_alone():
    expert, actions, policy, _ = pairs(400, seed=5)
    plain = make(DiscriminatorSettings(learning_rate=3e-3))
    contrast = make(DiscriminatorSettings(learning_rate=3e-3, reward_form="contrast"))
    for discriminator in (plain, contrast):
        for _ in range(5):
            discriminator.train(expert, actions, policy, np.random.default_rng(0).integers(0, 5, 400))
    every = np.tile(np.arange(5), 400)
    states = np.repeat(policy, 5, axis=0)
    contrasts = contrast.reward(states, every).reshape(400, 5)
    logits = plain.reward(states, every).reshape(400, 5)  # same seed and data: the same network
    np.testing.assert_allclose(contrasts.sum(axis=1), 0.0, atol=1e-9)
    np.testing.assert_allclose(contrasts, logits - logits.mean(axis=1, keepdims=True), rtol=1e-9, atol=1e-9)
    assert np.all(contrasts >= contrast.lowest_reward()) and np.all(logits >= plain.lowest_reward())
    saturated = make(DiscriminatorSettings(reward_form="contrast"))
    state = saturated.state()
    state["model"]["4.weight"][:] = 0.0
    state["model"]["4.bias"][:] = 0.0
    state["model"]["0.weight"][:] = 0.0
    state["model"]["0.bias"][:] = 0.0
    # one hidden unit per action: D of action 0 is clipped low, every other action's high (first layer: one-hot)
    state["model"]["0.weight"][0, N] = 1.0
    state["model"]["2.weight"][:] = 0.0
    state["model"]["2.bias"][:] = 0.0
    state["model"]["2.weight"][0, 0] = 1.0
    state["model"]["4.weight"][0, 0] = -1e5
    state["model"]["4.bias"][0] = 1e4
    saturated.load_state(state)
    assert saturated.reward(policy[:1], np.array([0]))[0] == pytest.approx(saturated.lowest_reward())


def test_balanced_minibatches_teach_the_rare_action_of_the_expert():
    """The expert takes action 3 on 2% of its states, the policy never; only a balanced discriminator learns to
    reward it there within a few steps."""
    rng = np.random.default_rng(6)
    observations = rng.normal(size=(3000, N)).astype(np.float32)
    expert_actions = np.where(np.arange(3000) % 50 == 0, 3, 0)
    rewards = {}
    for balance in (0.0, 1.0):
        discriminator = make(DiscriminatorSettings(learning_rate=3e-3, balance=balance, batch_size=128))
        for _ in range(3):
            discriminator.train(observations, expert_actions, observations, np.zeros(3000, np.int64))
        rewards[balance] = discriminator.reward(observations[:200], np.full(200, 3)).mean()
    assert rewards[1.0] > rewards[0.0] + 0.5


def test_the_gradient_penalty_keeps_the_discriminator_smoother_at_expert_pairs():
    data = pairs(1000, seed=7)

    def slope(penalty: float) -> float:
        discriminator = make(DiscriminatorSettings(learning_rate=3e-3, gradient_penalty=penalty))
        for _ in range(10):
            discriminator.train(*data)
        step = np.zeros(N, np.float32)
        step[0] = 0.05
        return float(np.abs(discriminator.reward(data[0] + step, data[1]) - discriminator.reward(*data[:2])).mean())

    assert slope(10.0) < 0.5 * slope(0.0)


def test_replay_trains_on_the_previous_calls_policy_pairs_too(tmp_path: Path):
    first, second = pairs(300, seed=8), pairs(300, seed=9)
    replayed, current = make(DiscriminatorSettings(replay=2)), make(DiscriminatorSettings(replay=1))
    for discriminator in (replayed, current):
        discriminator.train(*first)
    assert np.array_equal(replayed.probability(*first[:2]), current.probability(*first[:2]))  # nothing to replay yet
    replayed.train(*second)
    current.train(*second)
    assert not np.array_equal(replayed.probability(*second[:2]), current.probability(*second[:2]))
    torch.save(replayed.state(), tmp_path / "state.pt")
    resumed = make(DiscriminatorSettings(replay=2))
    resumed.load_state(torch.load(tmp_path / "state.pt", weights_only=True))
    assert resumed.train(*first) == replayed.train(*first)  # the replayed pairs are part of the state


def test_new_settings_are_checked():
    for settings, words in (({"reward_form": "softmax"}, "discriminator.reward_form must be one of logit, contrast"),
                            ({"balance": -1.0}, "discriminator.balance must be between 0 and 10"),
                            ({"replay": 0}, "discriminator.replay must be between 1 and")):
        with pytest.raises(ValueError, match=words):
            DiscriminatorSettings(**settings)
