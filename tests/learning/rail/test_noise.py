import subprocess
import sys

import numpy as np
import pytest

from sumo_rail.drivers.policies import Policy, PolicyShape
from sumo_rail.learning.rail.noise import NOISE_RANGE, direction, directions, flip_rate, noise_for_flip_rate


def test_same_integers_give_identical_bits_in_another_process():
    vector = direction(7, 3, 2, 1000)
    assert vector.dtype == np.float32 and vector.shape == (1000,)
    assert direction(7, 3, 2, 1000).tobytes() == vector.tobytes()
    code = "from sumo_rail.learning.rail.noise import direction; print(direction(7, 3, 2, 1000).tobytes().hex())"
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert other == vector.tobytes().hex()


def test_different_integers_give_different_directions():
    base = direction(7, 3, 2, 100)
    for other in (direction(8, 3, 2, 100), direction(7, 4, 2, 100), direction(7, 3, 3, 100), direction(7, 2, 3, 100)):
        assert not np.array_equal(base, other)
        assert abs(np.corrcoef(base, other)[0, 1]) < 0.4


def test_standard_normal_statistics():
    vector = direction(0, 0, 0, 200_000).astype(np.float64)
    assert abs(vector.mean()) < 0.01
    assert abs(vector.std() - 1.0) < 0.01
    assert abs(np.mean(np.abs(vector) < 1.0) - 0.6827) < 0.005


def test_rows_of_directions_equal_direction():
    rows = directions(5, 11, 4, 30)
    assert rows.shape == (4, 30) and rows.dtype == np.float32
    for index in range(4):
        assert rows[index].tobytes() == direction(5, 11, index, 30).tobytes()
    assert directions(5, 11, 0, 30).shape == (0, 30)


def test_negative_integers_are_rejected():
    with pytest.raises(ValueError, match="must not be negative"):
        direction(0, -1, 0, 3)


def flip_policy() -> tuple[Policy, np.ndarray, np.ndarray]:
    shape = PolicyShape("mlp", 6, hidden=5)
    rng = np.random.default_rng(0)
    policy = Policy(shape, rng.normal(size=shape.parameter_count).astype(np.float32))
    return policy, directions(0, 0, 8, shape.parameter_count), rng.normal(size=(400, 6))


def test_the_flip_rate_grows_with_the_perturbation_scale():
    policy, deltas, states = flip_policy()
    rates = [flip_rate(policy, deltas, nu, states) for nu in (0.0, 0.01, 0.1, 1.0)]
    assert rates[0] == 0.0 and rates == sorted(rates) and 0 < rates[1] < 0.1 and rates[3] > 0.3


@pytest.mark.parametrize("target", [0.02, 0.1, 0.3])
def test_the_noise_for_a_flip_rate_reaches_it(target):
    policy, deltas, states = flip_policy()
    nu = noise_for_flip_rate(policy, deltas, target, states)
    # the rate is a step function of nu: just below nu it is under the target, at nu at or above it
    assert flip_rate(policy, deltas, nu * 0.99, states) < target <= flip_rate(policy, deltas, nu * 1.01, states)
    with pytest.raises(ValueError, match="between 0 and 1"):
        noise_for_flip_rate(policy, deltas, 1.0, states)


def test_at_zero_weights_a_linear_policy_flips_alike_at_every_scale_and_the_search_stops_at_its_range():
    _, _, states = flip_policy()
    zero = Policy(PolicyShape("linear", 6), np.zeros(35, np.float32))
    deltas = directions(0, 0, 8, 35)
    assert flip_rate(zero, deltas, 1e-3, states) == flip_rate(zero, deltas, 1.0, states) > 0.5
    assert noise_for_flip_rate(zero, deltas, 0.05, states) == pytest.approx(NOISE_RANGE[0], rel=1e-6)
