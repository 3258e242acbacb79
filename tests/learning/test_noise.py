import subprocess
import sys

import numpy as np
import pytest

from sumo_rail.learning.noise import direction, directions


def test_same_integers_give_identical_bits_in_another_process():
    vector = direction(7, 3, 2, 1000)
    assert vector.dtype == np.float32 and vector.shape == (1000,)
    assert direction(7, 3, 2, 1000).tobytes() == vector.tobytes()
    code = "from sumo_rail.learning.noise import direction; print(direction(7, 3, 2, 1000).tobytes().hex())"
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
