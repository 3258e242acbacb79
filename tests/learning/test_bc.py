import numpy as np
import pytest
import torch

from sumo_rail.drivers.policies import Policy, PolicyShape
from sumo_rail.learning.bc import (
    BcSettings,
    behaviour_cloning,
    class_weights,
    policy_to_torch,
    split_episodes,
    torch_to_parameters,
    torch_to_policy,
)
from sumo_rail.runners.tables import Demonstrations

N = 12
CHOSEN = [7, 2, 9, 0, 4]  # action k is the argmax of feature CHOSEN[k]


def separable(episodes: int = 10, rows_per_episode: int = 200, seed: int = 1) -> Demonstrations:
    """Features with varied offsets and scales (one constant); action = argmax of 5 chosen, commonly scaled features."""
    rng = np.random.default_rng(seed)
    raw = rng.normal(size=(episodes * rows_per_episode, N))
    actions = np.argmax(raw[:, CHOSEN], axis=1).astype(np.int64)
    scales, offsets = rng.uniform(0.1, 10.0, N), rng.uniform(-5.0, 5.0, N)
    scales[CHOSEN], offsets[CHOSEN] = 3.0, -2.0  # a common affine map keeps the argmax
    observations = (raw * scales + offsets).astype(np.float32)
    observations[:, 11] = 3.0
    return Demonstrations(observations, actions, np.repeat(np.arange(episodes), rows_per_episode), {})


@pytest.mark.parametrize("kind", ["linear", "mlp"])
def test_conversion_preserves_logits_both_ways(kind: str):
    shape = PolicyShape(kind, N, hidden=7)
    rng = np.random.default_rng(0)
    std = rng.uniform(0.5, 2.0, N)
    std[3] = 1e-9  # below the floor: both sides must use max(std, 1e-6)
    policy = Policy(shape, rng.normal(size=shape.parameter_count), rng.normal(size=N), std)
    observations = rng.normal(size=(32, N)).astype(np.float32)
    observations[:, 3] = policy.observation_mean[3]
    network = policy_to_torch(policy)
    with torch.no_grad():
        logits = network(torch.from_numpy(observations)).numpy()
    assert np.allclose(logits, policy.logits(observations), atol=1e-5)
    assert np.array_equal(torch_to_parameters(network), policy.parameters)
    back = torch_to_policy(network)
    assert np.array_equal(back.parameters, policy.parameters)
    assert np.array_equal(back.observation_std, policy.observation_std)
    assert np.allclose(back.logits(observations), logits, atol=1e-5)


@pytest.mark.parametrize("kind", ["linear", "mlp"])
def test_bc_learns_a_separable_expert(kind: str):
    demos = separable()
    policy, report = behaviour_cloning(demos, PolicyShape(kind, N, hidden=16), BcSettings(epochs=30, batch_size=64,
                                                                                           learning_rate=1e-2))
    assert report.holdout_accuracy is not None and report.holdout_accuracy > 0.9
    assert report.train_accuracy > 0.9
    assert (report.train_rows, report.holdout_rows) == (1600, 400)
    assert len(report.losses) == 30 and report.losses[-1] < report.losses[0]
    train, _ = split_episodes(demos.episodes, 0.2, 0)
    assert np.allclose(policy.observation_mean, demos.observations[train].mean(axis=0, dtype=np.float64))
    assert policy.observation_std[11] == 1.0  # a constant feature is not blown up by the std floor
    assert policy.act(demos.observations[0]) == demos.actions[0]


def test_bc_is_deterministic_and_leaves_global_rng_alone():
    demos, shape, settings = separable(episodes=4, rows_per_episode=100), PolicyShape("mlp", N), BcSettings(epochs=3)
    rng_state, threads = torch.get_rng_state(), torch.get_num_threads()
    torch.use_deterministic_algorithms(True)
    try:
        first, first_report = behaviour_cloning(demos, shape, settings)
        second, second_report = behaviour_cloning(demos, shape, settings)
    finally:
        torch.use_deterministic_algorithms(False)
    assert np.array_equal(first.parameters, second.parameters) and first_report == second_report
    assert torch.equal(rng_state, torch.get_rng_state()) and torch.get_num_threads() == threads
    other, _ = behaviour_cloning(demos, shape, BcSettings(epochs=3, seed=1))
    assert not np.array_equal(first.parameters, other.parameters)


def test_class_weights():
    actions = torch.tensor([0] * 96 + [1] * 4)
    plain, balanced = class_weights(actions, 3, 0.0), class_weights(actions, 3, 1.0)
    assert torch.allclose(plain, torch.ones(3))
    assert balanced[1] / balanced[0] == pytest.approx(24.0) and balanced[2] == pytest.approx(balanced[0] * 96)
    half = class_weights(actions, 3, 0.5)
    assert (half[:2] * torch.tensor([96.0, 4.0])).sum() / 100 == pytest.approx(1.0)  # mean weight per row is 1


