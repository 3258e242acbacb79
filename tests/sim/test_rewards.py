import numpy as np
import pytest

from sumo_rail.sim.rewards import (
    AHEAD,
    ALONGSIDE,
    BEHIND,
    OvertakeCounter,
    lateral_reward,
    longitudinal_reward,
    relations,
)


def test_longitudinal_reward_is_normalised_speed_clipped():
    assert longitudinal_reward(20.0, 10.0, 30.0) == pytest.approx(0.5)
    assert longitudinal_reward(5.0, 10.0, 30.0) == 0.0
    assert longitudinal_reward(35.0, 10.0, 30.0) == 1.0


def test_lateral_reward_only_while_changing():
    assert lateral_reward(True, -0.5) == -0.5
    assert lateral_reward(False, -0.5) == 0.0


def test_relations_use_bumpers():
    # ego front at 100 m, length 5 -> rear at 95 m
    fronts = np.array([106.0, 104.0, 94.0, 96.0])
    lengths = np.array([5.0, 5.0, 5.0, 5.0])
    assert relations(100.0, 5.0, fronts, lengths) == [AHEAD, ALONGSIDE, BEHIND, ALONGSIDE]


def counter_sequence(states):
    counter = OvertakeCounter()
    new = [counter.update(tuple(ids), rel) for ids, rel in states]
    return counter, new


def test_ahead_then_alongside_then_behind_is_one_overtake():
    counter, new = counter_sequence([(["a"], [AHEAD]), (["a"], [ALONGSIDE]), (["a"], [BEHIND]), (["a"], [BEHIND])])
    assert new == [0, 0, 1, 0] and counter.overtakes == 1 and counter.overtaken == 0


def test_falling_back_alongside_is_no_overtake_and_being_passed_counts_separately():
    counter, new = counter_sequence([(["a", "b"], [AHEAD, BEHIND]), (["a", "b"], [ALONGSIDE, ALONGSIDE]),
                                     (["a", "b"], [AHEAD, AHEAD])])
    assert sum(new) == 0 and counter.overtakes == 0 and counter.overtaken == 1


def test_vehicles_first_seen_behind_or_lost_from_view_do_not_count():
    _, new = counter_sequence([(["a"], [BEHIND]), (["b"], [AHEAD]), ([], []), (["a", "b"], [BEHIND, BEHIND])])
    assert new == [0, 0, 0, 1]


def test_repeated_passes_count_each_time():
    counter, _ = counter_sequence([(["a"], [AHEAD]), (["a"], [BEHIND]), (["a"], [AHEAD]), (["a"], [BEHIND])])
    assert counter.overtakes == 2 and counter.overtaken == 1
