import pytest

from sumo_rail.evaluation.evaluate import evaluate
from sumo_rail.runners.backends import SerialBackend
from sumo_rail.runners.record import record_demonstrations
from sumo_rail.runners.rollout import EpisodeGroupTask, ExpertDriver, KeepDriver
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.env import HighwayEnv


class WatchingBackend(SerialBackend):
    """Runs tasks serially and keeps them, to see where each episode starts."""

    def __init__(self) -> None:
        super().__init__()
        self.tasks = []

    def run(self, tasks, on_result=None):
        self.tasks += list(tasks)
        return super().run(tasks, on_result)


def test_evaluation_starts_from_held_out_warm_states_one_per_episode(small_config, tmp_path):
    episodes = small_config.scenario.snapshots + 1
    with WatchingBackend() as backend:
        evaluate([KeepDriver()], small_config, episode_seeds(Purpose.EVALUATE, 0, episodes), backend)
        evaluate([KeepDriver()], small_config, episode_seeds(Purpose.EVALUATE, 0, 1), backend, pool="validation")
        record_demonstrations(small_config, ExpertDriver("normal"), "normal", 0, 1, backend, tmp_path / "demos.parquet")
    evaluated = [task.start for task in backend.tasks[:episodes]]
    assert {task.pool for task in evaluated} == {"test"}
    assert [task.warm_state for task in evaluated] == [0, 1, 2, 0]  # distinct until the pool is exhausted
    assert backend.tasks[episodes].start.pool == "validation"
    recording = backend.tasks[-1]  # a group of egos on a road reset without options: the train pool, drawn
    assert isinstance(recording, EpisodeGroupTask) and not {"pool", "warm_state"} & set(vars(recording))


def test_reset_options_choose_the_pool_and_state_and_reject_nonsense(small_config):
    env = HighwayEnv(small_config)
    try:
        first, _ = env.reset(seed=7, options={"pool": "test", "warm_state": 1})
        again, _ = env.reset(seed=7, options={"pool": "test", "warm_state": 1})
        other, _ = env.reset(seed=7, options={"pool": "test", "warm_state": 2})
        train, _ = env.reset(seed=7, options={"pool": "train", "warm_state": 1})
        assert (first == again).all() and (first != other).any() and (first != train).any()
        for options, message in (({"pool": "holdout"}, "'pool' must be one of"),
                                 ({"warm_state": 3}, r"'warm_state' must be an integer in \[0, 3\)"),
                                 ({"warm_state": "1"}, "'warm_state' must be an integer"),
                                 ({"speed": 1}, "unknown reset options")):
            with pytest.raises(ValueError, match=message):
                env.reset(seed=7, options=options)
    finally:
        env.close()
