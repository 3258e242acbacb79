import numpy as np
import pandas as pd
import pytest

from sumo_rail.evaluation.distributions import DISTANCE_COLUMNS, distance_table, distances


def records(speed, headway, lanes, actions) -> pd.DataFrame:
    count = len(speed)
    return pd.DataFrame({"speed_mps": speed, "set_point_mps": speed, "headway_s": headway, "lane": lanes,
                         "action": actions, "accepted_front_gap_m": np.full(count, np.nan),
                         "accepted_rear_gap_m": np.full(count, np.nan)})


def test_distances_of_shifted_and_reshuffled_behaviour():
    rng = np.random.default_rng(0)
    speed = rng.uniform(20, 30, 400)
    expert = records(speed, np.r_[rng.uniform(1, 3, 300), [np.nan] * 100], np.repeat([0, 1], 200),
                     np.zeros(400, int))
    driver = records(speed + 2.0, np.r_[rng.uniform(1, 3, 200), [np.nan] * 200], np.repeat([1, 2], 200),
                     np.repeat([0, 3], 200))
    found = distances(driver, expert, lanes=5)
    assert found["speed_w1_kmh"] == pytest.approx(2.0 * 3.6)   # a shift moves all mass by the shift
    assert found["set_point_w1_kmh"] == pytest.approx(7.2)
    assert found["no_leader_share_difference"] == pytest.approx(0.5 - 0.25)
    assert found["lane_tv"] == pytest.approx(0.5)                 # half the decisions moved one lane up
    assert found["action_tv"] == pytest.approx(0.5)
    assert np.isnan(found["accepted_front_gap_w1_m"])            # no accepted lane changes to compare
    assert distances(expert, expert, lanes=5)["lane_tv"] == 0.0


def test_distance_table_has_a_row_per_other_driver():
    frame = records(np.arange(10.0), np.ones(10), np.zeros(10, int), np.zeros(10, int))
    decisions = pd.concat([frame.assign(policy="expert-normal"), frame.assign(policy="bc")], ignore_index=True)
    table = distance_table(decisions, "expert-normal", lanes=5)
    assert table.index.tolist() == ["bc"] and table.columns.tolist() == list(DISTANCE_COLUMNS)
    assert table.loc["bc", "speed_w1_kmh"] == 0.0
    with pytest.raises(ValueError, match="reference driver 'expert-calm'"):
        distance_table(decisions, "expert-calm", lanes=5)


def test_lane_shares_count_an_acceleration_lane_or_ramp_below_lane_0():
    import pandas as pd

    from sumo_rail.evaluation.distributions import _total_variation

    on_ramp_then_lane_0 = pd.Series([-1, -1, 0, 0])
    assert _total_variation(on_ramp_then_lane_0, pd.Series([0, 0, 0, 0]), 5) == 0.5
    assert _total_variation(on_ramp_then_lane_0, on_ramp_then_lane_0, 5) == 0.0


def test_a_decision_summary_holds_the_distance_table_and_the_histograms(tmp_path):
    """What docs/results commits in place of the records (issue 45): the same distances after a parquet round trip,
    and each driver's histogram counts and lane shares."""
    from sumo_rail.evaluation.distributions import SPEED_BINS_KMH, decision_summary, summary_distances

    rng = np.random.default_rng(1)
    frames = [records(rng.uniform(20, 35, 300), np.r_[rng.uniform(0.5, 12, 250), [np.nan] * 50],
                      rng.integers(0, 3, 300), rng.integers(0, 5, 300)).assign(policy=name)
              for name in ("bc", "expert-normal", "dagger")]
    decisions = pd.concat(frames, ignore_index=True)
    decision_summary(decisions, "expert-normal", lanes=3).to_parquet(tmp_path / "summary.parquet")
    summary = pd.read_parquet(tmp_path / "summary.parquet")
    pd.testing.assert_frame_equal(summary_distances(summary, "expert-normal"),
                                  distance_table(decisions, "expert-normal", lanes=3), check_exact=True)
    assert summary.index.tolist() == ["bc", "expert-normal", "dagger"]
    speed_bins = [f"speed_bin_{k}" for k in range(len(SPEED_BINS_KMH) - 1)]
    assert (summary[speed_bins].sum(axis=1) == 300).all()
    assert summary.loc["bc", [f"lane_{k}" for k in range(3)]].sum() == pytest.approx(1.0)
    with pytest.raises(ValueError, match="reference driver 'expert-calm'"):
        summary_distances(summary, "expert-calm")
