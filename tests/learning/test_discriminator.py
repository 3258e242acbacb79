from pathlib import Path

import numpy as np
import pytest
import torch

from sumo_rail.learning.discriminator import Discriminator, DiscriminatorSettings, lsgan_loss

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
