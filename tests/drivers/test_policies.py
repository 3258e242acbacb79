import pickle
import zipfile

import numpy as np
import pytest
from reliability import assert_refuses_missing_and_garbage

from sumo_rail.drivers.policies import Policy, PolicyFileError, PolicyShape, load_policy, save_policy

N = 6


def linear_choosing(action: int) -> Policy:
    shape = PolicyShape("linear", N)
    parameters = np.zeros(shape.parameter_count, dtype=np.float32)
    parameters[5 * N + action] = 1.0  # bias of `action`
    return Policy(shape, parameters)


def test_parameter_counts():
    assert PolicyShape("linear", 56).parameter_count == 5 * 56 + 5
    assert PolicyShape("mlp", 56, hidden=10).parameter_count == 10 * 56 + 10 + 5 * 10 + 5


def test_linear_policy_follows_its_weights_and_normalisation():
    assert linear_choosing(3).act(np.zeros(N)) == 3
    shape = PolicyShape("linear", N)
    weights = np.zeros((5, N), dtype=np.float32)
    weights[1, 0], weights[2, 0] = 1.0, -1.0  # feature 0 above its mean -> accelerate, below -> decelerate
    parameters = np.concatenate([weights.ravel(), np.zeros(5, dtype=np.float32)])
    policy = Policy(shape, parameters, observation_mean=np.full(N, 0.5), observation_std=np.full(N, 0.1))
    assert policy.act(np.full(N, 0.6)) == 1 and policy.act(np.full(N, 0.4)) == 2
    x = np.linspace(0, 1, N)
    assert np.allclose(policy.logits(x), weights @ ((x - 0.5) / 0.1))


def test_mlp_matches_its_documented_layout():
    shape = PolicyShape("mlp", N, hidden=3)
    rng = np.random.default_rng(0)
    parameters = rng.normal(size=shape.parameter_count).astype(np.float32)
    w1 = parameters[:3 * N].reshape(3, N)
    b1 = parameters[3 * N:3 * N + 3]
    w2 = parameters[3 * N + 3:3 * N + 3 + 15].reshape(5, 3)
    b2 = parameters[-5:]
    x = rng.normal(size=N)
    expected = w2.astype(float) @ np.tanh(w1.astype(float) @ x + b1) + b2
    policy = Policy(shape, parameters)
    assert np.allclose(policy.logits(x), expected)
    batch = rng.normal(size=(4, N))
    assert np.allclose(policy.logits(batch)[2], policy.logits(batch[2]))


def test_wrong_parameter_count_is_refused():
    with pytest.raises(ValueError, match="needs 35 parameters"):
        Policy(PolicyShape("linear", N), np.zeros(10))


def test_save_load_round_trip_is_exact_and_picklable(tmp_path):
    shape = PolicyShape("mlp", N, hidden=4)
    policy = Policy(shape, np.random.default_rng(1).normal(size=shape.parameter_count), np.arange(N), np.full(N, 2.0))
    path = tmp_path / "p.npz"
    save_policy(policy, path, {"note": "hand made"})
    loaded, metadata = load_policy(path)
    assert metadata == {"note": "hand made"}
    assert loaded.shape == shape and np.array_equal(loaded.parameters, policy.parameters)
    assert np.array_equal(loaded.observation_mean, policy.observation_mean)
    copy = pickle.loads(pickle.dumps(loaded))
    assert np.array_equal(copy.logits(np.ones(N)), policy.logits(np.ones(N)))
    assert [p.name for p in tmp_path.iterdir()] == ["p.npz"]


def test_bad_policy_files_give_one_sentence_errors(tmp_path):
    assert_refuses_missing_and_garbage(load_policy, PolicyFileError, tmp_path, ".npz", b"not a zip file at all",
                                       "not a readable")
    other = tmp_path / "other.npz"
    np.savez(other, weights=np.zeros(3))
    with pytest.raises(PolicyFileError, match="format marker"):
        load_policy(other)
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, format=np.array("sumo-rail policy"), parameters=np.array([object()], dtype=object))
    with pytest.raises(PolicyFileError):
        load_policy(pickled)
    truncated = tmp_path / "truncated.npz"
    save_policy(linear_choosing(0), truncated, {})
    truncated.write_bytes(truncated.read_bytes()[:200])
    with pytest.raises(PolicyFileError):
        load_policy(truncated)


def test_inconsistent_policy_file_is_refused(tmp_path):
    path = tmp_path / "p.npz"
    save_policy(linear_choosing(0), path, {})
    with zipfile.ZipFile(path) as archive:
        fields = {name[:-4]: np.load(archive.open(name)) for name in archive.namelist()}
    fields["observation_size"] = np.array(N + 1)
    np.savez(path, **fields)
    with pytest.raises(PolicyFileError, match="inconsistent"):
        load_policy(path)


def policy_with_biases(biases: list[float]) -> Policy:
    shape = PolicyShape("linear", N)
    parameters = np.zeros(shape.parameter_count, dtype=np.float32)
    parameters[5 * N:] = biases
    return Policy(shape, parameters)


def test_sampling_draws_from_the_softmax_of_the_logits():
    strong, flat = policy_with_biases([0, 0, 8, 0, 0]), policy_with_biases([0] * 5)
    observation = np.zeros(N)
    np.testing.assert_allclose(strong.probabilities(observation), np.exp([0, 0, 8, 0, 0]) / (4 + np.exp(8)))
    np.testing.assert_allclose(strong.probabilities(np.zeros((3, N))).sum(axis=1), 1.0)
    rng = np.random.default_rng(0)
    strong_actions = np.bincount([strong.sample(observation, rng) for _ in range(2000)], minlength=5)
    flat_actions = np.bincount([flat.sample(observation, rng) for _ in range(2000)], minlength=5)
    assert strong_actions[2] > 1980 and strong.act(observation) == 2
    assert (flat_actions > 300).all()  # every action, about 400 times each
    first = [strong.sample(observation, np.random.default_rng(5)) for _ in range(3)]
    draws = [[flat.sample(observation, generator) for _ in range(50)]
             for generator in (np.random.default_rng(5), np.random.default_rng(5), np.random.default_rng(6))]
    assert first == [2, 2, 2] and draws[0] == draws[1] != draws[2]


@pytest.mark.parametrize("temperature", [1e-6, 1e-320])
def test_sampling_at_a_tiny_temperature_draws_the_argmax(temperature):
    """Any temperature the setting allows (above 0): no overflow of logits / T into NaN probabilities."""
    policy, observation = policy_with_biases([1, 3, 3.5, 0, -2]), np.zeros(N)
    with np.errstate(invalid="raise"):  # no inf - inf
        probabilities = policy.probabilities(observation, temperature)
    np.testing.assert_array_equal(probabilities, [0, 0, 1, 0, 0])
    assert policy.sample(observation, np.random.default_rng(0), temperature) == policy.act(observation) == 2
    tied = policy_with_biases([2, 2, 0, 0, 0]).probabilities(np.zeros((2, N)), temperature)
    np.testing.assert_array_equal(tied, [[0.5, 0.5, 0, 0, 0]] * 2)
