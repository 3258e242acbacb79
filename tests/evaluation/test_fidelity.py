import numpy as np
import pytest
from scenes import decided, view

from sumo_rail.drivers.expert import make_expert
from sumo_rail.evaluation.evaluate import evaluate
from sumo_rail.evaluation.fidelity import CONFUSION_COLUMNS, HEADWAY_CAP_S, AgreementObserver, rates
from sumo_rail.runners.backends import SerialBackend
from sumo_rail.runners.rollout import ExpertDriver, KeepDriver, RandomDriver
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.actions import Action


def test_rates_of_a_hand_made_confusion_matrix():
    confusion = np.zeros((5, 5), dtype=int)
    confusion[Action.KEEP, Action.KEEP] = 6             # agree
    confusion[Action.KEEP, Action.ACCELERATE] = 2       # same lane, set-point held instead of raised
    confusion[Action.LANE_LEFT, Action.LANE_LEFT] = 1   # the change the expert wanted
    confusion[Action.KEEP, Action.LANE_LEFT] = 3        # missed changes
    confusion[Action.LANE_RIGHT, Action.KEEP] = 2       # changes the expert would not make
    confusion[Action.DECELERATE, Action.ACCELERATE] = 1
    # 15 decisions; 7 on the diagonal; expert changes lanes 4 times, driver 3 times, 1 match.
    # Lateral parts agree unless one changes lanes and the other does not: 15 - 3 - 2 = 10.
    # Longitudinal parts agree unless set-point moves differ: 15 - 2 (hold vs up) - 1 (down vs up) = 12.
    assert rates(confusion) == pytest.approx({"agreement": 7 / 15, "lane_change_recall": 1 / 4,
                                              "lane_change_precision": 1 / 3, "lateral_agreement": 10 / 15,
                                              "longitudinal_agreement": 12 / 15})
    assert np.isnan(rates(np.eye(5, dtype=int) * [1, 1, 1, 0, 0])["lane_change_recall"])


def test_the_observer_asks_the_expert_without_acting_and_records_behaviour():
    expert = make_expert("normal", speed_step_mps=2.0)
    observer = AgreementObserver(expert)
    slow_leader = view([(1, 1040.0, 12.0, 22.0)], speed=24.0, set_point=30.0)   # the expert would go left
    open_road = view([], lane=0, speed=25.0, set_point=20.0)                      # the expert would accelerate
    assert expert.decide(slow_leader) is Action.LANE_LEFT and expert.decide(open_road) is Action.ACCELERATE
    observer(decided(slow_leader, Action.LANE_LEFT, {"lane_change_in_progress": True}))
    observer(decided(open_road, Action.KEEP, {"lane_change_in_progress": False}))
    columns = observer.episode_columns()
    assert columns["confusion_lane_left_lane_left"] == 1 and columns["confusion_keep_accelerate"] == 1
    assert sum(columns[name] for name in CONFUSION_COLUMNS) == 2
    assert columns["agreement"] == 0.5 and columns["lane_change_recall"] == 1.0
    assert columns["lateral_agreement"] == 1.0 and columns["longitudinal_agreement"] == 0.5
    decisions = observer.decision_columns()
    assert decisions["action"].tolist() == [3, 0] and decisions["expert_action"].tolist() == [3, 1]
    assert decisions["headway_s"][0] == pytest.approx((1040.0 - 12.0 - 1000.0) / 24.0)
    assert np.isnan(decisions["headway_s"][1])  # nobody ahead
    assert np.isnan(decisions["accepted_front_gap_m"]).all()  # nobody in the left lane to measure a gap to
    far = AgreementObserver(expert)
    far(decided(view([(1, 1300.0, 4.5, 20.0)], speed=5.0), Action.KEEP, {}))  # 295.5 m at 5 m/s: 59 s, capped
    assert far.decision_columns()["headway_s"][0] == HEADWAY_CAP_S


def test_accepted_gap_is_the_target_lanes_gap_when_the_change_starts():
    observer = AgreementObserver(make_expert("normal", speed_step_mps=2.0))
    traffic = view([(2, 1060.0, 4.5, 30.0), (2, 950.0, 4.5, 28.0)], lane=1, speed=25.0)
    observer(decided(traffic, Action.LANE_LEFT, {"lane_change_in_progress": True}))
    observer(decided(traffic, Action.LANE_LEFT, {"lane_change_in_progress": False}))  # refused: no gap
    decisions = observer.decision_columns()
    assert decisions["accepted_front_gap_m"][0] == pytest.approx(1060.0 - 4.5 - 1000.0)
    assert decisions["accepted_rear_gap_m"][0] == pytest.approx(1000.0 - 4.5 - 950.0)
    assert np.isnan(decisions["accepted_front_gap_m"][1])


def test_expert_agrees_with_itself_and_keep_and_random_score_what_is_counted_by_hand(small_config):
    seeds = episode_seeds(Purpose.EVALUATE, 5, 2)
    with SerialBackend() as backend:
        evaluation = evaluate([ExpertDriver("normal"), KeepDriver(), RandomDriver()], small_config, seeds, backend)
    metrics, decisions = evaluation.metrics, evaluation.decisions
    expert = metrics[metrics["policy"] == "expert-normal"]
    confusion = expert[list(CONFUSION_COLUMNS)].to_numpy().reshape(-1, 5, 5)
    assert (expert["agreement"] == 1.0).all() and (confusion.sum(axis=(1, 2)) == expert["steps"]).all()
    assert all(np.count_nonzero(matrix - np.diag(np.diag(matrix))) == 0 for matrix in confusion)
    for name in ("keep", "random"):
        ours = decisions[decisions["policy"] == name]
        rows = metrics[metrics["policy"] == name]
        for episode, frame in ours.groupby("episode"):
            agree = (frame["action"] == frame["expert_action"]).mean()
            assert rows[rows["episode"] == episode]["agreement"].item() == pytest.approx(agree)
    keep = decisions[decisions["policy"] == "keep"]
    assert (keep["action"] == 0).all()
    assert metrics[metrics["policy"] == "keep"]["lane_change_precision"].isna().all()  # it never changes lanes
    random = decisions[decisions["policy"] == "random"]
    for episode, seed in enumerate(seeds):  # the random driver's actions are its seeded generator's draws
        drawn = np.random.default_rng(seed).integers(5, size=(random["episode"] == episode).sum())
        assert random[random["episode"] == episode]["action"].tolist() == drawn.tolist()
