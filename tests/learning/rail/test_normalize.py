import numpy as np
import pytest

from sumo_rail.learning.rail.normalize import RunningStats


def batches(seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.normal(loc=[0.0, 100.0, -5.0], scale=[1.0, 20.0, 0.01], size=(size, 3)) for size in (1, 7, 50, 13)]


def merged(parts: list[np.ndarray]) -> RunningStats:
    stats = RunningStats.empty(3)
    for part in parts:
        stats = stats.merge(RunningStats.of(part))
    return stats


def test_merge_of_batches_equals_stats_of_concatenation():
    parts = batches()
    whole = np.concatenate(parts)
    stats = merged(parts)
    assert stats.count == len(whole)
    np.testing.assert_allclose(stats.mean, whole.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(stats.std, whole.std(axis=0), rtol=1e-10)
    tree = RunningStats.of(parts[0]).merge(RunningStats.of(parts[1])).merge(
        RunningStats.of(parts[2]).merge(RunningStats.of(parts[3])))
    np.testing.assert_allclose(tree.m2, RunningStats.of(whole).m2, rtol=1e-10)


def test_merging_with_empty_is_identity():
    stats = RunningStats.of(batches()[2])
    for result in (stats.merge(RunningStats.empty(3)), RunningStats.empty(3).merge(stats)):
        assert result.count == stats.count
        assert np.array_equal(result.mean, stats.mean) and np.array_equal(result.m2, stats.m2)
    assert RunningStats.of(np.zeros((0, 3))).count == 0


def test_merge_is_deterministic_and_pure():
    first, second = merged(batches()), merged(batches())
    assert first.mean.tobytes() == second.mean.tobytes() and first.m2.tobytes() == second.m2.tobytes()
    part = RunningStats.of(batches()[1])
    before = part.to_arrays()
    part.merge(RunningStats.of(batches()[2]))
    assert all(np.array_equal(before[key], value) for key, value in part.to_arrays().items())
    with pytest.raises(ValueError):
        part.mean[0] = 1.0  # read-only


def test_std_floor():
    assert np.array_equal(RunningStats.empty(3).std, np.ones(3))
    assert np.array_equal(RunningStats.of(np.array([[1.0, 2.0, 3.0]])).std, np.ones(3))  # count < 2
    stats = RunningStats.of(np.array([[5.0, 0.0, 1.0], [5.0, 2.0, 1.0 + 1e-10]]))
    np.testing.assert_allclose(stats.std, [1.0, 1.0, 1.0])  # constant, std 1 exactly, std ~5e-11
    assert RunningStats.of(np.array([[0.0], [4.0]])).std[0] == 2.0  # population std
    assert RunningStats.of(np.array([[0.0], [4e-6]])).std[0] == pytest.approx(2e-6)  # just above the floor
    assert RunningStats.of(np.array([[0.0], [1e-6]])).std[0] == 1.0  # just below it


def test_array_round_trip_is_exact(tmp_path):
    stats = merged(batches())
    arrays = stats.to_arrays()
    assert arrays["count"].dtype == np.int64 and arrays["count"].shape == ()
    np.savez(tmp_path / "stats.npz", **arrays)
    with np.load(tmp_path / "stats.npz", allow_pickle=False) as archive:
        restored = RunningStats.from_arrays(archive)
    assert restored.count == stats.count
    assert restored.mean.tobytes() == stats.mean.tobytes() and restored.m2.tobytes() == stats.m2.tobytes()


def test_invalid_inputs():
    with pytest.raises(ValueError, match="same shape"):
        RunningStats(1, np.zeros(2), np.zeros(3))
    with pytest.raises(ValueError, match="sizes 3 and 2"):
        RunningStats.empty(3).merge(RunningStats.empty(2))
    with pytest.raises(ValueError, match=r"shape \(B, n\)"):
        RunningStats.of(np.zeros(3))
    with pytest.raises(ValueError, match="lack"):
        RunningStats.from_arrays({"mean": np.zeros(2), "m2": np.zeros(2)})
    with pytest.raises(ValueError, match="0-d integer"):
        RunningStats.from_arrays({"count": np.array(2.0), "mean": np.zeros(2), "m2": np.zeros(2)})
