import pytest

from sumo_rail.evaluation.recovery import CONDITIONS, RecoveryTask, ScriptedStart, in_band, recovery_tasks
from sumo_rail.runners.backends import WorkerContext
from sumo_rail.runners.rollout import ExpertDriver, KeepDriver


@pytest.fixture
def context():
    context = WorkerContext()
    yield context
    context.close()


def test_the_band_is_half_a_speed_step_around_the_desired_speed():
    assert in_band(31.5, 30.5, 2.0) and in_band(29.5, 30.5, 2.0)
    assert not in_band(31.6, 30.5, 2.0) and not in_band(33.33, 30.5, 2.0)


def test_the_expert_returns_from_the_highest_set_point_in_one_decision_and_keep_never(small_config, context):
    expert, keep = (RecoveryTask(small_config, driver, "normal", "high", seed, 0, horizon=10).run(context)
                    for driver, seed in ((ExpertDriver("normal"), 4), (KeepDriver(), 4)))
    assert expert["started"] and keep["started"] and not expert["ended"]
    # from 33.33 m/s one step of 2 m/s down is 31.33, within 30.5 +- 1
    assert expert["recovered"] and expert["decisions_to_recover"] == 1 and expert["agreement"] == 1.0
    assert not keep["recovered"] and keep["decisions_to_recover"] == 10 and keep["agreement"] == 0.0


def test_the_expert_climbs_back_from_a_low_set_point_one_step_a_decision(small_config, context):
    row = RecoveryTask(small_config, ExpertDriver("normal"), "normal", "low", 4, 1).run(context)
    assert row["started"] and row["start_decisions"] >= 3  # into the band, then three steps of 2 m/s down
    assert row["recovered"] and row["decisions_to_recover"] == 3 and row["agreement"] == 1.0


def test_left_lane_start_waits_until_the_expert_would_move_right(small_config, context):
    row = RecoveryTask(small_config, ExpertDriver("normal"), "normal", "left", 3, 2).run(context)
    assert row["started"] and row["start_decisions"] >= 5  # one lane change takes 4 decisions, then the wait
    assert row["recovered"] and row["decisions_to_recover"] == 1  # it asks for the change at once
    keep = RecoveryTask(small_config, KeepDriver(), "normal", "left", 3, 2).run(context)
    assert keep["start_decisions"] == row["start_decisions"] and keep["decisions_to_recover"] > 1


def test_tasks_cover_every_driver_condition_and_seed_and_unknown_conditions_are_refused(small_config):
    tasks = recovery_tasks(small_config, [ExpertDriver("normal"), KeepDriver()], ExpertDriver("normal"),
                           [10, 13, 16, 19])
    assert len(tasks) == 2 * len(CONDITIONS) * 4
    assert [task.warm_state for task in tasks[:4]] == [0, 1, 2, 0]  # k mod 3 snapshots
    with pytest.raises(ValueError, match="unknown start condition"):
        ScriptedStart("sideways", 30.5, small_config)
