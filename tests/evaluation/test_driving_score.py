import numpy as np
import pandas as pd
import pytest

from sumo_rail.config import EnvConfig
from sumo_rail.evaluation.driving_score import (
    MAX_OVERSPEED_MPS,
    MIN_LON_ACCEL_MPS2,
    SCORE_COLUMNS,
    driving_scores,
    mean_overspeed,
    reference_distances,
)
from sumo_rail.evaluation.evaluate import evaluate
from sumo_rail.evaluation.summary import intervals
from sumo_rail.recordings.actions import ego_limits
from sumo_rail.runners.backends import SerialBackend
from sumo_rail.runners.rollout import ExpertDriver, KeepDriver
from sumo_rail.seeding import Purpose, episode_seeds


def _episode(**changes) -> dict:
    clean = {"policy": "learner", "episode": 0, "seed": 1, "collisions": 0, "missed_exits": 0, "lane_end_stops": 0,
             "distance_m": 1000.0, "min_ttc_s": 5.0, "hard_braking": 0, "jerk_mean_mps3": 1.0, "reference": "expert"}
    return clean | changes


def _scores(rows: list[dict], reference_m: float = 1000.0, overspeed: float = 0.0) -> pd.DataFrame:
    return driving_scores(pd.DataFrame(rows), np.full(len(rows), reference_m), np.full(len(rows), overspeed))


def test_a_clean_episode_scores_one_and_each_gate_zeroes_it():
    gates = [_episode(collisions=1), _episode(missed_exits=1), _episode(lane_end_stops=1),
             _episode(distance_m=150.0)]  # progress 0.15 < 0.2: not making progress
    scores = _scores([_episode(), *gates])
    assert scores.columns.tolist() == list(SCORE_COLUMNS)
    assert scores["driving_score"].tolist() == [1.0, 0.0, 0.0, 0.0, 0.0]
    off = driving_scores(pd.DataFrame([_episode(off_road=True)]), np.array([1000.0]), np.array([0.0]))
    assert off["driving_score"].item() == 0.0 and off["on_road"].item() == 0.0


def test_in_a_recorded_scene_only_collisions_the_ego_caused_zero_the_score():
    """A replayed vehicle running into the ego from behind is not the ego's fault (nuPlan's at-fault gate)."""
    rows = [_episode(collisions=1, at_fault_collisions=0), _episode(collisions=1, at_fault_collisions=1)]
    assert _scores(rows)["no_collision"].tolist() == [1.0, 0.0]


def test_weighted_terms_count_with_nuplans_weights():
    rows = [_episode(distance_m=500.0),  # progress 0.5: (5 x 0.5 + 11) / 16
            _episode(min_ttc_s=0.9),  # TTC below 0.95 s: (5 + 0 + 4 + 2) / 16
            _episode(hard_braking=1),  # uncomfortable: 14 / 16
            _episode(jerk_mean_mps3=4.2),  # mean jerk above 4.13 m/s^3: 14 / 16
            _episode(distance_m=1500.0)]  # beyond the reference: capped at 1
    assert _scores(rows)["driving_score"].to_numpy() == pytest.approx([13.5 / 16, 11 / 16, 14 / 16, 14 / 16, 1.0])
    half_over = _scores([_episode()], overspeed=MAX_OVERSPEED_MPS / 2)
    assert half_over["speed_limit_compliance"].item() == pytest.approx(0.5)
    assert half_over["driving_score"].item() == pytest.approx((5 + 5 + 4 * 0.5 + 2) / 16)
    assert _scores([_episode()], reference_m=0.0)["progress"].item() == 1.0  # a reference that did not move



def test_the_default_hard_braking_threshold_is_nuplans_comfort_limit():
    """`comfortable` reads nuPlan's min_lon_accel through the env's hard-braking count: by default that count's
    threshold is nuPlan's limit (within 0.05 m/s^2), beyond the ego's full ACC deceleration, so that a set-point step
    down closed by the ACC is not hard braking."""
    threshold_mps2 = EnvConfig().hard_brake_mps2
    assert threshold_mps2 == pytest.approx(-MIN_LON_ACCEL_MPS2, abs=0.05)
    assert threshold_mps2 > ego_limits()[1]

def test_reference_is_the_named_expert_on_the_same_seed_else_the_best():
    metrics = pd.DataFrame([_episode(policy="expert", seed=1, distance_m=800.0, reference="expert"),
                            _episode(policy="learner", seed=1, distance_m=900.0),
                            _episode(policy="learner", seed=2, distance_m=700.0),
                            _episode(policy="keep", seed=2, distance_m=750.0, reference=None)])
    assert reference_distances(metrics).tolist() == [800.0, 800.0, 750.0, 750.0]


def test_mean_overspeed_over_each_episodes_decisions():
    decisions = pd.DataFrame({"policy": ["a", "a", "a", "a", "b"], "episode": [0, 0, 0, 0, 0],
                              "speed_mps": [30.0, 34.0, 36.0, 20.0, 40.0]})
    metrics = pd.DataFrame({"policy": ["a", "b", "c"], "episode": [0, 0, 0]})
    assert mean_overspeed(decisions, metrics, 33.0).tolist() == pytest.approx([1.0, 7.0, 0.0])


def test_the_summary_shows_the_score_beside_its_parts():
    rows = [_episode(episode=k, seed=k, collisions=int(k == 0)) for k in range(4)]
    frame = pd.DataFrame(rows)
    frame[list(SCORE_COLUMNS)] = _scores(rows)
    found = intervals(frame).set_index("measure")
    assert found.loc["driving_score", "estimate"] == pytest.approx(0.75)
    assert found.loc["no_collision", "estimate"] == pytest.approx(0.75)


def test_evaluate_scores_every_episode_against_the_expert_on_its_seed(small_config):
    with SerialBackend() as backend:
        metrics = evaluate([ExpertDriver("normal"), KeepDriver()], small_config,
                           episode_seeds(Purpose.EVALUATE, 0, 2), backend).metrics
    expert, keep = (metrics[metrics["policy"] == name].reset_index(drop=True) for name in ("expert-normal", "keep"))
    assert expert["progress"].tolist() == [1.0, 1.0]  # its own reference
    ratio = np.minimum(keep["distance_m"] / expert["distance_m"], 1.0)
    assert keep["progress"].to_numpy() == pytest.approx(ratio.to_numpy())
    assert metrics["driving_score"].between(0.0, 1.0).all()