def test_class_balance_recovers_rare_actions():
    """An expert that takes action 1 in 3% of rows, where feature 0 is high but overlapping: plain BC predicts it
    less often than the expert, balanced BC more often."""
    rng = np.random.default_rng(3)
    observations = rng.normal(size=(6000, 4)).astype(np.float32)
    actions = ((observations[:, 0] + 0.7 * rng.normal(size=6000)) > 2.6).astype(np.int64)
    demos = Demonstrations(observations, actions, np.repeat(np.arange(10), 600), {})
    shape = PolicyShape("linear", 4)
    predicted = {}
    for balance in (0.0, 1.0):
        policy, _ = behaviour_cloning(demos, shape, BcSettings(epochs=30, learning_rate=1e-2, class_balance=balance))
        predicted[balance] = np.mean(np.argmax(policy.logits(observations), axis=1) == 1)
    assert predicted[0.0] < actions.mean() < predicted[1.0]


def test_holdout_is_whole_episodes_disjoint_from_training():
    episodes = np.repeat(np.array([5, 3, 9, 1, 7, 2, 8, 0, 6, 4]), np.arange(1, 11))
    train, holdout = split_episodes(episodes, 0.3, seed=4)
    assert np.all(train ^ holdout)
    assert len(np.unique(episodes[holdout])) == 3
    assert not set(episodes[train]) & set(episodes[holdout])
    assert split_episodes(episodes, 0.0, 4)[1].any()  # at least one episode held out
    assert not split_episodes(np.zeros(5), 0.2, 4)[1].any()  # a single episode: nothing held out
    assert np.array_equal(split_episodes(episodes, 0.3, 4)[1], holdout)


def test_a_single_episode_has_no_holdout_accuracy():
    demos = separable(episodes=1, rows_per_episode=50)
    _, report = behaviour_cloning(demos, PolicyShape("linear", N), BcSettings(epochs=1))
    assert report.holdout_accuracy is None and report.holdout_rows == 0 and report.train_rows == 50


def test_bc_rejects_bad_input():
    demos, shape = separable(episodes=2, rows_per_episode=5), PolicyShape("linear", N)
    with pytest.raises(ValueError, match="epochs"):
        behaviour_cloning(demos, shape, BcSettings(epochs=0))
    with pytest.raises(ValueError, match="at least one demonstration"):
        empty = Demonstrations(np.zeros((0, N), np.float32), np.zeros(0, np.int64), np.zeros(0, np.int64), {})
        behaviour_cloning(empty, shape, BcSettings())
    with pytest.raises(ValueError, match="expects"):
        behaviour_cloning(demos, PolicyShape("linear", N + 1), BcSettings())


def test_the_holdout_accuracy_comes_with_the_majority_action_baseline():
    demos = separable(episodes=4, rows_per_episode=30)
    train, holdout = split_episodes(demos.episodes, 0.2, 0)
    commonest = np.bincount(demos.actions[train]).argmax()
    _, report = behaviour_cloning(demos, PolicyShape("linear", N), BcSettings(epochs=1))
    assert report.majority_accuracy == pytest.approx(np.mean(demos.actions[holdout] == commonest))
    assert 0 < report.majority_accuracy < 1
    from sumo_rail_cli.running import bc_summary

    assert f"(majority action {report.majority_accuracy:.3f})" in bc_summary(report, "p.npz")
    _, single = behaviour_cloning(separable(episodes=1, rows_per_episode=20), PolicyShape("linear", N),
                                  BcSettings(epochs=1))
    assert single.majority_accuracy is None and "majority" not in bc_summary(single, "p.npz")


def test_the_holdout_accuracy_is_the_decoded_actions_beside_the_argmaxs():
    """Drivers who hold their speed (bin 24, 0 m/s^2) at 0.4 and speed up gently at 0.6 where feature 0 is positive:
    the argmax holds the speed, the expected decoding speeds up; the report scores the decoded action, the argmax's
    beside it, and a policy decoding by argmax reports no second accuracy."""
    rng = np.random.default_rng(3)
    observations = rng.normal(size=(2000, N)).astype(np.float32)
    gentle = rng.choice([24, 27, 28], size=2000, p=[0.4, 0.35, 0.25])
    actions = np.where(observations[:, 0] > 0, gentle, 24).astype(np.int64)
    demos = Demonstrations(observations, actions, np.repeat(np.arange(10), 200), {})
    settings = BcSettings(epochs=5, learning_rate=1e-2, class_balance=0.0)
    policy, report = behaviour_cloning(demos, PolicyShape("linear", N, actions=111, decoding="expected"), settings)
    _, holdout = split_episodes(demos.episodes, 0.2, 0)
    decoded, argmax = policy.acts(observations[holdout]), np.argmax(policy.logits(observations[holdout]), axis=1)
    assert np.any(decoded != argmax)
    assert report.holdout_accuracy == pytest.approx(np.mean(decoded == actions[holdout]))
    assert report.argmax_holdout_accuracy == pytest.approx(np.mean(argmax == actions[holdout]))
    from sumo_rail_cli.running import bc_summary

    assert f", by the logits' argmax {report.argmax_holdout_accuracy:.3f}" in bc_summary(report, "p.npz")
    same, by_argmax = behaviour_cloning(demos, PolicyShape("linear", N, actions=111), settings)
    assert by_argmax.argmax_holdout_accuracy is None and by_argmax.holdout_accuracy == report.argmax_holdout_accuracy
    assert np.array_equal(same.parameters, policy.parameters)  # the decoding changes no weight
